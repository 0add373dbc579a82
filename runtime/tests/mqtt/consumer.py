"""A Sparkplug B host application for runtime/tests/mqtt.rs: subscribes to one edge node's
topics on a real broker and checks what softplc publishes, step by step.

It talks to the Rust test on stdin/stdout: it prints `NEED <action>` when the test must do
something (start softplc, force a tag, restart the broker, kill softplc) and waits for a
line back; `PASS <step>` for each check that held; `FAIL <why>` (and exits 1) otherwise.
Every wait has a deadline. Usage: consumer.py PORT GROUP NODE PB2_DIR
"""

import queue
import sys
import time

sys.path.insert(0, sys.argv[4])

import paho.mqtt.client as mqtt  # noqa: E402
import sparkplug_b_pb2 as spb  # noqa: E402

PORT, GROUP, NODE = int(sys.argv[1]), sys.argv[2], sys.argv[3]
NS = f"spBv1.0/{GROUP}"
BOOLEAN, UINT16, INT32, INT64, UINT64, FLOAT, STRING = 11, 6, 3, 4, 8, 9, 12
WAIT = 20.0

messages = queue.Queue()


def say(line):
    print(line, flush=True)


def fail(why):
    say(f"FAIL {why}")
    sys.exit(1)


def need(action):
    say(f"NEED {action}")
    if sys.stdin.readline().strip() != "done":
        fail(f"the test did not do {action}")


def on_connect(client, userdata, flags, reason, properties):
    client.subscribe(f"{NS}/#", qos=1)
    messages.put(("CONNECTED", None, None))


def on_message(client, userdata, msg):
    p = spb.Payload()
    try:
        p.ParseFromString(msg.payload)
    except Exception as e:  # a payload that is not Sparkplug is a failure of the node
        messages.put(("BAD", msg.topic, str(e)))
        return
    messages.put((msg.topic, p, time.monotonic()))


client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="test-host")
client.on_connect = on_connect
client.on_message = on_message
client.reconnect_delay_set(min_delay=1, max_delay=1)
client.connect("127.0.0.1", PORT, keepalive=5)
client.loop_start()

# Alias -> (name, datatype), from the births.
aliases = {}


def value(m):
    kind = m.WhichOneof("value")
    v = getattr(m, kind) if kind else None
    if m.datatype == INT32 or aliases.get(m.alias, (None, None))[1] == INT32:
        v = v - (1 << 32) if v >= 1 << 31 else v
    return v


def quality(m):
    for k, v in zip(m.properties.keys, m.properties.values):
        if k == "Quality":
            return v.int_value
    return None


def string_property(m, key):
    for k, v in zip(m.properties.keys, m.properties.values):
        if k == key:
            if v.type != STRING:
                fail(f"{m.name}'s {key} property has type {v.type}, not String")
            return v.string_value
    return None


def wait_for(what, pred, timeout=WAIT):
    """The first message (topic, payload) that `pred` accepts, within `timeout`."""
    deadline = time.monotonic() + timeout
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            fail(f"no {what} within {timeout}s")
        try:
            topic, p, _ = messages.get(timeout=left)
        except queue.Empty:
            continue
        if topic == "BAD":
            fail(f"not a Sparkplug payload on {p}: {_}")
        if topic == "CONNECTED":
            if pred(topic, None):
                return topic, None
            continue
        if pred(topic, p):
            return topic, p


def metric(p, name):
    for m in p.metrics:
        if m.name == name:
            return m
    fail(f"no metric {name} in {[m.name for m in p.metrics]}")


