"""The ``ros2`` verbs of the official tutorials, against a live node of this process.

``topic pub | find | bw``, ``service echo | info | find``, ``param dump | load``,
``action type`` and ``doctor``, with upstream's (ros2cli jazzy) options and wording.
One fixture node lives in the test's session: it subscribes, publishes, serves a
service with introspection on, an action and parameters. Commands that need it to
answer run as processes while the session spins (``rosbook.cli.inline.ros2``, or
``Command`` for ones that run until stopped); graph-only commands run in this process.
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import threading
from array import array
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from geometry_msgs.msg import PoseStamped
from rclpy.action import ActionServer
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_services_default
from rclpy.service_introspection import ServiceIntrospectionState
from std_msgs.msg import String
from std_srvs.srv import SetBool
from test_msgs.action import Fibonacci

from rosbook import ros
from rosbook.cli import main
from rosbook.cli.inline import ros2 as ros2_process

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

#: Guards against a hang only: every wait below ends on an event.
HANG_S = 90.0


class VerbsFixture(Node):
    """What the verbs look at: subscriptions, a publisher, a service, an action, parameters."""

    def __init__(self) -> None:
        super().__init__("verbs_fixture")
        self.received: dict[str, list[Any]] = {}
        topics = (("/pub_once", String), ("/pub_stamped", PoseStamped), ("/unheard", String))
        for topic, kind in topics:
            self.create_subscription(kind, topic, self.receiver(topic), 10)
        self.bw_publisher = self.create_publisher(String, "/bw_test", 10)
        self.create_timer(0.05, lambda: self.bw_publisher.publish(String(data="x" * 100)))
        self.toggle = self.create_service(SetBool, "/toggle_test", self.on_toggle)
        self.toggle.configure_introspection(
            self.get_clock(), qos_profile_services_default, ServiceIntrospectionState.CONTENTS
        )
        self.action = ActionServer(self, Fibonacci, "/fib_test", lambda goal: Fibonacci.Result())
        self.declare_parameter("speed", 1.5)
        self.declare_parameter("robot_name", "robot")
        self.declare_parameter("limits.max", 3)
        self.declare_parameter("gains", [1, 2, 3])

    def receiver(self, topic: str) -> Callable[[Any], None]:
        self.received[topic] = []
        return self.received[topic].append

    def on_toggle(self, request: SetBool.Request, response: SetBool.Response) -> Any:
        response.success = True
        response.message = "on" if request.data else "off"
        return response


@pytest.fixture(scope="module")
def fixture_node() -> Iterator[VerbsFixture]:
    ros.init()
    node = ros.add(VerbsFixture())
    yield node
    ros.reset()


def in_process(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """``ros2 ARGV`` in this process (commands that only read the graph)."""
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def run(*argv: str) -> subprocess.CompletedProcess[str]:
    """``ros2 ARGV`` as a process while the session (the fixture node) spins."""
    return ros2_process(*argv, timeout=HANG_S, show=False, session=ros)


class Command:
    """``ros2 ARGV`` as a process that runs until it ends or is stopped, its output
    read as it comes; ``wait_until`` spins the session meanwhile."""

    def __init__(self, *argv: str) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "rosbook.cli", *argv],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        self.lines: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.append(line.rstrip("\n"))

    @property
    def out(self) -> str:
        return "\n".join(self.lines)

    def wait_until(self, condition: Callable[[], bool], what: str) -> None:
        assert ros.spin_until(condition, timeout=HANG_S), f"timeout: {what}; got {self.lines}"

    def finish(self, *, interrupt: bool = False) -> tuple[int, str]:
        """Exit status (after a Ctrl-C when ``interrupt``) and stderr."""
        if interrupt:
            self.process.send_signal(signal.SIGINT)
        self.wait_until(lambda: self.process.poll() is not None, "the command to end")
        self.reader.join()
        assert self.process.stderr is not None
        return self.process.returncode, self.process.stderr.read()


# -- topic pub ----------------------------------------------------------------------
def test_topic_pub_once_is_received_by_a_live_subscriber(fixture_node) -> None:
    result = run("topic", "pub", "--once", "/pub_once", "std_msgs/msg/String", "{data: bar}")
    assert result.returncode == 0, result.stderr
    lines = [ln for ln in result.stdout.splitlines() if not ln.startswith("Waiting for")]
    assert lines == [
        "publisher: beginning loop",
        "publishing #1: std_msgs.msg.String(data='bar')",
        "",
    ]
    got = fixture_node.received["/pub_once"]
    assert ros.spin_until(lambda: got, timeout=HANG_S), "timeout: the subscriber got nothing"
    assert [m.data for m in got] == ["bar"]
    got.clear()


# pub is checked in the fast tier by test_topic_pub_once_is_received_by_a_live_subscriber
@pytest.mark.slow
def test_topic_pub_w_waits_for_a_subscriber_that_appears_later(fixture_node) -> None:
    command = Command(
        "topic", "pub", "-w", "1", "-1", "/pub_late", "std_msgs/msg/String", "{data: late}"
    )
    command.wait_until(lambda: bool(command.lines), "a first line")
    assert command.lines[0] == "Waiting for at least 1 matching subscription(s)..."
    assert "publisher: beginning loop" not in command.lines, "it did not wait"
    got: list[String] = []
    fixture_node.create_subscription(String, "/pub_late", got.append, 10)
    command.wait_until(lambda: bool(got), "the late subscriber to receive")
    assert command.finish() == (0, "")
    assert [m.data for m in got] == ["late"]
    assert "publishing #1: std_msgs.msg.String(data='late')" in command.lines


# pub is checked in the fast tier by test_topic_pub_once_is_received_by_a_live_subscriber
@pytest.mark.slow
def test_topic_pub_times_with_header_auto_stamps_each_message(fixture_node) -> None:
    values = "{header: auto, pose: {position: {x: 1.5}}}"
    result = run(
        "topic",
        "pub",
        "-t",
        "3",
        "-r",
        "20",
        "/pub_stamped",
        "geometry_msgs/msg/PoseStamped",
        values,
    )
    assert result.returncode == 0, result.stderr
    assert re.findall(r"^publishing #(\d)", result.stdout, re.M) == ["1", "2", "3"]
    got = fixture_node.received["/pub_stamped"]
    assert ros.spin_until(lambda: len(got) == 3, timeout=HANG_S), f"timeout: got {len(got)} of 3"
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in got]
    assert 0 < stamps[0] < stamps[1] < stamps[2], "each message stamped when published"
    assert [m.pose.position.x for m in got] == [1.5] * 3
    got.clear()
    result = run(
        "topic",
        "pub",
        "-1",
        "/pub_stamped",
        "geometry_msgs/msg/PoseStamped",
        "{header: {stamp: now, frame_id: map}}",
    )
    assert result.returncode == 0, result.stderr
    assert ros.spin_until(lambda: got, timeout=HANG_S), "timeout: nothing received"
    assert got[0].header.frame_id == "map" and got[0].header.stamp.sec > 0
    got.clear()


def test_topic_pub_reports_a_bad_type_or_values_as_upstream(capsys) -> None:
    assert in_process(capsys, "topic", "pub", "/x", "std_msgs/msg/NoSuchType") == (
        1,
        "",
        "The passed message type is invalid\n",
    )
    assert in_process(capsys, "topic", "pub", "/x", "std_msgs/msg/String", "[1, 2]") == (
        1,
        "",
        "The passed value needs to be a dictionary in YAML format\n",
    )
    status, _, err = in_process(capsys, "topic", "pub", "/x", "std_msgs/msg/String", "{nope: 1}")
    assert status == 1 and err.startswith("Failed to populate field: ")


# -- topic find, bw -----------------------------------------------------------------
def test_topic_find_lists_the_topics_of_a_type(fixture_node, capsys) -> None:
    status, out, _ = in_process(capsys, "topic", "find", "geometry_msgs/msg/PoseStamped")
    assert (status, out) == (0, "/pub_stamped\n")
    status, out, _ = in_process(capsys, "topic", "find", "-c", "std_msgs/msg/String")
    assert status == 0 and int(out) >= 2  # /pub_once, /bw_test
    assert in_process(capsys, "topic", "find", "std_msgs/msg/Empty")[:2] == (0, "\n")


def test_topic_bw_prints_the_bandwidth_as_upstream(fixture_node) -> None:
    command = Command("topic", "bw", "/bw_test")
    command.wait_until(lambda: "Message size" in command.out, "a bandwidth line")
    assert command.finish(interrupt=True) == (0, "")
    assert command.lines[0] == "Subscribed to [/bw_test]"
    rate, sizes = command.lines[1:3]
    assert re.fullmatch(r"\d+(\.\d\d KB| B)/s from \d+ messages", rate), rate
    # Each message is the same 100 characters (with CDR header, length and NUL, 109
    # bytes), in the unit of the rate (KB from 1000 B/s on), as upstream.
    size = re.fullmatch(r"\tMessage size mean: (\S+ K?B) min: \1 max: \1", sizes)
    assert size and size[1] == ("0.11 KB" if "KB/s" in rate else "109 B"), sizes


# -- service echo, info, find -------------------------------------------------------
def test_service_echo_shows_a_real_request_and_response(fixture_node) -> None:
    command = Command("service", "echo", "-n", "2", "/toggle_test")
    command.wait_until(
        lambda: fixture_node.count_subscribers("/toggle_test/_service_event") > 0,
        "service echo to subscribe to the events",
    )
    result = run("service", "call", "/toggle_test", "std_srvs/srv/SetBool", "{data: true}")
    assert result.returncode == 0, result.stderr
    status, err = command.finish()
    assert (status, err) == (0, "")
    events = [yaml.safe_load(block) for block in command.out.split("---") if block.strip()]
    assert [e["info"]["event_type"] for e in events] == ["REQUEST_RECEIVED", "RESPONSE_SENT"]
    assert events[0]["request"] == [{"data": True}] and events[0]["response"] == []
    assert events[1]["response"] == [{"success": True, "message": "on"}]
    assert events[0]["info"]["sequence_number"] == events[1]["info"]["sequence_number"]


def test_service_echo_csv_no_str_prints_a_line_per_event(fixture_node) -> None:
    # ros2service/ros2service/verb/echo.py: --csv (message_to_csv), --no-str
    command = Command("service", "echo", "-n", "2", "--csv", "--no-str", "/toggle_test")
    command.wait_until(
        lambda: fixture_node.count_subscribers("/toggle_test/_service_event") > 0,
        "service echo to subscribe to the events",
    )
    result = run("service", "call", "/toggle_test", "std_srvs/srv/SetBool", "{data: false}")
    assert result.returncode == 0, result.stderr
    assert command.finish() == (0, "")
    received, sent = command.lines
    assert received.startswith("1,") and received.endswith(",False,"), command.lines
    assert sent.startswith("2,") and sent.endswith(",True,<string length: <3>>"), command.lines


# service echo is checked in the fast tier by test_service_echo_shows_a_real_request_and_response
@pytest.mark.slow
def test_service_echo_without_introspection_says_so_and_waits(fixture_node) -> None:
    command = Command("service", "echo", "/verbs_fixture/list_parameters")
    command.wait_until(lambda: bool(command.lines), "a first line")
    assert command.lines[0] == (
        "No publishers on topic '/verbs_fixture/list_parameters/_service_event'; "
        "is service introspection on the client or server enabled?"
    )
    assert command.process.poll() is None, "it keeps waiting, as upstream"
    assert command.finish(interrupt=True) == (0, "")


def test_service_info_counts_clients_and_services(fixture_node, capsys) -> None:
    assert in_process(capsys, "service", "info", "/toggle_test") == (
        0,
        "Type: std_srvs/srv/SetBool\nClients count: 0\nServices count: 1\n",
        "",
    )
    assert in_process(capsys, "service", "info", "/no_such_service") == (
        1,
        "",
        "Unknown service '/no_such_service'\n",
    )


def test_service_find_lists_the_services_of_a_type(fixture_node, capsys) -> None:
    assert in_process(capsys, "service", "find", "std_srvs/srv/SetBool")[:2] == (
        0,
        "/toggle_test\n",
    )
    status, out, _ = in_process(
        capsys, "service", "find", "-c", "rcl_interfaces/srv/ListParameters"
    )
    assert status == 0 and int(out) >= 1
    status, out, _ = in_process(capsys, "service", "find", "test_msgs/srv/Empty")
    assert (status, out) == (0, "\n")


# -- param dump, load ---------------------------------------------------------------
DUMPED = """\
/verbs_fixture:
  ros__parameters:
    gains:
    - 1
    - 2
    - 3
    limits:
      max: 3
    robot_name: robot
    speed: 1.5
    start_type_description_service: true
    use_sim_time: false

