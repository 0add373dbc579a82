"""Third-party clients for runtime/tests/plant_view.rs: what a SCADA (OPC UA, asyncua) and a
Sparkplug host (paho-mqtt with Eclipse Tahu's sparkplug_b.proto) see of softplc's tags.

Usage:
  client.py opcua-quality URL NAMESPACE_URI TAG...
      each TAG's status once the server has values: prints "QUALITY tag StatusName".
  client.py opcua-count URL NAMESPACE_URI TAG PERIOD_MS SECONDS
      subscribes to TAG (sampling interval 0, queue 100, publishing every PERIOD_MS), collects
      its notifications for SECONDS and prints "COUNT received first last missing overflow".
  client.py opcua-write-read URL NAMESPACE_URI TAG N
      writes TAG (a UInt16) the values 1..=N, reading it straight after each Good answer:
      "WRITES n old k", k the reads that returned anything but the value just written.
  client.py opcua-sessions URL N
      opens N sessions at once: "SESSIONS ok k refused r", r refused BadTooManySessions.
  client.py opcua-status URL NAMESPACE_URI TAG
      subscribes to TAG twice, without a filter and with a StatusValueTimestamp
      DataChangeFilter; once both report Good it asks the test to kill the device ("NEED
      kill") and prints "STATUS filterless Name" and "STATUS timestamp Name" with the first
      status other than Good each reports after that.
  client.py sparkplug-quality PORT GROUP NODE PB2_DIR TAG...
      follows the births and DATA of the node's devices for a few seconds: "QUALITY tag code"
      for the quality each TAG has in the host's view at the end, "BIRTH tag code" as its
      DBIRTH gave it, and "ENGUNIT tag unit" when the DBIRTH gave it an engUnit.
  client.py sparkplug-order PORT GROUP NODE PB2_DIR RUNS
      follows the node's births and deaths while the test starts softplc RUNS times, one
      after the other ("NEED runs", then a line back when they are over): "ORDER births b
      deaths d early e", e the NDEATHs that came while the node had no NBIRTH out.
  client.py sparkplug-state PORT GROUP NODE PB2_DIR HOST_ID
      plays the primary host HOST_ID: its STATE offline (the test then starts softplc: "NEED
      start"), online, offline, online again, then offline with an older timestamp; prints
      what the node did after each: "BEFORE births n", "ONLINE birth bdSeq", "OFFLINE death
      bdSeq", "BACK birth bdSeq", "STALE deaths n".
  client.py sparkplug-count PORT GROUP NODE PB2_DIR TAG SECONDS
      counts every value of TAG in NDATA (and the historical ones after a birth) for SECONDS:
      "COUNT received first last missing out_of_order".

Speaks on stdout: "READY" once subscribed, result lines, "FAIL why" (exit 1).
"""

import asyncio
import sys
import time


def say(line):
    print(line, flush=True)


def fail(why):
    say(f"FAIL {why}")
    sys.exit(1)


def gaps(values):
    """(missing, out_of_order) in a run of consecutive integers."""
    missing = out_of_order = 0
    for a, b in zip(values, values[1:]):
        if b > a + 1:
            missing += b - a - 1
        elif b <= a:
            out_of_order += 1
    return missing, out_of_order


async def opcua_connect(url):
    from asyncua import Client, ua

    deadline = time.monotonic() + 20
    while True:
        c = Client(url=url, timeout=5)
        try:
            await c.connect()
            return c
        except (OSError, asyncio.TimeoutError, ua.UaError):
            if time.monotonic() > deadline:
                fail(f"cannot connect to {url}")
            await asyncio.sleep(0.1)


async def opcua_quality(url, ns_uri, tags):
    from asyncua import ua

    c = await opcua_connect(url)
    try:
        ns = await c.get_namespace_index(ns_uri)
        for tag in tags:
            node = c.get_node(ua.NodeId(f"Tags.{tag}", ns))
            deadline = time.monotonic() + 20
            while True:
                dv = await node.read_data_value(raise_on_bad_status=False)
                if dv.StatusCode.value != ua.StatusCodes.BadWaitingForInitialData:
                    break
                if time.monotonic() > deadline:
                    fail(f"{tag}: no value from the scan within 20 s")
                await asyncio.sleep(0.05)
            say(f"QUALITY {tag} {dv.StatusCode.name}")
    finally:
        await c.disconnect()


