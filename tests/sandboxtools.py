"""Running code in the grader's sandbox from a test: the environment of a ROS program
there, and a script run inside with a seed folder."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from autograder import sandbox
from rosbook.runtime.isolation import BASE_ENV, child_env


def ros_env(domain: int = 7) -> dict[str, str]:
    """The environment of a ROS program the tests run in a sandbox, in ``domain``."""
    return {**child_env(), **BASE_ENV, "ROS_DOMAIN_ID": str(domain)}


def run_inside(
    code: str,
    tmp_path: Path,
    private: Path,
    limits: sandbox.Limits | None = None,
    **env: str,
) -> subprocess.CompletedProcess[str]:
    """``python -c code`` in a sandbox of its own (``private``: the grader's folder for
    it), seeded with a lab folder holding one file; its exit code and output."""
    seed = tmp_path / "lab"
    seed.mkdir(exist_ok=True)
    (seed / "given.txt").write_text("a file of the lab")
    with sandbox.Network() as net:
        launch = sandbox.prepare(
            [sys.executable, "-c", code],
            network=net,
            private=private,
            env={**ros_env(), **env},
            seed=seed,
            limits=limits or sandbox.Limits(),
        )
        proc, _ = sandbox.start(launch, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        out, _ = proc.communicate(timeout=300)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out.decode(), "")
