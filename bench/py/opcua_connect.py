"""The connection the plant-services scenario's asyncua clients share: retried until softplc's
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
