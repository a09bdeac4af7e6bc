#!/usr/bin/env python3
"""A TCP relay that impairs a link in user space, for kernels without tc netem.

Listens on LISTEN (host:port) and relays each connection to TARGET, delaying every chunk in
each direction by a uniform 100-200 ms (order kept) and, with probability LOSS, holding it back
a further 300 ms as a lost segment's retransmission would. Stops after DURATION seconds.

usage: impair.py LISTEN TARGET [LOSS] [DURATION]
"""
import asyncio
import random
import sys


async def pump(reader, writer, loss):
    release = 0.0
    loop = asyncio.get_running_loop()
    try:
        while True:
            data = await reader.read(65536)
            if not data:
                break
            delay = random.uniform(0.1, 0.2) + (0.3 if random.random() < loss else 0.0)
            # Order-preserving: a chunk never overtakes the one before it.
            release = max(release, loop.time() + delay)
            await asyncio.sleep(max(0.0, release - loop.time()))
            writer.write(data)
            await writer.drain()
    except (ConnectionError, asyncio.CancelledError):
        pass
    finally:
        try:
            writer.close()
        except Exception:
            pass


async def main():
    listen, target = sys.argv[1], sys.argv[2]
    loss = float(sys.argv[3]) if len(sys.argv) > 3 else 0.03
    duration = float(sys.argv[4]) if len(sys.argv) > 4 else 120.0
    lhost, lport = listen.rsplit(":", 1)
    thost, tport = target.rsplit(":", 1)

    async def handle(cr, cw):
        try:
            ur, uw = await asyncio.open_connection(thost, int(tport))
        except OSError:
            cw.close()
            return
        await asyncio.gather(pump(cr, uw, loss), pump(ur, cw, loss))

    server = await asyncio.start_server(handle, lhost, int(lport))
    async with server:
        try:
            await asyncio.wait_for(server.serve_forever(), duration)
        except asyncio.TimeoutError:
            pass


asyncio.run(main())
