"""The ``ros2`` command's topic, node, interface and graph verbs, run as processes.

A talker process publishes /chatter at 20 Hz and subscribes /heard (which nobody
publishes); every command runs against it at once, in the test run's own domain.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path

import pytest

from rosbook import ros
from rosbook.runtime import graph
from tests.slowdown import slow_machine

TALKER = textwrap.dedent(
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.node import Node
    from std_msgs.msg import String


    class Talker(Node):
        def __init__(self):
            super().__init__('talker')
            self.pub = self.create_publisher(String, 'chatter', 10)
            self.sub = self.create_subscription(String, 'heard', lambda msg: None, 10)
            self.timer = self.create_timer(0.05, self.tick)
            self.count = 0

        def tick(self):
            self.pub.publish(String(data=f'Hello World: {self.count}'))
            self.count += 1


    rclpy.init()
    node = Talker()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    """
)

COMMANDS = {
    "topic list": ["topic", "list"],
    "topic list -t": ["topic", "list", "-t"],
    "topic info -v": ["topic", "info", "-v", "/chatter"],
    "topic echo -n 2": ["topic", "echo", "-n", "2", "chatter"],
    "topic echo --once": ["topic", "echo", "--once", "/chatter"],
    "topic hz": ["topic", "hz", "--duration", "2.5", "/chatter"],
    "node list": ["node", "list"],
    "node info": ["node", "info", "/talker"],
    "interface show": ["interface", "show", "geometry_msgs/msg/Pose"],
    "graph --svg": ["graph", "--svg", "{tmp}/graph.svg"],
    "unknown topic": ["topic", "echo", "/no_such_topic"],
    "no publisher": ["topic", "hz", "/heard"],
    "unknown interface": ["interface", "show", "std_msgs/msg/NoSuchThing"],
    "unknown node": ["node", "info", "/nobody"],
}


@pytest.fixture(scope="module")
def runs(
    tmp_path_factory: pytest.TempPathFactory,
) -> Iterator[dict[str, subprocess.CompletedProcess[str]]]:
    """Every command of COMMANDS run once, concurrently, against the live talker."""
    tmp = tmp_path_factory.mktemp("cli")
    script = tmp / "talker.py"
    script.write_text(TALKER)
    talker = subprocess.Popen(
        [sys.executable, str(script)], env=dict(os.environ), start_new_session=True
    )
    try:
        # the commands start cold, like the real CLI without its daemon: let the
        # talker be up and discoverable first
        assert graph.wait_for(lambda g: "/talker" in graph.node_names(g), timeout=15.0)
        ros.reset()
        # all at once: each is mostly waiting (for discovery, for messages, for hz's
        # window), and none depends on another
        procs = {
            name: subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "rosbook.cli",
                    *(a.replace("{tmp}", str(tmp)) for a in argv),
                ],
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
            for name, argv in COMMANDS.items()
        }
        results = {}
        for name, proc in procs.items():
            out, err = proc.communicate(timeout=120)
            results[name] = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
        results["svg"] = subprocess.CompletedProcess([], 0, (tmp / "graph.svg").read_text(), "")
        yield results
    finally:
        os.killpg(talker.pid, signal.SIGKILL)
        talker.wait()


def ok(runs: dict[str, subprocess.CompletedProcess[str]], name: str) -> str:
    run = runs[name]
    assert run.returncode == 0 and "Traceback" not in run.stderr, (name, run.stderr)
    return run.stdout


def test_topic_list_prints_names_and_with_t_their_types(runs: dict) -> None:
    names = ok(runs, "topic list").split()
    assert {"/chatter", "/heard", "/parameter_events", "/rosout"} <= set(names), names
    assert names == sorted(names)
    assert "/chatter [std_msgs/msg/String]\n" in ok(runs, "topic list -t")
    assert "/rosout [rcl_interfaces/msg/Log]\n" in ok(runs, "topic list -t")


def test_topic_info_verbose_prints_each_endpoint_with_its_qos(runs: dict) -> None:
    out = ok(runs, "topic info -v")
    assert out.startswith("Type: std_msgs/msg/String\n\nPublisher count: 1\n\nNode name: talker\n")
    assert "Endpoint type: PUBLISHER\n" in out
    assert "QoS profile:\n  Reliability: RELIABLE\n" in out
    assert "  Durability: VOLATILE\n" in out


def test_topic_echo_prints_yaml_documents(runs: dict) -> None:
    out = ok(runs, "topic echo -n 2")
    documents = out.split("---\n")
    assert len(documents) == 3 and documents[-1] == "", out
    assert all(d.startswith("data: 'Hello World: ") for d in documents[:2]), out
    assert ok(runs, "topic echo --once").count("---") == 1