def check_births(expect_bd_seq=None):
    _, nb = wait_for("NBIRTH", lambda t, p: t == f"{NS}/NBIRTH/{NODE}")
    if nb.seq != 0:
        fail(f"NBIRTH seq {nb.seq}, not 0")
    bd = metric(nb, "bdSeq")
    if bd.datatype != INT64:
        fail(f"bdSeq datatype {bd.datatype}")
    if expect_bd_seq is not None and bd.long_value != expect_bd_seq:
        fail(f"NBIRTH bdSeq {bd.long_value}, expected {expect_bd_seq}")
    rebirth = metric(nb, "Node Control/Rebirth")
    if rebirth.datatype != BOOLEAN or rebirth.boolean_value or rebirth.HasField("alias"):
        fail("Node Control/Rebirth must be Boolean false without alias")
    for name, dt in [("PLC/Scans", UINT64), ("PLC/Overruns", UINT64),
                     ("PLC/Cycle p99 us", UINT64), ("PLC/State", STRING),
                     ("setpoint", UINT16), ("limit", INT32), ("gain", FLOAT)]:
        m = metric(nb, name)
        if m.datatype != dt or not m.HasField("alias") or not m.HasField("timestamp"):
            fail(f"NBIRTH {name}: datatype {m.datatype} (want {dt}), alias and timestamp needed")
        aliases[m.alias] = (name, dt)
    if metric(nb, "PLC/State").string_value != "running":
        fail("PLC/State is not running in NBIRTH")
    if value(metric(nb, "limit")) != -40:
        fail(f"limit (i32) born as {value(metric(nb, 'limit'))}, not -40")
    # A tag's `description:` is its metric's `description` property in the births.
    got = string_property(metric(nb, "setpoint"), "description")
    if got != "Belt speed, mm/s":
        fail(f"NBIRTH setpoint's description property: {got!r}")
    if string_property(metric(nb, "limit"), "description") is not None:
        fail("NBIRTH limit has a description property, and no description")
    seqs = [0]
    for dev, tags in [("mm1", ["box_at_entry", "start", "stop", "motor"]),
                      ("mm2", ["box_at_exit", "lamp"])]:
        _, db = wait_for(f"DBIRTH {dev}", lambda t, p, d=dev: t == f"{NS}/DBIRTH/{NODE}/{d}")
        seqs.append(db.seq)
        for name in tags:
            m = metric(db, name)
            if m.datatype != BOOLEAN or not m.HasField("alias"):
                fail(f"DBIRTH {dev} {name}: datatype {m.datatype}")
            if quality(m) not in (192, 500, 0):
                fail(f"DBIRTH {dev} {name}: no Quality property")
            aliases[m.alias] = (name, BOOLEAN)
            got = string_property(m, "description")
            want = "Start button, green" if name == "start" else None
            if got != want:
                fail(f"DBIRTH {dev} {name}: description property {got!r}, not {want!r}")
    # Each DBIRTH follows the NBIRTH, its seq one more than the node's message before it: 1
    # and 2 when both modules are up at the birth; a module still stale then (a loaded
    # machine) is born when it answers, after data that took seqs in between.
    if seqs[1] < 1 or seqs[2] <= seqs[1]:
        fail(f"birth seqs {seqs}: each DBIRTH must come after the NBIRTH, in order")
    return bd.long_value


def alias_of(name):
    for a, (n, _) in aliases.items():
        if n == name:
            return a
    fail(f"no alias for {name}")


def ncmd(metrics, topic=None):
    p = spb.Payload(timestamp=int(time.time() * 1000))
    for name, dt, field, v in metrics:
        m = p.metrics.add(name=name, datatype=dt)
        setattr(m, field, v)
    client.publish(topic or f"{NS}/NCMD/{NODE}", p.SerializeToString(), qos=0)


def data_with(topic, alias, pred=lambda v: True):
    def ok(t, p):
        return t == topic and any(m.alias == alias and pred(value(m)) for m in p.metrics)
    return ok


wait_for("the broker", lambda t, p: t == "CONNECTED")
need("start")
bd0 = check_births()
say(f"PASS births bdSeq {bd0}")

# The plant model puts a box on the belt and presses start: inputs of mm1 change.
wait_for("DDATA after an input change",
         lambda t, p: t == f"{NS}/DDATA/{NODE}/mm1"
         and any(m.alias in (alias_of("box_at_entry"), alias_of("start")) and not m.HasField("name")
                 for m in p.metrics))
say("PASS ddata after an input change")