class Collect:
    def __init__(self):
        self.values = []
        self.overflow = 0

    def datachange_notification(self, node, val, data):
        status = data.monitored_item.Value.StatusCode
        # The Overflow InfoBit (OPC 10000-4 §7.39.1): bits 10 (InfoType DataValue) and 7.
        if status.value & 0x480 == 0x480:
            self.overflow += 1
        if isinstance(val, int):
            self.values.append(val)


async def opcua_count(url, ns_uri, tag, period_ms, seconds):
    from asyncua import ua

    c = await opcua_connect(url)
    try:
        ns = await c.get_namespace_index(ns_uri)
        node = c.get_node(ua.NodeId(f"Tags.{tag}", ns))
        handler = Collect()
        sub = await c.create_subscription(period_ms, handler)
        await sub.subscribe_data_change([node], sampling_interval=0, queuesize=100)
        say("READY")
        await asyncio.sleep(seconds)
        await sub.delete()
        values = handler.values[1:]  # the first is the value at subscription
        if len(values) < 2:
            fail(f"{tag}: {len(values)} notifications in {seconds} s")
        missing, _ = gaps(values)
        say(f"COUNT {len(values)} {values[0]} {values[-1]} {missing} {handler.overflow}")
    finally:
        await c.disconnect()


async def opcua_write_read(url, ns_uri, tag, n):
    from asyncua import ua

    c = await opcua_connect(url)
    try:
        ns = await c.get_namespace_index(ns_uri)
        node = c.get_node(ua.NodeId(f"Tags.{tag}", ns))
        old = 0
        for v in range(1, n + 1):
            await node.write_value(ua.DataValue(ua.Variant(v, ua.VariantType.UInt16)))
            if await node.read_value() != v:
                old += 1
        say(f"WRITES {n} old {old}")
    finally:
        await c.disconnect()


async def opcua_sessions(url, n):
    from asyncua import Client, ua

    opened, ok, refused = [], 0, 0
    for _ in range(n):
        c = Client(url=url, timeout=5)
        try:
            await c.connect()
            opened.append(c)
            ok += 1
        except ua.UaStatusCodeError as e:
            if e.code != ua.StatusCodes.BadTooManySessions:
                fail(f"session refused with {ua.StatusCode(e.code).name}")
            refused += 1
    say(f"SESSIONS ok {ok} refused {refused}")
    for c in opened:
        await c.disconnect()


class Statuses:
    def __init__(self):
        self.q = asyncio.Queue()

    def datachange_notification(self, node, val, data):
        self.q.put_nowait(data.monitored_item.Value.StatusCode)

    async def first(self, want_good, within):
        deadline = time.monotonic() + within
        while (left := deadline - time.monotonic()) > 0:
            try:
                status = await asyncio.wait_for(self.q.get(), left)
            except asyncio.TimeoutError:
                break
            if status.is_good() == want_good:
                return status
        return None


def code_name(status):
    """The name of a StatusCode's code, without its info bits (OPC UA Part 4, 7.39: the low 16
    bits). With a queue of one, a status that changes twice within a publishing interval arrives
    with the Overflow bit set, and asyncua names any code it cannot look up just "Bad"."""
    from asyncua import ua

    return ua.StatusCode(status.value & 0xFFFF0000).name


async def opcua_status(url, ns_uri, tag):
    from asyncua import ua

    c = await opcua_connect(url)
    try:
        ns = await c.get_namespace_index(ns_uri)
        node = c.get_node(ua.NodeId(f"Tags.{tag}", ns))
        plain, stamped = Statuses(), Statuses()
        sub = await c.create_subscription(50, plain)
        await sub.subscribe_data_change([node], sampling_interval=0)
        sub2 = await c.create_subscription(50, stamped)
        trigger = ua.DataChangeFilter(Trigger=ua.DataChangeTrigger.StatusValueTimestamp)
        await sub2._subscribe([node], ua.AttributeIds.Value, trigger, sampling_interval=0)
        for name, h in [("filterless", plain), ("timestamp", stamped)]:
            if await h.first(True, 20) is None:
                fail(f"{name}: {tag} never reported Good")
        say("READY")
        say("NEED kill")
        await asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)
        for name, h in [("filterless", plain), ("timestamp", stamped)]:
            status = await h.first(False, 30)
            say(f"STATUS {name} {code_name(status) if status else 'none'}")
    finally:
        await c.disconnect()


