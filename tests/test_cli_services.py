"""``ros2 service/action/param`` against live nodes running in another process."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
from collections import Counter
from collections.abc import Iterator

import pytest
from rclpy.node import Node

from rosbook import ros
from rosbook.cli import main
from rosbook.runtime import graph
from rosbook.runtime.isolation import kill_marked, reserve_domain

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


@pytest.fixture(scope="module")
def servers() -> Iterator[subprocess.Popen]:
    """``rosbook.demos.nodes`` (clock_server, countdown_server) as a process of its own."""
    process = subprocess.Popen(
        [sys.executable, "-X", "faulthandler", "-m", "rosbook.demos.nodes"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,  # a crash's Python stack (faulthandler) shows in a failure
        text=True,
    )
    # The commands report the graph as it is: let the servers be up first, and the
    # nodes of earlier tests in this domain be gone (a limit that only guards a hang).
    ros.reset()
    both = {"/clock_server", "/countdown_server"}

    def others(g: Node) -> Counter[str]:  # a same-named node of an earlier test counts too
        return (
            Counter(graph.node_names(g)) - Counter(both) - Counter([g.get_fully_qualified_name()])
        )

    assert graph.wait_for(
        lambda g: both <= set(graph.node_names(g)) and not others(g), timeout=60.0
    ), f"rosbook.demos.nodes did not come up, or other nodes stayed: {others(graph.observer())}"
    ros.reset()
    yield process
    process.send_signal(signal.SIGINT)
    try:
        _, err = process.communicate(timeout=10)
    except subprocess.TimeoutExpired:
        process.kill()
        raise
    assert process.returncode == 0, err


def ros2(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """Run ``ros2 ARGV`` in this process: exit status, stdout, stderr."""
    status = main(list(argv))
    out, err = capsys.readouterr()
    return status, out, err


def test_service_list_shows_the_running_services_with_types(servers, capsys) -> None:
    status, out, _ = ros2(capsys, "service", "list", "-t")
    assert status == 0
    lines = out.splitlines()
    assert "/what_time [std_srvs/srv/Trigger]" in lines
    assert "/switch [std_srvs/srv/SetBool]" in lines
    assert "/clock_server/set_parameters [rcl_interfaces/srv/SetParameters]" in lines
    assert not [ln for ln in lines if "/_action/" in ln], "an action's services are hidden"
    status, out, _ = ros2(capsys, "service", "list")
    assert "/what_time" in out.splitlines()


def test_service_type_names_the_type_or_fails_in_one_line(servers, capsys) -> None:
    assert ros2(capsys, "service", "type", "/switch") == (0, "std_srvs/srv/SetBool\n", "")
    status, out, err = ros2(capsys, "service", "type", "/no_such_service")
    assert (status, out) == (1, "")
    assert err == ""  # as upstream: nothing, exit code 1


def test_service_call_sends_the_yaml_request_and_prints_the_response(servers, capsys) -> None:
    status, out, _ = ros2(
        capsys, "service", "call", "/switch", "std_srvs/srv/SetBool", "{data: true}"
    )
    assert status == 0
    assert "requester: making request: std_srvs.srv.SetBool_Request(data=True)" in out
    assert "std_srvs.srv.SetBool_Response(success=True, message='on')" in out
    status, out, _ = ros2(capsys, "service", "call", "/what_time", "std_srvs/srv/Trigger")
    assert status == 0 and "success=True, message='It is " in out


@pytest.mark.parametrize(
    ("argv", "error"),
    [
        (
            ["/switch", "std_srvs/srv/NoSuch"],
            "The passed service type is invalid\n",
        ),
        (
            ["/switch", "std_srvs/srv/SetBool", "{value: 1}"],
            "Failed to populate field: SetBool_Request has no field 'value' (its fields: data)\n",
        ),
        (
            ["/nobody", "std_srvs/srv/Trigger", "", "--timeout", "0.5"],
            "ros2 service call: no server for '/nobody (std_srvs/srv/Trigger)' "
            "appeared within 0.5 s\n",
        ),
    ],
    ids=["unknown_type", "unknown_field", "no_server"],
)
def test_service_call_errors_are_one_line_on_stderr(servers, capsys, argv, error) -> None:
    status, out, err = ros2(capsys, "service", "call", *argv)
    assert (status, err) == (1, error)
    assert "Traceback" not in out + err


def test_action_list_and_info(servers, capsys) -> None:
    status, out, _ = ros2(capsys, "action", "list", "-t")
    assert (status, out) == (0, "/countdown [test_msgs/action/Fibonacci]\n")
    status, out, _ = ros2(capsys, "action", "info", "/countdown")
    assert status == 0
    assert (
        out == "Action: /countdown\nAction clients: 0\nAction servers: 1\n    /countdown_server\n"
    )
    status, out, err = ros2(capsys, "action", "info", "/nothing")
    assert (status, out, err) == (
        0,
        "Action: /nothing\nAction clients: 0\nAction servers: 0\n",
        "",
    )


def test_param_list_get_and_set(servers, capsys) -> None:
    status, out, _ = ros2(capsys, "param", "list", "/clock_server")
    assert status == 0
    assert out == "  rate_hz\n  start_type_description_service\n  use_sim_time\n"
    assert ros2(capsys, "param", "get", "/clock_server", "rate_hz") == (
        0,
        "Double value is: 2.0\n",
        "",
    )
    assert ros2(capsys, "param", "set", "/clock_server", "rate_hz", "5.0")[:2] == (
        0,
        "Set parameter successful\n",
    )
    assert ros2(capsys, "param", "get", "clock_server", "rate_hz")[1] == "Double value is: 5.0\n"


def test_param_list_without_a_node_lists_every_node(servers, capsys) -> None:
    status, out, _ = ros2(capsys, "param", "list")
    assert status == 0
    assert "/clock_server:\n  rate_hz\n" in out and "/countdown_server:\n  rate_hz\n" in out
    assert "_ros2cli" not in out


def test_param_errors_name_the_reason(servers, capsys) -> None:
    status, out, err = ros2(capsys, "param", "set", "/clock_server", "rate_hz", "-1.0")
    # upstream reports the refusal on stderr and exits 0
    assert (status, out, err) == (0, "", "Setting parameter failed: rate_hz must be > 0\n")
    status, _, err = ros2(capsys, "param", "get", "/clock_server", "rate")
    assert (status, err) == (1, "Parameter not set\n")
    status, _, err = ros2(capsys, "param", "get", "/nobody", "rate_hz")
    assert (status, err) == (1, "Node not found\n")


def test_action_send_goal_prints_goal_id_feedback_result_and_status(servers, capsys) -> None:
    status, out, err = ros2(
        capsys, "action", "send_goal", "-f", "/countdown", "test_msgs/action/Fibonacci",
        "{order: 2}",
    )  # fmt: skip
    assert (status, err) == (0, "")
    assert out.startswith(
        "Waiting for an action server to become available...\nSending goal:\n     order: 2\n\n"
    )
    assert re.search(r"^Goal accepted with ID: [0-9a-f]{32}$", out, re.MULTILINE), out
    assert out.index("Goal accepted") < out.index("Feedback:")
    feedback = re.findall(r"Feedback:\n    sequence:\n((?:- \d+\n)+)", out)
    assert feedback == ["- 2\n", "- 2\n- 1\n", "- 2\n- 1\n- 0\n"]
    assert out.endswith(
        "Result:\n    sequence:\n- 2\n- 1\n- 0\n\nGoal finished with status: SUCCEEDED\n"
    )
    status, out, _ = ros2(
        capsys, "action", "send_goal", "countdown", "test_msgs/action/Fibonacci", "{order: 1}"
    )
    assert status == 0 and "Feedback:" not in out and out.endswith("status: SUCCEEDED\n")


@pytest.mark.parametrize(
    ("argv", "error"),
    [
        (
            ["/countdown", "test_msgs/action/Countdown", "{order: 1}"],
            "The passed action type is invalid\n",
        ),
        (
            ["/countdown", "test_msgs/action/Fibonacci", "{start: 3}"],
            "Failed to populate message fields: "
            "Fibonacci_Goal has no field 'start' (its fields: order)\n",
        ),
        (
            # send_goal waits for a server as long as asked (upstream: for ever)
            ["/nobody", "test_msgs/action/Fibonacci", "{order: 1}", "--timeout", "2"],
            "ros2 action send_goal: no server for '/nobody (test_msgs/action/Fibonacci)' "
            "appeared within 2 s\n",
        ),
    ],
    ids=["unknown_type", "unknown_field", "no_server"],
)
def test_action_send_goal_errors_are_one_line_on_stderr(servers, capsys, argv, error) -> None:
    status, out, err = ros2(capsys, "action", "send_goal", *argv)
    assert (status, err) == (1, error)
    assert "Traceback" not in out + err


def test_action_send_goal_cancels_the_goal_on_ctrl_c(servers) -> None:
    process = subprocess.Popen(
        [sys.executable, "-m", "rosbook.cli", "action", "send_goal", "/countdown",
         "test_msgs/action/Fibonacci", "{order: 50}"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        lines = []
        while not any(line.startswith("Goal accepted with ID") for line in lines):
            line = process.stdout.readline()
            assert line, f"send_goal ended before the goal was accepted: {lines}"
            lines.append(line)
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=10)
    finally:
        process.kill()
    assert process.returncode == 0, err
    assert out.strip().endswith("Canceling goal..."), out
    assert "Traceback" not in err, err


def test_the_demo_nodes_stop_cleanly_on_ctrl_c_while_a_goal_runs() -> None:
    """Ctrl-C ends ``rosbook.demos.nodes`` with exit code 0 and nothing on stderr, also
    while the countdown server sleeps between two steps of a goal (stress run of stop 47:
    the goal's sleep met a timer its node had destroyed, and rclpy's signal handler shut
    the context down while ``main`` did). A domain of its own: the servers are not the
    module's, whose nodes other tests list."""
    with reserve_domain() as reservation:
        env = reservation.env()
        slow = ["--ros-args", "-p", "rate_hz:=0.05"]  # a step every 20 s: Ctrl-C lands in a sleep
        demo = subprocess.Popen(
            [sys.executable, "-m", "rosbook.demos.nodes", *slow],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        goal = subprocess.Popen(
            [sys.executable, "-m", "rosbook.cli", "action", "send_goal", "-f", "/countdown",
             "test_msgs/action/Fibonacci", "{order: 5}"],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        )  # fmt: skip
        try:
            lines: list[str] = []
            while not any(line.startswith("Feedback:") for line in lines):
                line = goal.stdout.readline()
                assert line, f"send_goal ended before the first feedback: {lines}"
                lines.append(line)
            demo.send_signal(signal.SIGINT)
            _, err = demo.communicate(timeout=60)  # a guard against a hang
        finally:
            goal.kill()
            demo.kill()
            goal.communicate()
            kill_marked(reservation.token)
    assert (demo.returncode, err) == (0, "")