# A write to a writable memory tag is applied and reported by NDATA.
ncmd([("setpoint", UINT16, "int_value", 1234)])
wait_for("NDATA setpoint=1234", data_with(f"{NS}/NDATA/{NODE}", alias_of("setpoint"), lambda v: v == 1234))
say("PASS write applied")

# A write to a tag that is not `scada: write` is refused: no change follows.
ncmd([("limit", INT32, "int_value", 7)])
# A write to a forced tag is refused too.
need("force setpoint 7")
wait_for("NDATA setpoint=7 (forced)", data_with(f"{NS}/NDATA/{NODE}", alias_of("setpoint"), lambda v: v == 7))
ncmd([("setpoint", UINT16, "int_value", 99)])
deadline = time.monotonic() + 2.0
while time.monotonic() < deadline:
    try:
        topic, p, _ = messages.get(timeout=0.1)
    except queue.Empty:
        continue
    if topic != "BAD" and topic != "CONNECTED":
        for m in p.metrics:
            if m.alias == alias_of("setpoint") and value(m) == 99:
                fail("a write to a forced tag was applied")
            if m.alias == alias_of("limit") and value(m) == 7:
                fail("a write to a read-only tag was applied")
say("PASS refused writes not applied")

# Rebirth on command: NBIRTH again, same bdSeq, seq 0, and the DBIRTHs.
ncmd([("Node Control/Rebirth", BOOLEAN, "boolean_value", True)])
check_births(expect_bd_seq=bd0)
say("PASS rebirth")

# The broker restarts: softplc reconnects (a new session: bdSeq + 1 at least), births again,
# and keeps scanning.
need("restart broker")
wait_for("the broker again", lambda t, p: t == "CONNECTED", timeout=30)
bd1 = None
deadline = time.monotonic() + 3.0
while bd1 is None and time.monotonic() < deadline:
    try:
        topic, p, _ = messages.get(timeout=0.1)
    except queue.Empty:
        continue
    if topic == f"{NS}/NBIRTH/{NODE}":
        bd1 = metric(p, "bdSeq").long_value
if bd1 is None:
    # The node was born again before this host was back: ask for a rebirth, as a host does.
    ncmd([("Node Control/Rebirth", BOOLEAN, "boolean_value", True)])
    bd1 = check_births()
if bd1 == bd0:
    fail(f"bdSeq {bd1} unchanged after the broker restart")
scans_alias = alias_of("PLC/Scans")
_, a = wait_for("NDATA PLC/Scans", data_with(f"{NS}/NDATA/{NODE}", scans_alias))
_, b = wait_for("a later NDATA PLC/Scans", data_with(f"{NS}/NDATA/{NODE}", scans_alias))
say(f"PASS broker restart: bdSeq {bd0} -> {bd1}, scanning")

# softplc is killed: the broker publishes its Will, NDEATH with the current bdSeq.
need("kill")
_, d = wait_for("NDEATH after kill", lambda t, p: t == f"{NS}/NDEATH/{NODE}")
if d.HasField("seq"):
    fail("NDEATH carries a seq")
if metric(d, "bdSeq").long_value != bd1:
    fail(f"NDEATH bdSeq {metric(d, 'bdSeq').long_value}, NBIRTH had {bd1}")
say(f"PASS ndeath on kill, bdSeq {bd1}")

# A clean stop: the last DATA says stopped, then NDEATH with the session's bdSeq.
need("start short")
bd2 = check_births()
_, s = wait_for("NDATA PLC/State stopped",
                data_with(f"{NS}/NDATA/{NODE}", alias_of("PLC/State"), lambda v: v == "stopped"))
_, d = wait_for("NDEATH at a clean stop", lambda t, p: t == f"{NS}/NDEATH/{NODE}")
if metric(d, "bdSeq").long_value != bd2:
    fail(f"clean NDEATH bdSeq {metric(d, 'bdSeq').long_value}, NBIRTH had {bd2}")
say("PASS clean stop")
client.loop_stop()
say("DONE")