def sparkplug(port, group, node, pb2_dir, rebirth=True):
    """A connected paho client subscribed to the node's topics, and the queue of messages."""
    import queue

    sys.path.insert(0, pb2_dir)
    import paho.mqtt.client as mqtt
    import sparkplug_b_pb2 as spb

    messages = queue.Queue()

    def on_connect(client, userdata, flags, reason, properties):
        client.subscribe(f"spBv1.0/{group}/#", qos=1)
        messages.put(("CONNECTED", None))

    def on_message(client, userdata, msg):
        p = spb.Payload()
        p.ParseFromString(msg.payload)
        messages.put((msg.topic, p))

    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"plant-view-{time.time_ns()}")
    client.on_connect = on_connect
    client.on_message = on_message
    # Back within a fraction of a second when a test restarts the broker.
    client.reconnect_delay_set(min_delay=0.1, max_delay=0.2)
    client.connect("127.0.0.1", port, keepalive=5)
    client.loop_start()
    topic, _ = messages.get(timeout=20)
    if topic != "CONNECTED":
        fail("no connection to the broker")
    if not rebirth:
        return client, messages
    # A host that comes after the node's birth asks for one, as a primary host does.
    cmd = spb.Payload()
    cmd.timestamp = int(time.time() * 1000)
    m = cmd.metrics.add()
    m.name = "Node Control/Rebirth"
    m.datatype = 11  # Boolean
    m.boolean_value = True
    client.publish(f"spBv1.0/{group}/NCMD/{node}", cmd.SerializeToString(), qos=0)
    return client, messages


def until(messages, seconds):
    """The (topic, payload) messages that arrive within `seconds`."""
    import queue

    deadline = time.monotonic() + seconds
    while (left := deadline - time.monotonic()) > 0:
        try:
            yield messages.get(timeout=left)
        except queue.Empty:
            return


def quality_of(m):
    for k, v in zip(m.properties.keys, m.properties.values):
        if k == "Quality":
            return v.int_value
    return None


def metric_value(m):
    kind = m.WhichOneof("value")
    return getattr(m, kind) if kind else None


def sparkplug_quality(port, group, node, pb2_dir, tags):
    client, messages = sparkplug(port, group, node, pb2_dir)
    say("READY")
    aliases, view, birth, eng = {}, {}, {}, {}
    births, data = f"spBv1.0/{group}/DBIRTH/{node}/", f"spBv1.0/{group}/DDATA/{node}/"
    for topic, p in until(messages, 8):
        if topic.startswith(births):
            for m in p.metrics:
                aliases[m.alias] = m.name
                if m.name in tags:
                    view[m.name] = quality_of(m)
                    birth.setdefault(m.name, quality_of(m))
                    props = dict(zip(m.properties.keys, m.properties.values))
                    if "engUnit" in props:
                        eng[m.name] = props["engUnit"].string_value
        elif topic.startswith(data):
            for m in p.metrics:
                name = aliases.get(m.alias)
                if name in tags and quality_of(m) is not None:
                    view[name] = quality_of(m)
    client.loop_stop()
    for tag in tags:
        if tag not in birth:
            fail(f"{tag}: no DBIRTH carried it")
        say(f"BIRTH {tag} {birth[tag]}")
        say(f"QUALITY {tag} {view[tag]}")
        if tag in eng:
            say(f"ENGUNIT {tag} {eng[tag]}")


def sparkplug_order(port, group, node, pb2_dir, runs):
    """Counts NBIRTHs and NDEATHs over `runs` starts of the node, each on a fresh broker. The
    test starts one when asked; the next is asked for once this one's NDEATH arrived (or ten
    seconds passed), so restarting the broker never takes an undelivered death with it."""
    client, messages = sparkplug(port, group, node, pb2_dir, rebirth=False)
    say("READY")
    births = deaths = early = 0
    born = False

    def count(batch):
        nonlocal births, deaths, early, born
        for topic, p in batch:
            if topic == f"spBv1.0/{group}/NBIRTH/{node}":
                births += 1
                born = True
            elif topic == f"spBv1.0/{group}/NDEATH/{node}":
                deaths += 1
                if not born:
                    early += 1
                born = False

    for _ in range(runs):
        say("NEED run")
        sys.stdin.readline()
        want = deaths + 1
        deadline = time.monotonic() + 10
        while deaths < want and time.monotonic() < deadline:
            count(until(messages, 0.2))
    count(until(messages, 0.5))
    client.loop_stop()
    if births != runs:
        fail(f"{births} NBIRTHs for {runs} runs ({deaths} NDEATHs, {early} early)")
    say(f"ORDER births {births} deaths {deaths} early {early}")


