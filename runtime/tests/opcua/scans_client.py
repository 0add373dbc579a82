"""A third-party OPC UA client (asyncua) reading the PLC's scan counts and tag values.

Usage: scans_client.py URL NAMESPACE_URI TASKS TAGS
TASKS and TAGS are comma-separated names (TASKS may be empty: a PLC of one task). Connects,
says "READY", then for every line "read" on stdin reads, in one Read request, PLC.Scans,
each task's PLC.Tasks.TASK.Scans and each tag's value (Tags.NAME) and prints them as one JSON
object on a line ({"PLC.Scans": 7, "PLC.Tasks.main.Scans": 7, "Tags.n": 7, ...}; a value not
good yet is null). "quit" ends it with "DONE". A failure prints "FAIL why".
"""

import asyncio
import json
import sys

from asyncua import Client

URL, NS_URI = sys.argv[1], sys.argv[2]
TASKS = [t for t in sys.argv[3].split(",") if t]
TAGS = [t for t in sys.argv[4].split(",") if t]


def say(line):
    print(line, flush=True)


async def main():
    async with Client(URL) as client:
        ns = await client.get_namespace_index(NS_URI)
        ids = ["PLC.Scans"] + [f"PLC.Tasks.{t}.Scans" for t in TASKS] + [f"Tags.{t}" for t in TAGS]
        nodes = [client.get_node(f"ns={ns};s={i}") for i in ids]
        say("READY")
        loop = asyncio.get_running_loop()
        while True:
            line = (await loop.run_in_executor(None, sys.stdin.readline)).strip()
            if line in ("", "quit"):
                break
            values = [dv.Value.Value if dv.StatusCode.is_good() else None
                      for dv in await client.read_attributes(nodes)]
            say(json.dumps({i: (v if isinstance(v, (int, float, bool)) or v is None else str(v))
                            for i, v in zip(ids, values)}))
    say("DONE")


try:
    asyncio.run(main())
except Exception as e:  # the test reads this line, not a traceback
    say(f"FAIL {type(e).__name__}: {e}")
