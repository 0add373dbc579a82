"""The plant-services scenario's OPC UA client (asyncua): subscribes to one tag of softplc's
OPC UA server and prints a line the moment each data-change notification arrives.

Usage: opcua_watch.py URL NAMESPACE_URI TAG PUBLISHING_MS
Prints "READY" once the subscription is created, then "CHANGE <value>" per notification.
"""

import asyncio
import sys

from asyncua import ua

from opcua_connect import connect

URL, NS_URI, TAG, PUBLISHING_MS = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])


class Printer:
    def datachange_notification(self, node, val, data):
        print(f"CHANGE {val}", flush=True)


async def main():
    client = await connect(URL)
    if client is None:
        return
    ns = await client.get_namespace_index(NS_URI)
    node = client.get_node(ua.NodeId(f"Tags.{TAG}", ns))
    sub = await client.create_subscription(PUBLISHING_MS, Printer())
    # Sampling interval 0: the server's fastest, which softplc sets to its scan period.
    await sub.subscribe_data_change([node], sampling_interval=0)
    print("READY", flush=True)
    # Until the harness closes standard input.
    await asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)
    await client.disconnect()


asyncio.run(main())
