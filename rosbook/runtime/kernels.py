"""Jupyter kernels on Unix sockets, so that no other process can take their ports.

jupyter_client gives a TCP kernel five ports that its manager found free (bound, then
closed again) before the kernel binds them. On a busy machine another process can take
one in between (any outgoing connection is given a free port from the same range): the
kernel then dies at start ("Address already in use") and its client waits out its limit.
Seen once in a whole test run's few dozen kernels. A kernel on Unix sockets (``ipc``)
binds files in a folder of its manager's own, which nothing else uses.

``UnixSockets`` goes first among a kernel manager's bases: ``UnixSocketKernelManager``
(blocking) and ``AsyncUnixSocketKernelManager`` are jupyter_client's managers with it.
The folder (``rosbook-kernel-*`` in the temporary folder) holds the connection file and
the sockets, and goes with the kernel's shutdown.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

from jupyter_client import AsyncKernelManager, KernelManager
from traitlets import HasTraits, default


class UnixSockets(HasTraits):
    """A kernel manager's defaults: Unix sockets in a private folder, removed at shutdown."""

    _private: Path | None = None

    @default("transport")
    def _transport_default(self) -> str:
        return "ipc"

    @default("connection_file")
    def _connection_file_default(self) -> str:
        self._private = Path(tempfile.mkdtemp(prefix="rosbook-kernel-", dir=self.private_parent()))
        return str(self._private / "kernel.json")

    def private_parent(self) -> str | None:
        """Where the private folder is made (None: the temporary folder)."""
        return None

    @default("ip")
    def _ip_default(self) -> str:
        return str(Path(self.connection_file).parent / "k")

    async def _async_cleanup_resources(self, restart: bool = False) -> None:
        await super()._async_cleanup_resources(restart)  # type: ignore[misc]
        if not restart and self._private is not None:
            shutil.rmtree(self._private, ignore_errors=True)
            self._private = None


class UnixSocketKernelManager(UnixSockets, KernelManager):
    """jupyter_client's ``KernelManager`` on Unix sockets."""


class AsyncUnixSocketKernelManager(UnixSockets, AsyncKernelManager):
    """jupyter_client's ``AsyncKernelManager`` on Unix sockets."""
