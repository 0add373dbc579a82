"""A third-party OPC UA client (asyncua) counting the changes of a PLC of several tasks.

Usage: task_changes_client.py URL NAMESPACE_URI SECONDS
The PLC's first task `slow` toggles `slow_toggle` every cycle; the task `fast` counts `count`
up every cycle; the test forced `held` (the fast task's) before this client runs. Checks that
Modules lists both tasks' modules, each with its live status (good, requests growing); then
subscribes to `count` and `slow_toggle` (sampling interval 0) for SECONDS and checks every
change came: `count` steps by one from each value to the next, `slow_toggle` alternates; then
that a write to the forced `held` is refused with BadLocked. Speaks on stdout: "PASS step",
"FAIL why", "DONE".
"""

import asyncio
import sys
import time

from asyncua import Client, ua

URL, NS_URI, SECONDS = sys.argv[1], sys.argv[2], float(sys.argv[3])


def say(line):
    print(line, flush=True)


def fail(why):
    say(f"FAIL {why}")
    sys.exit(1)


class Changes:
    """Every data change notification, per node id, in arrival order."""

    def __init__(self):
        self.values = {}

    def datachange_notification(self, node, val, data):
        self.values.setdefault(node.nodeid.Identifier, []).append(val)


async def good(node, deadline):
    """The node's value once it reads good (Bad_WaitingForInitialData before the first scan)."""
    while True:
        dv = await node.read_data_value(raise_on_bad_status=False)
        if dv.StatusCode.is_good():
            return dv.Value.Value
        if time.monotonic() > deadline:
            fail(f"{node} still {dv.StatusCode}")
        await asyncio.sleep(0.2)


async def main():
    async with Client(URL) as c:
        ns = await c.get_namespace_index(NS_URI)
        node = lambda ident: c.get_node(ua.NodeId(ident, ns))
        modules = sorted([(await m.read_browse_name()).Name for m in await node("Modules").get_children()])
        if modules != ["fm", "sm"]:
            fail(f"Modules holds {modules}, not both tasks' modules")
        deadline = time.monotonic() + 30
        for m in modules:
            while await good(node(f"Modules.{m}.Quality"), deadline) != "good":
                if time.monotonic() > deadline:
                    fail(f"module {m} is not good")
                await asyncio.sleep(0.2)
        first = {m: await good(node(f"Modules.{m}.Requests"), deadline) for m in modules}
        while True:
            now = {m: await good(node(f"Modules.{m}.Requests"), deadline) for m in modules}
            if all(now[m] > first[m] for m in modules):
                break
            if time.monotonic() > deadline:
                fail(f"the modules' requests did not grow: {first} then {now}")
            await asyncio.sleep(0.5)
        say("PASS modules " + " ".join(f"{m}={first[m]}->{now[m]}" for m in modules))

        changes = Changes()
        sub = await c.create_subscription(50, changes)
        await sub.subscribe_data_change(
            [node("Tags.count"), node("Tags.slow_toggle")], sampling_interval=0, queuesize=1000
        )
        await asyncio.sleep(SECONDS)
        await sub.delete()
        count = changes.values.get("Tags.count", [])
        steps = [(b - a) % 65536 for a, b in zip(count, count[1:])]
        if len(count) < 2 or any(s != 1 for s in steps):
            fail(f"count did not step by one: {count}")
        toggles = changes.values.get("Tags.slow_toggle", [])
        if len(toggles) < 2 or any(a == b for a, b in zip(toggles, toggles[1:])):
            fail(f"slow_toggle did not alternate: {toggles}")
        say(f"PASS changes count {len(count)} slow_toggle {len(toggles)}")

        try:
            await node("Tags.held").write_value(ua.DataValue(ua.Variant(False, ua.VariantType.Boolean)))
            status = "Good"
        except ua.UaStatusCodeError as e:
            status = ua.StatusCode(e.code).name
        if status != "BadLocked":
            fail(f"write to the forced held: {status}")
        say("PASS forced")
    say("DONE")


asyncio.run(main())
