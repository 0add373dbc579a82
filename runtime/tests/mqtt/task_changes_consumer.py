"""A Sparkplug B host application counting the changes of a PLC of several tasks.

Usage: task_changes_consumer.py PORT GROUP NODE PB2_DIR SECONDS
The PLC's first task `slow` toggles `slow_toggle` every cycle and drives sm.Y1 (`slow_lamp`);
the task `fast` counts `count` up every cycle and drives fm.Y1 (`fast_lamp`). Asks the node
for a rebirth until an NBIRTH comes, checks a DBIRTH for each task's module (device) with the
tag bound to it, then takes NDATA for SECONDS and checks every change came: `count` steps by
one from each value to the next, `slow_toggle` alternates, and `held` (which the fast task
toggles every cycle, forced true by the test before this host runs) is true in the NBIRTH and
in no NDATA. Speaks on stdout: "PASS step",
"FAIL why", "DONE". Every wait has a deadline.
"""

import sys
import time

sys.path.insert(0, sys.argv[4])

import sparkplug_b_pb2 as spb  # noqa: E402
from task_host import Host, fail, say  # noqa: E402

PORT, GROUP, NODE, SECONDS = int(sys.argv[1]), sys.argv[2], sys.argv[3], float(sys.argv[5])
host = Host(PORT, GROUP, NODE, "task-changes-host", spb)

deadline = time.monotonic() + 40
births = {}
asked = 0.0
# The NBIRTH and the DBIRTH of both modules, of one birth sequence.
while not ("node" in births and "fm" in births and "sm" in births):
    if time.monotonic() > deadline:
        fail(f"no NBIRTH and DBIRTH of fm and sm: {sorted(births)}")
    if "node" not in births and time.monotonic() - asked > 3:
        host.rebirth()
        asked = time.monotonic()
    got = host.next(0.5)
    if got is None:
        continue
    topic, p = got
    if topic == host.topic("NBIRTH"):
        births = {"node": p}
    elif topic.startswith(host.topic("DBIRTH") + "/") and "node" in births:
        births[topic.rsplit("/", 1)[1]] = p
for device, tag in [("fm", "fast_lamp"), ("sm", "slow_lamp")]:
    names = [m.name for m in births[device].metrics]
    if tag not in names:
        fail(f"DBIRTH {device} does not declare {tag}: {names}")
say("PASS births " + " ".join(sorted(d for d in births if d != "node")))

alias = {m.alias: m.name for m in births["node"].metrics}
values = {"count": [], "slow_toggle": [], "held": []}
for name in values:
    if name not in alias.values():
        fail(f"NBIRTH does not declare {name}")
end = time.monotonic() + SECONDS
while time.monotonic() < end:
    got = host.next(0.2)
    if got is None or got[0] != host.topic("NDATA"):
        continue
    for m in got[1].metrics:
        name = alias.get(m.alias)
        if name == "count":
            values[name].append(m.int_value)
        elif name in ("slow_toggle", "held"):
            values[name].append(m.boolean_value)
count, toggles = values["count"], values["slow_toggle"]
steps = [(b - a) % 65536 for a, b in zip(count, count[1:])]
if len(count) < 2 or any(s != 1 for s in steps):
    fail(f"count did not step by one: {count}")
if len(toggles) < 2 or any(a == b for a, b in zip(toggles, toggles[1:])):
    fail(f"slow_toggle did not alternate: {toggles}")
say(f"PASS changes count {len(count)} slow_toggle {len(toggles)}")
held = next(m for m in births["node"].metrics if m.name == "held")
if not held.boolean_value or values["held"]:
    fail(f"held is not held forced: {held.boolean_value} in the NBIRTH, then {values['held']}")
say("PASS forced")
host.stop()
say("DONE")
