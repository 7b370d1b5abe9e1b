"""Run this project's ``ros2`` command from a notebook while the notebook's nodes spin.

A CLI call in a cell blocks the kernel; if the node it talks to lives in the same
kernel, nothing would answer it. ``ros2(...)`` runs the command as a separate process
(as in a terminal next to the notebook) and spins the session until it exits. Its
output is read as it comes (in a thread), so a command that prints more than a pipe
holds (64 KiB on Linux) does not block on a full pipe.
"""

from __future__ import annotations

import subprocess
import sys
import threading

from rosbook.runtime.session import Session, notebook_session


def ros2(
    *args: str, timeout: float = 30.0, show: bool = True, session: Session | None = None
) -> subprocess.CompletedProcess[str]:
    """``ros2 ARGS`` in another process, ``session`` spinning meanwhile; its result.

    ``session`` defaults to the notebook's (``rosbook.ros``). With ``show`` the command
    line and what it printed (stdout, then stderr) are printed. A command still running
    after ``timeout`` seconds of wall time is killed, and its stderr ends with a line
    that says so.
    """
    session = notebook_session(session)
    argv = [sys.executable, "-m", "rosbook.cli", *args]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    output: list[tuple[str, str]] = []
    reader = threading.Thread(target=lambda: output.append(proc.communicate()), daemon=True)
    reader.start()
    session.spin_until(lambda: not reader.is_alive(), timeout=timeout)
    timed_out = reader.is_alive()
    if timed_out:
        proc.kill()
    reader.join()
    out, err = output[0]
    if timed_out:
        err += f"ros2: timeout: still running after {timeout:g} s, stopped\n"
    result = subprocess.CompletedProcess(argv, proc.returncode, out, err)
    if show:
        quoted = " ".join(a if a and " " not in a else repr(a) for a in args)
        print(f"$ ros2 {quoted}\n{out}{err}".rstrip())
    return result