"""


def test_param_dump_then_load_round_trips_on_a_live_node(fixture_node, tmp_path: Path) -> None:
    dumped = run("param", "dump", "/verbs_fixture")
    assert (dumped.returncode, dumped.stdout, dumped.stderr) == (0, DUMPED, "")
    params = tmp_path / "verbs_fixture.yaml"
    params.write_text(dumped.stdout)
    fixture_node.set_parameters(
        [
            Parameter("speed", value=9.0),
            Parameter("limits.max", value=7),
            Parameter("gains", value=[0]),
        ]
    )
    loaded = run("param", "load", "/verbs_fixture", str(params))
    assert loaded.returncode == 0, loaded.stderr
    assert sorted(loaded.stdout.splitlines()) == [
        f"Set parameter {name} successful"
        for name in ("gains", "limits.max", "robot_name", "speed", "use_sim_time")
    ]
    # rclpy makes this one read-only: the node refuses it, and the command says so.
    assert loaded.stderr.startswith("Set parameter start_type_description_service failed: ")
    values = {
        p.name: p.value for p in fixture_node.get_parameters(["speed", "limits.max", "gains"])
    }
    assert values == {"speed": 1.5, "limits.max": 3, "gains": array("q", [1, 2, 3])}


# dump and load are checked in the fast tier by the live node's round trip
@pytest.mark.slow
def test_param_dump_and_load_of_an_unknown_node(fixture_node, tmp_path: Path) -> None:
    result = run("param", "dump", "/nobody_here")
    assert (result.returncode, result.stdout, result.stderr) == (1, "", "Node not found\n")
    params = tmp_path / "params.yaml"
    params.write_text("/nobody_here:\n  ros__parameters:\n    speed: 1.0\n")
    result = run("param", "load", "/nobody_here", str(params))
    assert (result.returncode, result.stdout, result.stderr) == (1, "", "Node not found\n")


# -- action type, doctor ------------------------------------------------------------
def test_action_type_prints_the_type_or_exits_1(fixture_node, capsys) -> None:
    assert in_process(capsys, "action", "type", "/fib_test") == (
        0,
        "test_msgs/action/Fibonacci\n",
        "",
    )
    assert in_process(capsys, "action", "type", "/not_an_action") == (1, "", "")


def test_doctor_report_has_the_sections_a_student_reads(fixture_node, capsys) -> None:
    status, out, _ = in_process(capsys, "doctor", "--report")
    assert status == 0
    titles = re.findall(r"^   ([A-Z][A-Z 2]+)$", out, re.M)
    assert titles == [
        "PLATFORM INFORMATION",
        "ROS 2 INFORMATION",
        "NETWORK CONFIGURATION",
        "RMW MIDDLEWARE",
        "TOPIC LIST",
        "QOS COMPATIBILITY LIST",
    ]
    assert "\nmiddleware name    : rmw_fastrtps_cpp\n" in out
    assert "\ndistribution name      : jazzy\n" in out
    assert "\ndevice  : lo\n" in out
    assert (
        "\ntopic               : /unheard\npublisher count     : 0\nsubscriber count    : 1\n"
        in out
    )


def test_doctor_summarises_its_checks_as_upstream(fixture_node, capsys) -> None:
    status, out, _ = in_process(capsys, "doctor")
    assert (status, out) == (0, "\nAll 4 checks passed\n\n")
    status, out, err = in_process(capsys, "doctor", "--include-warnings")
    assert status == 0
    assert "Subscriber without publisher detected on /unheard." in err
    assert re.search(r"^\d/4 check\(s\) failed$", out, re.M)
    assert re.search(r"^Failed modules: .*\btopic\b", out, re.M)


def test_a_qos_option_never_changes_rclpys_preset_for_the_rest_of_the_process() -> None:
    """``--qos-profile sensor_data --qos-reliability reliable`` gives the command its own
    profile: rclpy's ``qos_profile_sensor_data`` (the preset itself) stays best effort
    for every other node of a notebook that ran the command."""
    import argparse

    from rclpy.qos import QoSReliabilityPolicy, qos_profile_sensor_data

    from rosbook.cli import verb_topic

    args = argparse.Namespace(
        qos_profile="sensor_data", qos_reliability="reliable", qos_history=None,
        qos_durability=None, qos_liveliness=None, qos_depth=3,
        qos_liveliness_lease_duration_seconds=None,
    )  # fmt: skip
    made = verb_topic._qos(args)
    assert (made.reliability, made.depth) == (QoSReliabilityPolicy.RELIABLE, 3)
    assert qos_profile_sensor_data.reliability == QoSReliabilityPolicy.BEST_EFFORT
    assert qos_profile_sensor_data.depth == 5
