"""``ros2(...)`` in a notebook cell: the command runs in a child process while the
session spins, so a node of the same kernel answers it."""

from __future__ import annotations

import pytest
from rclpy.node import Node
from std_msgs.msg import String

from rosbook.cli.inline import ros2
from rosbook.runtime.session import Session


def test_inline_ros2_reads_more_output_than_a_pipe_holds(session: Session) -> None:
    # A pipe holds 64 KiB: a parent that only waits for its child would leave the child
    # blocked on write until the timeout kills it (return code -9, output cut short).
    blob = "x" * (200 * 1024)
    node = Node("big_params")
    node.declare_parameter("blob", blob)
    result = ros2("param", "get", "/big_params", "blob", timeout=120.0, show=False)
    assert result.returncode == 0, result.stderr[-2000:]
    assert blob in result.stdout
    assert len(result.stdout) > 200 * 1024


# waits out its limit: slow tier
@pytest.mark.slow
def test_inline_ros2_says_timeout_when_the_command_outlives_it(session: Session) -> None:
    # echo waits for a first message from a publisher that never publishes; the limit
    # stops it.
    Node("silent").create_publisher(String, "silent", 10)
    result = ros2("topic", "echo", "/silent", timeout=5.0)
    assert result.returncode != 0
    assert "timeout" in result.stderr.splitlines()[-1]
