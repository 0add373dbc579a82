"""The connection the plant scenarios' asyncua clients share: retried until softplc's
OPC UA server listens (it starts with the PLC), for up to 30 s."""

import asyncio
import time

from asyncua import Client, ua


async def connect(url):
    """A connected client, or None (after printing "FAIL ...") when the server never answered."""
    deadline = time.monotonic() + 30
    while True:
        client = Client(url=url, timeout=5)
        try:
            await client.connect()
            return client
        except (OSError, asyncio.TimeoutError, ua.UaError):
            if time.monotonic() > deadline:
                print(f"FAIL cannot connect to {url}", flush=True)
                return None
            await asyncio.sleep(0.1)


async def connect_tags(url, ns_uri, prefix, count):
    """A connected client and the nodes of tags PREFIX0 .. PREFIX{count-1}, or None."""
    client = await connect(url)
    if client is None:
        return None
    ns = await client.get_namespace_index(ns_uri)
    return client, [client.get_node(ua.NodeId(f"Tags.{prefix}{i}", ns)) for i in range(count)]
