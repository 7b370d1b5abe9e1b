"""The judge process's life around one submission: started early, ended promptly.

Grading speed depends on both: the judge starts (interpreter, rclpy, ROS) while the
kernel starts rather than at the first judged cell, and it ends as soon as its stdin
closes instead of asking the already shut-down kernel for a last "stop".
"""

from __future__ import annotations

import json
from pathlib import Path

from autograder import judge, sandbox
from autograder.verdicts import judging


def test_the_judge_starts_with_the_submission_before_any_cell() -> None:
    with sandbox.Network() as network, sandbox.using(network):
        with judging("lab01_nodes_topics") as run:
            process = run.process
            assert process is not None and process.poll() is None
            assert run.verdicts == {}
        assert run.process is None and process.poll() is not None  # ended with the block


def test_an_assignment_without_judged_checks_starts_no_judge() -> None:
    """Every lab of the course is judged; an assignment an instructor adds without a
    judge module (its test cells score in the kernel, as nbgrader's do) costs none."""
    assert judge.judged_checks("lab99_new") == {}
    with judging("lab99_new") as run:
        assert run.process is None


def test_closing_a_kernel_sends_it_nothing(tmp_path: Path) -> None:
    """When the judge's stdin closes, the kernel is already gone: a last call would
    only wait out its guard (10 s per submission, every submission)."""
    connection = tmp_path / "kernel.json"
    connection.write_text(
        json.dumps(
            {
                "transport": "ipc",
                "ip": str(tmp_path / "k"),
                "shell_port": 1,
                "iopub_port": 2,
                "stdin_port": 3,
                "control_port": 4,
                "hb_port": 5,
                "key": "",
                "signature_scheme": "hmac-sha256",
            }
        )
    )
    kernel = judge.Kernel(str(connection))
    kernel.agent_ready = True  # as after a check: the agent was defined
    sent: list[dict] = []
    kernel.client.session.send = lambda *a, **k: sent.append({"args": a})  # type: ignore[method-assign]
    kernel.close()
    assert sent == []