def bd_seq(p):
    for m in p.metrics:
        if m.name == "bdSeq":
            return m.long_value
    return None


def sparkplug_state(port, group, node, pb2_dir, host_id):
    import json

    client, messages = sparkplug(port, group, node, pb2_dir, rebirth=False)
    topic = f"spBv1.0/STATE/{host_id}"

    def state(online, ts):
        payload = json.dumps({"online": online, "timestamp": ts})
        client.publish(topic, payload, qos=1, retain=True).wait_for_publish(5)

    def first(verb, seconds):
        for t, p in until(messages, seconds):
            if t == f"spBv1.0/{group}/{verb}/{node}":
                return p
        return None

    def count(verb, seconds):
        return sum(1 for t, _ in until(messages, seconds) if t == f"spBv1.0/{group}/{verb}/{node}")

    state(False, 1000)
    say("READY")
    say("NEED start")
    sys.stdin.readline()
    say(f"BEFORE births {count('NBIRTH', 3)}")
    state(True, 2000)
    p = first("NBIRTH", 10)
    say(f"ONLINE birth {bd_seq(p) if p else 'none'}")
    state(False, 3000)
    p = first("NDEATH", 10)
    say(f"OFFLINE death {bd_seq(p) if p else 'none'}")
    state(True, 4000)
    p = first("NBIRTH", 15)
    say(f"BACK birth {bd_seq(p) if p else 'none'}")
    state(False, 3500)
    say(f"STALE deaths {count('NDEATH', 3)}")
    client.publish(topic, b"", qos=1, retain=True).wait_for_publish(5)
    client.loop_stop()


def sparkplug_count(port, group, node, pb2_dir, tag, seconds):
    client, messages = sparkplug(port, group, node, pb2_dir)
    say("READY")
    alias = None
    values = []
    for topic, p in until(messages, seconds):
        if topic == f"spBv1.0/{group}/NBIRTH/{node}":
            for m in p.metrics:
                if m.name == tag:
                    alias = m.alias
        elif topic == f"spBv1.0/{group}/NDATA/{node}" and alias is not None:
            values.extend(metric_value(m) for m in p.metrics if m.alias == alias)
    client.loop_stop()
    # Sparkplug carries an Int32 as its two's complement in a uint32.
    values = [v - (1 << 32) if v >= 1 << 31 else v for v in values]
    if len(values) < 2:
        fail(f"{tag}: {len(values)} values in {seconds} s (alias {alias})")
    missing, out_of_order = gaps(values)
    say(f"COUNT {len(values)} {values[0]} {values[-1]} {missing} {out_of_order}")


def main():
    mode, args = sys.argv[1], sys.argv[2:]
    if mode == "opcua-quality":
        asyncio.run(opcua_quality(args[0], args[1], args[2:]))
    elif mode == "opcua-count":
        asyncio.run(opcua_count(args[0], args[1], args[2], float(args[3]), float(args[4])))
    elif mode == "opcua-write-read":
        asyncio.run(opcua_write_read(args[0], args[1], args[2], int(args[3])))
    elif mode == "opcua-sessions":
        asyncio.run(opcua_sessions(args[0], int(args[1])))
    elif mode == "opcua-status":
        asyncio.run(opcua_status(args[0], args[1], args[2]))
    elif mode == "sparkplug-quality":
        sparkplug_quality(int(args[0]), args[1], args[2], args[3], args[4:])
    elif mode == "sparkplug-order":
        sparkplug_order(int(args[0]), args[1], args[2], args[3], int(args[4]))
    elif mode == "sparkplug-state":
        sparkplug_state(int(args[0]), args[1], args[2], args[3], args[4])
    elif mode == "sparkplug-count":
        sparkplug_count(int(args[0]), args[1], args[2], args[3], args[4], float(args[5]))
    else:
        fail(f"unknown mode {mode}")
    say("DONE")


if __name__ == "__main__":
    main()
