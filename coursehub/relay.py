"""A byte relay between two endpoints: how the course hub crosses a sandbox's network.

A student's server (``coursehub.hub``) runs in a network namespace with only a
loopback of its own, so neither side can reach the other by TCP. Unix sockets are
files, not network objects: a socket in a folder both sides see connects them. An
endpoint is ``tcp:HOST:PORT`` or ``unix:PATH``; each connection accepted on the
listening endpoint is piped, both ways, to a new connection to the other one.

``python -m coursehub.relay LISTEN CONNECT`` (started in a sandbox's network with
``Network.join_argv``) prints ``ready PORT`` once it listens, and ends when its
standard input closes: when the hub that started it stops or dies.
"""

from __future__ import annotations

import asyncio
import contextlib
import sys

CHUNK = 1 << 16


async def _open(endpoint: str) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    kind, _, address = endpoint.partition(":")
    if kind == "unix":
        return await asyncio.open_unix_connection(address)
    host, _, port = address.rpartition(":")
    return await asyncio.open_connection(host, int(port))


async def _pipe(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
    try:
        while data := await reader.read(CHUNK):
            writer.write(data)
            await writer.drain()
        if writer.can_write_eof():
            writer.write_eof()  # a half-close passes through
    except OSError:
        writer.close()


async def serve(listen: str, connect: str) -> asyncio.AbstractServer:
    """Listen on ``listen``; pipe every connection to a new one to ``connect``."""

    async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            up_reader, up_writer = await _open(connect)
        except OSError:
            writer.close()
            return
        try:
            await asyncio.gather(_pipe(reader, up_writer), _pipe(up_reader, writer))
        finally:
            for end in (writer, up_writer):
                end.close()

    kind, _, address = listen.partition(":")
    if kind == "unix":
        return await asyncio.start_unix_server(handle, address)
    host, _, port = address.rpartition(":")
    return await asyncio.start_server(handle, host, int(port))


def port(server: asyncio.AbstractServer) -> int:
    """The TCP port ``server`` listens on (for ``tcp:HOST:0``)."""
    return int(server.sockets[0].getsockname()[1])


async def _main(listen: str, connect: str) -> None:
    server = await serve(listen, connect)
    bound = port(server) if listen.startswith("tcp:") else 0
    print(f"ready {bound}", flush=True)
    loop = asyncio.get_running_loop()
    await loop.run_in_executor(None, sys.stdin.buffer.read)  # returns at EOF
    server.close()


if __name__ == "__main__":
    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(_main(sys.argv[1], sys.argv[2]))
