"""Run this project's ``ros2`` command from a notebook while the notebook's nodes spin.

A CLI call in a cell blocks the kernel; if the node it talks to lives in the same
kernel, nothing would answer it. ``ros2(...)`` runs the command as a separate process
(as in a terminal next to the notebook) and spins the session until it exits.
"""

from __future__ import annotations

import subprocess
import sys

from rosbook.session import ros


def ros2(*args: str, timeout: float = 30.0, show: bool = True) -> subprocess.CompletedProcess[str]:
    """``ros2 ARGS`` in another process, the session spinning meanwhile; its result.

    With ``show`` the command line and what it printed (stdout, then stderr) are printed.
    """
    argv = [sys.executable, "-m", "rosbook.cli", *args]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    ros.spin_until(lambda: proc.poll() is not None, timeout=timeout)
    if proc.poll() is None:
        proc.kill()
    out, err = proc.communicate()
    result = subprocess.CompletedProcess(argv, proc.returncode, out, err)
    if show:
        quoted = " ".join(a if a and " " not in a else repr(a) for a in args)
        print(f"$ ros2 {quoted}\n{out}{err}".rstrip())
    return result
