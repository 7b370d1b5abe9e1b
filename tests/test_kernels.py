"""autograder.kernels and rosbook.runtime.kernels: each kernel's sockets are its own
absolute Unix socket paths."""

from __future__ import annotations

import os
from pathlib import Path

import psutil

from autograder.config import nbgrader_config
from autograder.kernels import IpcKernelManager
from rosbook.runtime.kernels import UnixSocketKernelManager


def test_each_kernel_gets_absolute_unique_socket_paths(tmp_path) -> None:
    a, b = IpcKernelManager(), IpcKernelManager()
    assert a.transport == b.transport == "ipc"
    assert os.path.isabs(a.ip) and os.path.isabs(b.ip)
    assert a.ip != b.ip and a.connection_file != b.connection_file
    assert len(a.ip) + len("-65535") < 108  # a Unix socket path must fit sun_path


def test_the_course_config_runs_notebooks_with_it(tmp_path) -> None:
    config = nbgrader_config(tmp_path)
    assert config.Execute.kernel_manager_class == "autograder.kernels.IpcKernelManager"


def test_a_plain_kernel_listens_on_unix_sockets_and_leaves_no_folder() -> None:
    """The book's chapters and the tests' own kernels (``rosbook.runtime.kernels``): a
    TCP kernel binds ports its manager found free a moment before, which another process
    can take in between ("Address already in use": the kernel dies as it starts). Its
    five channels are files in the manager's folder instead."""
    km = UnixSocketKernelManager()
    km.start_kernel()
    folder = Path(km.connection_file).parent
    try:
        client = km.client()
        client.start_channels()
        client.wait_for_ready(timeout=60)
        reply = client.execute_interactive("print('hello')", timeout=60)
        assert reply["content"]["status"] == "ok", reply["content"]
        client.stop_channels()
        kernel = psutil.Process(km.provisioner.process.pid)  # type: ignore[union-attr]
        channels = {str(folder / f"k-{i}") for i in range(1, 6)}
        assert channels <= {c.laddr for c in kernel.net_connections(kind="unix")}
    finally:
        km.shutdown_kernel(now=True)
    assert not folder.exists()
