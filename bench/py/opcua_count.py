"""The plant-load scenario's peer client (asyncua): subscribes to the counter tags of
softplc's OPC UA server with sampling interval 0 and counts every data change the way the
harness's compiled clients do (bench/src/sequence.rs): each tag is a counter that steps by one
at each change, a value above the last one received is a change received; after a tag's first
value, the same value again and a lower one (out of order) are counted apart.

Usage: opcua_count.py URL NAMESPACE_URI TAG_PREFIX TAG_COUNT PUBLISHING_MS QUEUE_SIZE
Prints "READY" once the subscription is created, then runs until the harness closes standard
input and prints "DONE <received> <repeated> <out_of_order> <overflow> <without_value>".
"""

import asyncio
import sys

from opcua_connect import connect_tags

URL, NS_URI, PREFIX = sys.argv[1], sys.argv[2], sys.argv[3]
COUNT, PUBLISHING_MS, QUEUE = int(sys.argv[4]), float(sys.argv[5]), int(sys.argv[6])
# The Overflow InfoBit is bit 7, meaningful with InfoType DataValue (bit 10): OPC 10000-4 §7.39.
OVERFLOW = 0x480


class Counter:
    def __init__(self, tags):
        self.index = {tag: i for i, tag in enumerate(tags)}
        self.last = [0] * len(tags)
        self.seen = [False] * len(tags)
        self.received = self.repeated = self.out_of_order = 0
        self.overflow = self.without_value = 0

    def datachange_notification(self, node, val, data):
        status = data.monitored_item.Value.StatusCode
        if status is not None and status.value & OVERFLOW == OVERFLOW:
            self.overflow += 1
        i = self.index.get(node.nodeid)
        if i is None or not isinstance(val, int):
            self.without_value += 1
            return
        first, self.seen[i] = not self.seen[i], True
        if val > self.last[i]:
            self.received += 1
            self.last[i] = val
        elif val < self.last[i]:
            self.out_of_order += 1
        elif not first:
            self.repeated += 1


async def main():
    connected = await connect_tags(URL, NS_URI, PREFIX, COUNT)
    if connected is None:
        return
    client, nodes = connected
    counter = Counter([n.nodeid for n in nodes])
    sub = await client.create_subscription(PUBLISHING_MS, counter)
    await sub.subscribe_data_change(nodes, queuesize=QUEUE, sampling_interval=0)
    print("READY", flush=True)
    await asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)
    await client.disconnect()
    c = counter
    print(
        f"DONE {c.received} {c.repeated} {c.out_of_order} {c.overflow} {c.without_value}",
        flush=True,
    )


asyncio.run(main())
