"""A Sparkplug B host application reading each task's node metrics of a PLC of several tasks.

Usage: tasks_consumer.py PORT GROUP NODE PB2_DIR TASK...
Subscribes to the group, asks the node for a rebirth (NCMD Node Control/Rebirth) until an
NBIRTH comes, checks it declares Tasks/TASK/Scans (and the other fields) for every TASK, then
waits for NDATA raising every TASK's Scans by alias. Speaks on stdout: "PASS step",
"FAIL why", "DONE". Every wait has a deadline.
"""

import sys
import time

sys.path.insert(0, sys.argv[4])

import sparkplug_b_pb2 as spb  # noqa: E402
from task_host import Host, fail, say  # noqa: E402

PORT, GROUP, NODE, TASKS = int(sys.argv[1]), sys.argv[2], sys.argv[3], sys.argv[5:]
FIELDS = ["Scans", "Overruns", "Cycle p50 us", "Cycle p99 us", "Cycle max us", "Lateness p99 us"]
host = Host(PORT, GROUP, NODE, "tasks-host", spb)

deadline = time.monotonic() + 40
birth = host.birth()

declared = {m.name: m for m in birth.metrics}
for t in TASKS:
    for f in FIELDS:
        name = f"Tasks/{t}/{f}"
        if name not in declared:
            fail(f"NBIRTH does not declare {name}: {sorted(declared)}")
        if declared[name].datatype != 8:
            fail(f"{name} is not UInt64")
say("PASS birth")
alias = {declared[f"Tasks/{t}/Scans"].alias: t for t in TASKS}
first = {t: declared[f"Tasks/{t}/Scans"].long_value for t in TASKS}
grown = {}
while len(grown) < len(TASKS):
    if time.monotonic() > deadline:
        fail(f"NDATA did not raise every task's Scans: {first}, then {grown}")
    got = host.next(0.5)
    if got is None or got[0] != host.topic("NDATA"):
        continue
    for m in got[1].metrics:
        t = alias.get(m.alias)
        if t is not None and m.long_value > first[t]:
            grown[t] = m.long_value
say("PASS data " + " ".join(f"{t}={first[t]}->{grown[t]}" for t in TASKS))
host.stop()
say("DONE")