def test_topic_hz_reports_the_rate_of_a_20_hz_publisher(runs: dict) -> None:
    out = ok(runs, "topic hz")
    rates = [
        float(line.split()[-1]) for line in out.splitlines() if line.startswith("average rate:")
    ]
    assert rates, out
    # within 10 % of 20 Hz; less only if the talker was starved and skipped ticks (an
    # interval over 1.5 periods), and never more than it published
    longest = max(float(line.split()[3].rstrip("s")) for line in out.splitlines() if "max:" in line)
    assert abs(rates[-1] - 20.0) / 20.0 < 0.1 or (longest > 0.075 and rates[-1] < 22.0), out
    assert "\tmin: " in out and "window: " in out


def test_node_list_and_info(runs: dict) -> None:
    nodes = ok(runs, "node list").splitlines()
    assert "/talker" in nodes and nodes == sorted(nodes), nodes
    assert not any(name.startswith("/_") for name in nodes), "hidden CLI nodes are listed"
    out = ok(runs, "node info")
    assert out.startswith(
        "/talker\n  Subscribers:\n    /heard: std_msgs/msg/String\n  Publishers:\n"
    )
    assert "    /chatter: std_msgs/msg/String\n" in out


def test_interface_show_prints_the_definition(runs: dict) -> None:
    assert "Point position\n\tfloat64 x\n" in ok(runs, "interface show")


def test_graph_svg_is_written_with_the_talker_and_its_topics(runs: dict) -> None:
    assert ok(runs, "graph --svg").startswith("wrote ")
    svg = runs["svg"].stdout
    assert 'data-name="/talker"' in svg and 'data-name="/chatter"' in svg
    assert 'data-from="/talker" data-to="/chatter"' in svg
    assert 'data-from="/heard" data-to="/talker"' in svg


@pytest.mark.parametrize(
    "name, message",
    [
        ("unknown topic", "Could not determine the type for the passed topic"),
        ("no publisher", "topic '/heard' has no publisher"),
        ("unknown interface", "Could not find the interface '"),
        ("unknown node", "Unable to find node '/nobody'"),
    ],
)
def test_bad_input_is_one_line_on_stderr_and_exit_code_1(
    runs: dict, name: str, message: str
) -> None:
    run = runs[name]
    assert run.returncode == 1, (name, run.returncode, run.stderr)
    # upstream's echo warns on stdout before it gives up
    warning = "WARNING: topic [/no_such_topic] does not appear to be published yet\n"
    assert run.stdout == (warning if name == "unknown topic" else "")
    assert run.stderr.startswith(message) and run.stderr.count("\n") == 1, run.stderr


def test_ros2_console_script_is_installed() -> None:
    ros2 = Path(sys.executable).parent / "ros2"
    assert ros2.exists(), "pip install -e . should install the ros2 console script"


#: Asked of the live talker on a slow machine (tests/slowdown.py): the answers must be
#: the same as on an idle machine, whatever the time they take.
UNDER_LOAD = {
    "topic info -v": ["topic", "info", "-v", "/chatter"],
    "node info": ["node", "info", "/talker"],
    "node list": ["node", "list"],
    "topic hz": ["topic", "hz", "--duration", "1.5", "/chatter"],
    "unknown topic": ["topic", "info", "/no_such_topic"],
    "unknown node": ["node", "info", "/nobody"],
}


@pytest.fixture(scope="module")
def loaded_runs(runs: dict) -> dict[str, subprocess.CompletedProcess[str]]:
    """Each command of UNDER_LOAD run cold, one at a time, on a slow machine, against
    the talker that ``runs`` keeps alive."""
    results = {}
    with slow_machine() as inside:
        for name, argv in UNDER_LOAD.items():
            results[name] = subprocess.run(
                [sys.executable, "-m", "rosbook.cli", *argv],
                preexec_fn=inside,
                capture_output=True,
                text=True,
                timeout=120,
            )
    return results


def test_topic_info_under_load_names_every_endpoints_node(loaded_runs: dict) -> None:
    out = ok(loaded_runs, "topic info -v")
    assert "Publisher count: 1\n\nNode name: talker\n" in out, out
    assert graph.UNKNOWN_NODE not in out, "an endpoint was shown before its node was known"


def test_node_info_and_list_under_load_show_the_talker_whole(loaded_runs: dict) -> None:
    assert "/talker" in ok(loaded_runs, "node list").splitlines()
    out = ok(loaded_runs, "node info")
    assert "  Subscribers:\n    /heard: std_msgs/msg/String\n" in out, out
    assert "    /chatter: std_msgs/msg/String\n" in out, out


def test_topic_hz_under_load_finds_the_live_topic(loaded_runs: dict) -> None:
    assert "average rate: " in ok(loaded_runs, "topic hz")


def test_absent_things_under_load_are_reported_absent(loaded_runs: dict) -> None:
    assert loaded_runs["unknown topic"].stderr == "Unknown topic '/no_such_topic'\n"
    assert loaded_runs["unknown node"].stderr == "Unable to find node '/nobody'\n"
