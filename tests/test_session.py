"""The notebook session: re-runnable cells, bounded spinning, exact simulated time."""

from __future__ import annotations

import subprocess
import sys
import time

import rclpy
from rcl_interfaces.msg import Log
from rclpy.action import ActionClient, ActionServer
from rclpy.node import Node
from std_msgs.msg import Int64
from test_msgs.action import Fibonacci

from rosbook.runtime.session import Session, spin_node_until


class Ticker(Node):
    def __init__(self, period: float = 0.5, name: str = "ticker") -> None:
        super().__init__(name)
        self.pub = self.create_publisher(Int64, "ticks", 10)
        self.count = 0
        self.timer = self.create_timer(period, self.tick)

    def tick(self) -> None:
        self.pub.publish(Int64(data=self.count))
        self.count += 1


def test_init_twice_is_harmless(session: Session) -> None:
    session.init()
    session.init()
    assert rclpy.ok()


#: Run in a process of its own: there, the session's nodes are the only ones, so the
#: participant's life is theirs (in the test process another test's node may keep it).
HOLD_SCRIPT = """
from rclpy.node import Node
from std_msgs.msg import Int64
from rosbook.runtime.graph import is_hidden
from rosbook.runtime.session import notebook_session

ros = notebook_session()

def participant(name):
    # the first 12 bytes of an endpoint's GID are its participant's GUID prefix
    node = Node(name)
    node.create_publisher(Int64, "ticks", 10)
    (mine,) = [e for e in node.get_publishers_info_by_topic("/ticks") if e.node_name == name]
    return bytes(mine.endpoint_gid)[:12]

def after_reset(name):
    before = participant(name + "_a")
    ros.reset()
    return "same" if participant(name + "_b") == before else "new"

ros.init()
print("plain", after_reset("plain"))
ros.hold_participant()
print("held", after_reset("held"))
print("nodes", [n.get_name() for n in ros.nodes])
keepers = [n for n in ros.nodes[0].get_node_names() if n.startswith("_rosbook_participant_")]
print("keepers", len(keepers), all(is_hidden(n) for n in keepers))
ros.init(sim_time=True)  # a new context: held too
print("sim", after_reset("sim"))
ros.hold_participant(False)
print("released", after_reset("released"))
ros.shutdown()
"""


