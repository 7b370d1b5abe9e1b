"""autograder.kernels: each kernel's sockets are its own absolute Unix socket paths."""

from __future__ import annotations

import os

from autograder.config import nbgrader_config
from autograder.kernels import IpcKernelManager


def test_each_kernel_gets_absolute_unique_socket_paths(tmp_path) -> None:
    a, b = IpcKernelManager(), IpcKernelManager()
    assert a.transport == b.transport == "ipc"
    assert os.path.isabs(a.ip) and os.path.isabs(b.ip)
    assert a.ip != b.ip and a.connection_file != b.connection_file
    assert len(a.ip) + len("-65535") < 108  # a Unix socket path must fit sun_path


def test_the_course_config_runs_notebooks_with_it(tmp_path) -> None:
    config = nbgrader_config(tmp_path)
    assert config.Execute.kernel_manager_class == "autograder.kernels.IpcKernelManager"
