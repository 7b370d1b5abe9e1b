"""The checks that lab test cells use say what is wrong, in ROS terms."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from rclpy.node import Node
from std_msgs.msg import Int64, String

from rosbook.labs import lab01 as checks
from rosbook.runtime.session import Session, ros

GOOD_MAIN = """
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node


def main(args=None):
    rclpy.init(args=args)
    node = Node('sleeper')
    node.create_timer(0.1, lambda: print('spinning', flush=True))  # the tests wait for it
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


main()
"""


def test_the_rosout_log_has_lines_logged_before_it_listened(session: Session) -> None:
    early = Node("early_logger")
    for k in range(3):
        early.get_logger().info(f"line {k}")
    log = checks.RosoutLog()
    try:
        ros.spin_until(lambda: len(log.of("early_logger")) >= 3, timeout=30.0)  # a hang guard
        assert log.of("early_logger") == ["line 0", "line 1", "line 2"]
    finally:
        log.close()


def test_wrong_topic_name_is_named(session: Session) -> None:
    node = Node("pub")
    node.create_publisher(Int64, "count", 10)
    with pytest.raises(AssertionError, match=r"no publisher on /counter .*its publishers: /count"):
        checks.node_publishes(node, "counter", Int64)


def test_wrong_type_is_named(session: Session) -> None:
    node = Node("pub")
    node.create_publisher(String, "counter", 10)
    with pytest.raises(
        AssertionError, match=r"std_msgs/msg/String, but the task asks for std_msgs/msg/Int64"
    ):
        checks.node_publishes(node, "counter", Int64)


def test_silent_topic_explains_the_graph(session: Session) -> None:
    Node("other").create_publisher(Int64, "elsewhere", 10)
    probe = checks.Probe("counter", Int64)
    with pytest.raises(AssertionError, match=r"no publisher on /counter.*/elsewhere"):
        probe.wait_for_publisher(timeout=0.5)


def test_a_match_the_graph_shows_coming_is_waited_for_then_a_timeout_not_wrong(
    session: Session, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Past the first limit, a probe waits on only for a publisher the graph shows will
    match (right type, compatible QoS), and says "timeout" when that never happens; a
    publisher whose QoS cannot match is not waited for. (A match that never comes stands
    in for one slowed past every limit.)"""
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from rosbook.labs import probes

    monkeypatch.setattr(probes, "MATCH_GUARD_S", 0.5)
    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    reliable = QoSProfile(depth=10)
    Node("late_talker").create_publisher(Int64, "counter", best_effort)
    probe = Node("probe_counter")

    def never() -> bool:
        return False

    said = r"timeout: node 'late_talker' has a publisher on /counter \(std_msgs/msg/Int64\) "
    with pytest.raises(TimeoutError, match=said + r".* did not match within 0.7 s"):
        probes.await_match(probe, "/counter", Int64, best_effort, never, timeout=0.2)
    assert not probes.await_match(probe, "/counter", Int64, reliable, never, timeout=0.2)
    assert not probes.await_match(probe, "/counter", String, best_effort, never, timeout=0.2)


@pytest.mark.parametrize(
    ("got", "message"),
    [
        ([], "nothing was received"),
        ([2, 1, 0], "right values in the wrong order"),
        ([0, 1], "received 2 messages, expected 3"),
        ([5, 5, 5], "expected [0, 1, 2], got [5, 5, 5]"),
    ],
)
def test_sequence_mismatch_messages(got: list[int], message: str) -> None:
    with pytest.raises(AssertionError, match=re.escape(message)):
        checks.assert_sequence("x", got, [0, 1, 2])


def spinning(run: checks.ScriptRun) -> None:
    """Wait until the script spins (its timer printed): Ctrl-C then reaches rclpy's
    handler, not an import still under way."""
    assert run.proc.stdout is not None
    line = run.proc.stdout.readline()  # the script's own end (EOF) stops a hang
    assert line == "spinning\n", f"the script did not start spinning: {line!r}"


def test_clean_ctrl_c_passes(tmp_path: Path) -> None:
    script = tmp_path / "good.py"
    script.write_text(GOOD_MAIN)
    with checks.run_script(script) as run:
        spinning(run)
        checks.assert_clean_exit(run)


def test_old_ctrl_c_pattern_fails_with_the_jazzy_hint(tmp_path: Path) -> None:
    script = tmp_path / "bad.py"
    script.write_text(
        GOOD_MAIN.replace(
            "(KeyboardInterrupt, ExternalShutdownException)", "KeyboardInterrupt"
        ).replace("rclpy.try_shutdown()", "rclpy.shutdown()")
    )
    with checks.run_script(script) as run:
        spinning(run)
        with pytest.raises(AssertionError, match="ExternalShutdownException"):
            checks.assert_clean_exit(run)


def test_missing_script_is_named(tmp_path: Path) -> None:
    with pytest.raises(AssertionError, match="did you run the %%writefile cell"):
        with checks.run_script(tmp_path / "talker.py"):
            pass


def test_script_that_crashes_at_start_is_reported_with_its_output(
    session: Session, tmp_path: Path
) -> None:
    script = tmp_path / "talker.py"
    script.write_text("# YOUR CODE HERE\nraise NotImplementedError()\n")
    probe = checks.Probe("chatter", String)
    died = r"(?s)exited by itself with code 1.*NotImplementedError"
    with pytest.raises(AssertionError, match=died):
        with checks.run_script(script) as run:
            checks.wait_for_script_publisher(run, probe)


def test_unfinished_constructor_says_the_task_is_not_done(session: Session) -> None:
    class Stub(Node):
        def __init__(self) -> None:
            raise NotImplementedError()

    with pytest.raises(AssertionError, match=r"^Stub\(\): this task is not done yet"):
        checks.make_node(Stub)
