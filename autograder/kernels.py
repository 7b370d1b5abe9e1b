"""The kernel manager the grader and the self-check run notebooks with.

jupyter_client's default transport is TCP on localhost: it picks five free ports, then
the kernel binds them, so two kernels starting at once (``--workers 2``) can race for
a port and one dies with "Address already in use"; and ipykernel warns on the terminal
that the connection is not encrypted. Over Unix sockets (``ipc``) neither happens. The
sockets must be named by an absolute path (by default they are relative to the
process's folder, and the kernel runs in the notebook's): this manager names them
after its connection file, which is unique per kernel.
"""

from __future__ import annotations

import os
import tempfile
import uuid

from jupyter_client import AsyncKernelManager
from jupyter_core.paths import jupyter_runtime_dir
from traitlets import default

#: Longest path a Unix socket may have (sun_path is 108 bytes on Linux), with room for
#: the "-ipc-<n>" the sockets add to the connection file's name.
_SOCKET_PATH_MAX = 100


class IpcKernelManager(AsyncKernelManager):
    """An ``AsyncKernelManager`` on Unix sockets named after its own connection file."""

    @default("transport")
    def _transport_default(self) -> str:
        return "ipc"

    @default("connection_file")
    def _connection_file_default(self) -> str:
        name = f"kernel-{uuid.uuid4()}.json"
        folder = jupyter_runtime_dir()
        if len(os.path.join(folder, name)) > _SOCKET_PATH_MAX:
            folder = tempfile.gettempdir()
        os.makedirs(folder, exist_ok=True)
        return os.path.join(folder, name)
