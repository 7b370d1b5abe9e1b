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
import os
import stat
import sys
from collections.abc import Callable

CHUNK = 1 << 16


class NotTheSocket(OSError):
    """The unix socket to connect to is a link, not a socket, or someone else's."""


async def _open(
    endpoint: str, owner: int | None = None
) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    kind, _, address = endpoint.partition(":")
    if kind == "unix" and owner is not None:
        # The socket file itself, opened without following a link, checked, and
        # connected through its descriptor: nothing can be swapped in between.
        fd = os.open(address, os.O_PATH | os.O_NOFOLLOW | os.O_CLOEXEC)
        try:
            found = os.fstat(fd)
            if not stat.S_ISSOCK(found.st_mode) or found.st_uid != owner:
                what = "a link" if stat.S_ISLNK(found.st_mode) else "not a socket"
                if stat.S_ISSOCK(found.st_mode):
                    what = f"a socket of uid {found.st_uid}, not of uid {owner}"
                raise NotTheSocket(f"{address}: {what}; refused, never connected to")
            return await asyncio.open_unix_connection(f"/proc/self/fd/{fd}")
        finally:
            os.close(fd)
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


async def serve(
    listen: str,
    connect: str,
    owner: int | None = None,
    refused: Callable[[str], None] | None = None,
) -> asyncio.AbstractServer:
    """Listen on ``listen``; pipe every connection to a new one to ``connect``.

    ``owner``: ``connect`` is a unix socket in a folder someone else can write (a
    student's server's): connect only to a socket, not a link, of that uid (what the
    server made); otherwise the connection is closed and ``refused`` is told why."""

    async def handle(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            up_reader, up_writer = await _open(connect, owner)
        except OSError as exc:
            if isinstance(exc, NotTheSocket) and refused is not None:
                refused(str(exc))
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
