"""A third-party OPC UA client (asyncua) reading softplc's alarms under Objects/Alarms.

Usage: alarms_client.py URL NAMESPACE_URI
Browses Alarms (a folder per alarm with its variables), waits for the test to raise the
alarm `jam` (NEED raise), reads it active and waiting with its severity, text and raise time,
acknowledges it by writing true to its Acknowledge, is refused a second time and for false,
and reads it acknowledged with its time.

Speaks to the test on stdout: "PASS step", "FAIL why", "NEED action" (then waits for a line
on stdin once the test has done it), "DONE".
"""

import asyncio
import sys
import time

from asyncua import Client, ua

URL, NS_URI = sys.argv[1], sys.argv[2]


def say(line):
    print(line, flush=True)


class Fail(Exception):
    pass


def check(ok, why):
    if not ok:
        raise Fail(why)


async def connect_with_retries():
    deadline = time.monotonic() + 20
    while True:
        c = Client(url=URL, timeout=5)
        try:
            await c.connect()
            return c
        except (OSError, asyncio.TimeoutError, ua.UaError):
            check(time.monotonic() < deadline, f"cannot connect to {URL}")
            await asyncio.sleep(0.1)


async def until(read, want, within=10):
    deadline = time.monotonic() + within
    while True:
        try:
            got = await read()
        except ua.UaStatusCodeError:
            got = None
        if got == want:
            return
        check(time.monotonic() < deadline, f"still {got!r}, not {want!r}")
        await asyncio.sleep(0.05)


async def write_status(node, variant):
    try:
        await node.write_value(ua.DataValue(variant))
        return "Good"
    except ua.UaStatusCodeError as e:
        return ua.StatusCode(e.code).name


async def main():
    c = await connect_with_retries()
    try:
        ns = await c.get_namespace_index(NS_URI)
        node = lambda ident: c.get_node(ua.NodeId(ident, ns))
        names = {(await ch.read_browse_name()).Name: ch for ch in await c.nodes.objects.get_children()}
        check("Alarms" in names, f"Objects has no Alarms folder: {sorted(names)}")
        alarms = sorted([(await ch.read_browse_name()).Name for ch in await names["Alarms"].get_children()])
        check(alarms == ["jam", "lost.mm1"], f"Alarms: {alarms}")
        fields = sorted([(await ch.read_browse_name()).Name for ch in await node("Alarms.jam").get_children()])
        check(
            fields == sorted(["Active", "Acknowledged", "Severity", "Text", "RaisedAt", "ClearedAt", "AckedAt", "Acknowledge"]),
            f"jam's variables: {fields}",
        )
        await until(lambda: node("Alarms.jam.Active").read_value(), False, 20)
        raised = await node("Alarms.jam.RaisedAt").read_value()
        check(raised is None or raised.year < 1700, f"never raised, yet RaisedAt {raised!r}")
        say("PASS browse")

        say("NEED raise")
        await asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)
        await until(lambda: node("Alarms.jam.Active").read_value(), True)
        check(await node("Alarms.jam.Acknowledged").read_value() is False, "waiting")
        sev = await node("Alarms.jam.Severity").read_data_value()
        check(sev.Value.VariantType == ua.VariantType.UInt16 and sev.Value.Value == 750, f"Severity {sev.Value}")
        text = await node("Alarms.jam.Text").read_value()
        check(text == "Door jammed", f"Text {text!r}")
        raised = await node("Alarms.jam.RaisedAt").read_value()
        check(raised is not None and raised.year >= 2020, f"RaisedAt {raised!r}")
        say("PASS raised")

        ack = node("Alarms.jam.Acknowledge")
        got = await write_status(ack, ua.Variant(False, ua.VariantType.Boolean))
        check(got == "BadOutOfRange", f"writing false: {got}")
        got = await write_status(ack, ua.Variant(True, ua.VariantType.Boolean))
        check(got == "Good", f"acknowledging: {got}")
        await until(lambda: node("Alarms.jam.Acknowledged").read_value(), True)
        acked = await node("Alarms.jam.AckedAt").read_value()
        check(acked is not None and acked >= raised, f"AckedAt {acked!r} before RaisedAt {raised!r}")
        check(await node("Alarms.jam.Active").read_value() is True, "still active")
        got = await write_status(ack, ua.Variant(True, ua.VariantType.Boolean))
        check(got == "BadInvalidState", f"a second acknowledgement: {got}")
        say("PASS acknowledged")
    finally:
        await c.disconnect()


try:
    asyncio.run(main())
    say("DONE")
except Fail as e:
    say(f"FAIL {e}")
    sys.exit(1)
