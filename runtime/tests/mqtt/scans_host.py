"""A Sparkplug B host application checking that a node's scan counts are its counters' cycles.

Usage: scans_host.py PORT GROUP NODE PB2_DIR SECONDS TASK:TAG,...
Each TASK of the PLC counts its own cycles into TAG (the first task's is also `PLC/Scans`).
Asks the node for a rebirth until an NBIRTH comes, where `PLC/Scans` and each
`Tasks/TASK/Scans` must equal their counter. Then, for SECONDS, in every NDATA that carries a
scan count, the count must equal its counter as the host holds it after that NDATA (the
counter's latest value in it, or from an earlier message), with the same timestamp: the
cycle's end. Historical metrics (sent after a birth) are history, not current values.
Speaks on stdout: "PASS births", "PASS ndata NAME=K ..." (how many times each count was
checked), "FAIL why", "DONE". Every wait has a deadline.
"""

import sys
import time

sys.path.insert(0, sys.argv[4])

import sparkplug_b_pb2 as spb  # noqa: E402
from task_host import Host, fail, say  # noqa: E402

PORT, GROUP, NODE, SECONDS = int(sys.argv[1]), sys.argv[2], sys.argv[3], float(sys.argv[5])
PAIRS = [p.split(":") for p in sys.argv[6].split(",")]
# Each scan count's metric name and the counter tag it must equal.
COUNTS = {"PLC/Scans": PAIRS[0][1]}
COUNTS.update({f"Tasks/{task}/Scans": tag for task, tag in PAIRS})
host = Host(PORT, GROUP, NODE, "scans-host", spb)


def value(m):
    """A count's or a counter's value: UInt64 metrics are long_value, Int32 int_value."""
    return m.long_value if m.WhichOneof("value") == "long_value" else m.int_value


birth = host.birth()
alias = {m.alias: m.name for m in birth.metrics}
# What the host holds of each counter: (value, timestamp).
held = {m.name: (value(m), m.timestamp) for m in birth.metrics if m.name in COUNTS.values()}
for m in birth.metrics:
    if m.name in COUNTS and value(m) != held[COUNTS[m.name]][0]:
        fail(f"NBIRTH: {m.name} is {value(m)}, {COUNTS[m.name]} {held[COUNTS[m.name]][0]}")
missing = sorted(set(COUNTS) - {m.name for m in birth.metrics})
if missing:
    fail(f"NBIRTH does not declare {missing}")
say("PASS births")

checked = {name: 0 for name in COUNTS}
end = time.monotonic() + SECONDS
while time.monotonic() < end:
    got = host.next(0.2)
    if got is None or got[0] != host.topic("NDATA"):
        continue
    counts = []
    for m in got[1].metrics:
        name = alias.get(m.alias)
        if m.is_historical:
            continue
        if name in held:
            held[name] = (value(m), m.timestamp)
        elif name in COUNTS:
            counts.append((name, value(m), m.timestamp))
    for name, count, stamp in counts:
        tag = COUNTS[name]
        if (count, stamp) != held[tag]:
            fail(f"NDATA seq {got[1].seq}: {name} is {count} at {stamp}, "
                 f"{tag} {held[tag][0]} at {held[tag][1]}")
        checked[name] += 1
say("PASS ndata " + " ".join(f"{name}={k}" for name, k in sorted(checked.items())))
host.stop()
say("DONE")
