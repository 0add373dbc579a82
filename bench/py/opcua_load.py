"""The plant-services scenario's OPC UA client load (asyncua): subscribes to every tag of
softplc's OPC UA server and reads them all again and again, as a SCADA and a historian would.

Usage: opcua_load.py URL NAMESPACE_URI TAG_PREFIX TAG_COUNT PUBLISHING_MS MODE
Tags are TAG_PREFIX0 .. TAG_PREFIX{TAG_COUNT-1}; MODE "subscribe" only subscribes, "read" also
reads every tag in a loop. Prints "READY" once the subscription is
created, then runs until the harness closes standard input and prints
"DONE <notifications> <reads>".
"""

import asyncio
import sys

from opcua_connect import connect_tags

URL, NS_URI, PREFIX = sys.argv[1], sys.argv[2], sys.argv[3]
COUNT, PUBLISHING_MS, MODE = int(sys.argv[4]), float(sys.argv[5]), sys.argv[6]


class Counter:
    def __init__(self):
        self.changes = 0

    def datachange_notification(self, node, val, data):
        self.changes += 1


async def main():
    connected = await connect_tags(URL, NS_URI, PREFIX, COUNT)
    if connected is None:
        return
    client, nodes = connected
    counter = Counter()
    sub = await client.create_subscription(PUBLISHING_MS, counter)
    await sub.subscribe_data_change(nodes, sampling_interval=0)
    print("READY", flush=True)
    stop = asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)
    reads = 0
    if MODE != "read":
        await stop
    while not stop.done():
        # One Read service call for every tag, then the next: the reader never waits.
        await client.read_values(nodes)
        reads += 1
    await client.disconnect()
    print(f"DONE {counter.changes} {reads}", flush=True)


asyncio.run(main())