def test_a_held_participant_outlives_the_sessions_nodes() -> None:
    run = subprocess.run(
        [sys.executable, "-c", HOLD_SCRIPT], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0, run.stderr[-2000:]
    said = dict(line.split(" ", 1) for line in run.stdout.splitlines())
    # rmw_fastrtps_cpp makes a new participant after the last node went: what a hold is for
    assert said["plain"] == "new" and said["released"] == "new", said
    assert said["held"] == "same" and said["sim"] == "same", said
    assert said["nodes"] == "['held_b']", said  # the hidden node is not one of the session's
    assert said["keepers"] == "1 True", said


def test_recreating_a_node_replaces_the_old_one_first(session: Session) -> None:
    first = Node("twin")
    second = Node("twin")
    assert session.nodes.count(second) == 1 and first not in session.nodes
    assert [n.get_name() for n in session.nodes] == ["twin"]
    # rcl would warn on a live duplicate and the survivor would lose /rosout: it keeps it.
    logs: list[Log] = []
    ear = Node("ear")
    ear.create_subscription(Log, "/rosout", logs.append, 10)
    session.spin_until(lambda: False, timeout=0.3)
    second.get_logger().info("still on rosout")
    assert session.spin_until(lambda: any(m.msg == "still on rosout" for m in logs), timeout=3)


def test_a_re_run_cells_action_server_and_client_go_with_its_node(session: Session) -> None:
    class Server(Node):
        def __init__(self) -> None:
            super().__init__("countdown_server")
            self.server = ActionServer(self, Fibonacci, "countdown", lambda handle: None)
            self.client = ActionClient(self, Fibonacci, "countdown")

    Server()
    Server()  # the cell again: rclpy's destroy_node alone leaves the first server up
    eye = Node("eye")
    assert eye.count_publishers("/countdown/_action/feedback") == 1
    assert eye.count_subscribers("/countdown/_action/feedback") == 1
    session.reset()
    assert Node("eye").count_publishers("/countdown/_action/feedback") == 0


def test_same_name_in_another_namespace_is_a_different_node(session: Session) -> None:
    Node("driver", namespace="robot1")
    Node("driver", namespace="robot2")
    assert sorted(n.get_fully_qualified_name() for n in session.nodes) == [
        "/robot1/driver",
        "/robot2/driver",
    ]


def test_destroyed_nodes_leave_the_session(session: Session) -> None:
    node = Node("short_lived")
    node.destroy_node()
    assert node not in session.nodes
    session.spin_for(0.05)  # spinning the rest still works


def test_spin_until_is_bounded_and_reports_failure(session: Session) -> None:
    Node("idle")
    start = time.monotonic()
    assert session.spin_until(lambda: False, timeout=0.3) is False
    assert 0.25 < time.monotonic() - start < 5.0  # ends near its timeout, never hangs


def test_session_recovers_after_someone_shut_rclpy_down(session: Session) -> None:
    Node("before")
    rclpy.shutdown()  # e.g. a signal handler in some other code
    session.init()
    assert rclpy.ok()
    Node("after")
    session.spin_for(0.05)


def test_sim_clock_runs_a_timer_exactly(session: Session) -> None:
    clock = session.sim_clock()
    ticker = Ticker(period=0.5)
    got: list[tuple[int, float]] = []
    probe = Node("probe")
    probe.create_subscription(
        Int64,
        "ticks",
        lambda m: got.append((m.data, probe.get_clock().now().nanoseconds / 1e9)),
        50,
    )
    session.spin_until(lambda: ticker.pub.get_subscription_count() > 0, timeout=2)
    clock.advance(20.0, step=0.05)
    session.spin_until(lambda: len(got) >= 40, timeout=1)
    assert [d for d, _ in got] == list(range(40))
    assert [round(t, 6) for _, t in got] == [round(0.5 * (k + 1), 6) for k in range(40)]


def test_sim_clock_starts_a_fresh_world(session: Session) -> None:
    session.sim_clock()
    Node("old")
    clock = session.sim_clock()
    assert [n.get_name() for n in session.nodes] == ["sim_clock"]
    assert clock.now == 0.0


def test_back_to_wall_time(session: Session) -> None:
    session.sim_clock()
    session.init(sim_time=False)
    assert not session.sim_time
    node = Node("wall")
    assert node.get_clock().now().nanoseconds > 1e18  # seconds since 1970


def test_node_tracking_ends_with_the_session(session: Session) -> None:
    session.shutdown()
    assert Node.__init__.__qualname__ == "Node.__init__"  # rclpy's own, not a wrapper
    assert Node.destroy_node.__qualname__ == "Node.destroy_node"
    rclpy.init()
    try:
        untracked = Node("untracked")
        assert untracked not in session.nodes
        untracked.destroy_node()
    finally:
        rclpy.shutdown()
    session.init()  # the notebook session tracks again
    assert Node("tracked_again") in session.nodes


def test_a_session_without_tracking_knows_only_the_nodes_added(session: Session) -> None:
    explicit = Session()  # shares the default context that `session` initialised
    stranger = Node("stranger")
    assert stranger in session.nodes and explicit.nodes == []
    publisher = explicit.add(Node("added", context=rclpy.get_default_context()))
    assert explicit.nodes == [publisher] and explicit.owns(publisher)
    explicit.remove(publisher)
    assert explicit.nodes == [] and not explicit.owns(publisher)


def test_spin_node_until_spins_the_nodes_session(session: Session) -> None:
    # A helper given only its own node still gets answers from the session's other
    # nodes (a talker of the same kernel), because the node's whole session spins.
    talker = Ticker(period=0.05, name="session_talker")
    heard: list[int] = []
    ear = Node("ear")
    ear.create_subscription(Int64, "ticks", lambda m: heard.append(m.data), 10)
    assert spin_node_until(ear, lambda: len(heard) >= 3, timeout=10.0), "timeout"
    assert talker.count >= 3


def test_spin_node_until_spins_a_node_of_its_own_context_alone(session: Session) -> None:
    talker = Ticker(period=0.05, name="kernel_talker")  # the session's: not spun here
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        cli = Node("_cli", context=context)
        assert not session.owns(cli)
        assert spin_node_until(cli, lambda: False, timeout=0.3) is False
        assert talker.count == 0
        cli.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def test_spin_for_says_when_a_node_on_sim_time_gets_no_clock(session: Session, capsys) -> None:
    """A timer waiting on a /clock nobody advances never fires: the cell says so."""
    session.init(sim_time=True)
    ticker = Ticker(period=0.1)
    session.spin_for(0.6)
    assert ticker.count == 0
    said = capsys.readouterr().out
    assert "the timers of ticker did not fire" in said and "ros.init()" in said, said


def test_spin_for_is_quiet_when_time_moves(session: Session, capsys) -> None:
    session.init()
    ticker = Ticker(period=0.1)
    session.spin_until(lambda: ticker.count >= 1, timeout=5.0)
    session.spin_for(0.6)
    clock = session.sim_clock()
    Ticker(period=0.1)
    clock.advance(0.3)
    session.spin_for(0.05)  # a check's settle on a paused simulated clock
    assert capsys.readouterr().out == ""
