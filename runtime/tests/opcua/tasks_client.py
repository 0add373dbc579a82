"""A third-party OPC UA client (asyncua) reading each task's figures of a PLC of several tasks.

Usage: tasks_client.py URL NAMESPACE_URI TASK...
Browses PLC/Tasks, then reads each TASK's Scans (PLC.Tasks.TASK.Scans) until every one has
grown (at most 30 s). Speaks on stdout: "PASS step", "FAIL why", "DONE".
"""

import asyncio
import sys
import time

from asyncua import Client

URL, NS_URI, TASKS = sys.argv[1], sys.argv[2], sys.argv[3:]


def say(line):
    print(line, flush=True)


async def value(node, deadline):
    """The node's value once the server has one (Bad_WaitingForInitialData until the task's
    first statistics reach the services)."""
    while True:
        dv = await node.read_data_value(raise_on_bad_status=False)
        if dv.StatusCode.is_good():
            return dv.Value.Value
        if time.monotonic() > deadline:
            raise TimeoutError(f"{node} still {dv.StatusCode}")
        await asyncio.sleep(0.2)


async def main():
    async with Client(URL) as client:
        ns = await client.get_namespace_index(NS_URI)
        folder = client.get_node(f"ns={ns};s=PLC.Tasks")
        names = sorted([(await c.read_browse_name()).Name for c in await folder.get_children()])
        if names != sorted(TASKS):
            say(f"FAIL PLC/Tasks holds {names}, not {sorted(TASKS)}")
            return
        say("PASS browse")
        scans = lambda t: client.get_node(f"ns={ns};s=PLC.Tasks.{t}.Scans")
        deadline = time.monotonic() + 30
        period = await value(client.get_node(f"ns={ns};s=PLC.Tasks.{TASKS[0]}.Period"), deadline)
        say(f"PASS period {TASKS[0]} {period}")
        first = {t: await value(scans(t), deadline) for t in TASKS}
        while True:
            now = {t: await value(scans(t), deadline) for t in TASKS}
            if all(now[t] > first[t] for t in TASKS):
                say("PASS grow " + " ".join(f"{t}={first[t]}->{now[t]}" for t in TASKS))
                break
            if time.monotonic() > deadline:
                say(f"FAIL scans did not grow: {first} then {now}")
                return
            await asyncio.sleep(0.5)
    say("DONE")


asyncio.run(main())
