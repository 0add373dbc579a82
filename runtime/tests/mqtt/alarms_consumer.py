"""A Sparkplug B host for runtime/tests/mqtt.rs's alarm case: it checks the alarms' node
metrics under `Alarms/` in NBIRTH (names, datatypes, aliases, values), then asks the test to
raise an alarm and to acknowledge it (NEED raise, NEED ack) and sees each change in NDATA by
alias. Speaks PASS/FAIL/NEED/DONE on stdout like consumer.py.
Usage: alarms_consumer.py PORT GROUP NODE PB2_DIR
"""

import queue
import sys
import time

sys.path.insert(0, sys.argv[4])

import paho.mqtt.client as mqtt  # noqa: E402
import sparkplug_b_pb2 as spb  # noqa: E402

PORT, GROUP, NODE = int(sys.argv[1]), sys.argv[2], sys.argv[3]
NS = f"spBv1.0/{GROUP}"
BOOLEAN, UINT16, STRING, DATETIME = 11, 6, 12, 13
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
    messages.put(("CONNECTED", None))


def on_message(client, userdata, msg):
    p = spb.Payload()
    p.ParseFromString(msg.payload)
    messages.put((msg.topic, p))


client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="alarm-host")
client.on_connect = on_connect
client.on_message = on_message
client.connect("127.0.0.1", PORT, keepalive=5)
client.loop_start()


def next_message(topic, within=20.0):
    deadline = time.monotonic() + within
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            fail(f"no {topic} within {within}s")
        try:
            t, p = messages.get(timeout=left)
        except queue.Empty:
            continue
        if t == topic:
            return p


def value(m):
    kind = m.WhichOneof("value")
    return getattr(m, kind) if kind else None


next_message("CONNECTED")
need("start")
birth = next_message(f"{NS}/NBIRTH/{NODE}")
by_name = {m.name: m for m in birth.metrics}
want = {
    "Alarms/jam/Active": (BOOLEAN, False),
    "Alarms/jam/Acknowledged": (BOOLEAN, True),
    "Alarms/jam/Severity": (UINT16, 750),
    "Alarms/jam/Text": (STRING, "Door jammed"),
    "Alarms/jam/RaisedAt": (DATETIME, 0),
    "Alarms/jam/ClearedAt": (DATETIME, 0),
    "Alarms/jam/AckedAt": (DATETIME, 0),
    "Alarms/lost.mm1/Active": (BOOLEAN, False),
}
for name, (dt, v) in want.items():
    m = by_name.get(name)
    if m is None:
        fail(f"no {name} in NBIRTH: {sorted(by_name)}")
    if m.datatype != dt or value(m) != v:
        fail(f"{name}: datatype {m.datatype}, value {value(m)!r}; wanted {dt}, {v!r}")
aliases = {by_name[n].alias: n for n in want}
if len(set(aliases)) != len(want):
    fail(f"aliases not unique: {aliases}")
say("PASS birth")


def wait_data(name, v, within=20.0):
    """The NDATA that carries `name` = `v` (by alias); the metric."""
    deadline = time.monotonic() + within
    while True:
        p = next_message(f"{NS}/NDATA/{NODE}", deadline - time.monotonic())
        for m in p.metrics:
            if aliases.get(m.alias) == name and value(m) == v:
                return m


need("raise")
active = wait_data("Alarms/jam/Active", True)
say("PASS raised")
need("ack")
acked = wait_data("Alarms/jam/Acknowledged", True)
if acked.timestamp < active.timestamp:
    fail(f"acknowledged at {acked.timestamp} before it was raised at {active.timestamp}")
say("PASS acknowledged")
say("DONE")
client.loop_stop()
