"""The introspection toolkit (graph, interfaces, graph_svg) on live nodes."""

from __future__ import annotations

import re
import time
from typing import Any

import pytest
from geometry_msgs.msg import Pose
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from std_msgs.msg import Int64, String

from rosbook.cli import private_node
from rosbook.runtime import graph, interfaces
from rosbook.runtime.isolation import reserve_domain
from rosbook.runtime.session import Session
from rosbook.viz.graph_svg import GraphEdges, collect, graph_svg, to_svg


class Talker(Node):
    """Publishes 'n: N' on /chatter every `period` seconds (timer on the node's clock)."""

    def __init__(self, period: float = 0.05) -> None:
        super().__init__("talker")
        self.pub = self.create_publisher(String, "chatter", 10)
        self.scan = self.create_publisher(Int64, "scan", qos_profile_sensor_data)
        self.count = 0
        self.timer = self.create_timer(period, self.tick)

    def tick(self) -> None:
        self.pub.publish(String(data=f"n: {self.count}"))
        self.scan.publish(Int64(data=self.count))
        self.count += 1


@pytest.fixture
def system(session: Session) -> dict[str, Any]:
    """talker → /chatter → listener; best-effort /scan; a latched /robot/status; a lonely /heard."""
    talker = Talker()
    listener = Node("listener", namespace="/robot")
    listener.create_subscription(String, "/chatter", lambda m: None, 10)
    listener.create_subscription(Int64, "heard", lambda m: None, 10)
    status_qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    status = listener.create_publisher(Int64, "status", status_qos)
    Node("_hidden_helper")
    # Discovery lists even this process's endpoints asynchronously, and a process of an
    # earlier test in this domain may still be listed (until its lease ends): wait for
    # ours, and name them by their nodes.
    ours = {
        ("/chatter", "talker"), ("/chatter", "listener"), ("/scan", "talker"),
        ("/robot/status", "listener"), ("/robot/heard", "listener"),
    }  # fmt: skip

    def found(g: Node) -> bool:
        seen = set()
        for topic, _ in ours:
            infos = g.get_publishers_info_by_topic(topic) + g.get_subscriptions_info_by_topic(topic)
            seen |= {(topic, i.node_name) for i in infos}
        return ours <= seen

    assert graph.wait_for(found, timeout=30.0), "the fixture's endpoints were not discovered"
    return {"talker": talker, "listener": listener, "status": status}


def test_node_names_lists_live_nodes_and_hides_hidden_ones(system: dict[str, Any]) -> None:
    names = graph.node_names()
    assert "/talker" in names and "/robot/listener" in names
    assert not any(graph.is_hidden(n) for n in names), names
    assert "/_hidden_helper" in graph.node_names(include_hidden=True)


def test_topic_names_and_types_reports_each_topics_type(system: dict[str, Any]) -> None:
    topics = dict(graph.topic_names_and_types())
    assert topics["/chatter"] == ["std_msgs/msg/String"]
    assert topics["/robot/heard"] == ["std_msgs/msg/Int64"]
    assert topics["/robot/status"] == ["std_msgs/msg/Int64"]
    assert topics["/rosout"] == ["rcl_interfaces/msg/Log"]


def test_topic_info_counts_endpoints_and_gives_each_endpoints_qos(system: dict[str, Any]) -> None:
    chatter = graph.topic_info("chatter")
    assert (len(chatter.publishers), len(chatter.subscriptions)) == (1, 1)
    assert chatter.publishers[0].node_name == "talker"
    assert chatter.subscriptions[0].node_namespace == "/robot"

    status = graph.topic_info("/robot/status")
    (publisher,) = status.publishers
    assert publisher.qos_profile.reliability == ReliabilityPolicy.RELIABLE
    assert publisher.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert graph.qos_summary(publisher).startswith("RELIABLE, TRANSIENT_LOCAL")
    (scan,) = [p for p in graph.topic_info("/scan").publishers if p.node_name == "talker"]
    assert graph.qos_summary(scan).startswith("BEST_EFFORT, VOLATILE")

    text = status.format(verbose=True)
    assert text.startswith("Type: std_msgs/msg/Int64\n\nPublisher count: 1\n")
    assert "Endpoint type: PUBLISHER" in text and "Durability: TRANSIENT_LOCAL" in text
    assert "Subscription count: 0" in text
    assert graph.topic_info("/robot/status").format() == (
        "Type: std_msgs/msg/Int64\nPublisher count: 1\nSubscription count: 0"
    )


def test_node_info_lists_the_nodes_endpoints_like_ros2_node_info(system: dict[str, Any]) -> None:
    info = graph.node_info("/robot/listener")
    assert ("/chatter", ["std_msgs/msg/String"]) in info.subscribers
    assert ("/robot/heard", ["std_msgs/msg/Int64"]) in info.subscribers
    assert ("/robot/status", ["std_msgs/msg/Int64"]) in info.publishers
    assert any(name == "/robot/listener/get_parameters" for name, _ in info.service_servers)
    lines = info.format().splitlines()
    assert lines[:2] == ["/robot/listener", "  Subscribers:"]
    assert "    /chatter: std_msgs/msg/String" in lines
    assert "  Action Clients:" in lines


def test_echo_returns_the_next_n_messages_of_a_live_publisher(system: dict[str, Any]) -> None:
    seen: list[str] = []
    messages = graph.echo("/chatter", 3, on_message=lambda m: seen.append(m.data), timeout=5.0)
    assert len(messages) == 3 and [m.data for m in messages] == seen
    numbers = [int(m.data.split()[1]) for m in messages]
    assert numbers == list(range(numbers[0], numbers[0] + 3)), numbers
    assert interfaces.to_yaml(messages[0]) == f"data: 'n: {numbers[0]}'"


def test_echo_subscribes_with_a_qos_that_matches_the_publishers(system: dict[str, Any]) -> None:
    # a reliable subscription would never match a best-effort publisher
    assert len(graph.echo("/scan", 2, timeout=3.0)) == 2
    # published before echo subscribed: only a transient-local subscription receives it
    system["status"].publish(Int64(data=42))
    assert [m.data for m in graph.echo("/robot/status", 1, timeout=3.0)] == [42]


def test_hz_on_sim_time_measures_the_timer_period_within_one_clock_step(
    session: Session,
) -> None:
    clock = session.sim_clock()
    Talker(period=0.1)
    watcher = Node("_hz_observer")
    monitor = graph.HzMonitor("/chatter", watcher)
    clock.advance(3.0, step=0.01)
    rate = monitor.rate()
    monitor.close()
    assert rate is not None and rate.window >= 25, rate
    assert abs(rate.rate - 10.0) < 0.1, rate
    assert 0.08 <= rate.min <= 0.1 <= rate.max <= 0.12, rate
    assert re.fullmatch(
        r"average rate: \d+\.\d{3}\n"
        r"\tmin: \d\.\d{3}s max: \d\.\d{3}s std dev: \d\.\d{5}s window: \d+",
        rate.format(),
    ), rate.format()


def test_hz_on_wall_time_is_near_a_20_hz_publisher(system: dict[str, Any]) -> None:
    rate = graph.hz("/chatter", duration=1.5)
    assert abs(rate.rate - 20.0) / 20.0 < 0.15, rate
    assert rate.window >= 20


def test_an_observer_that_started_slowly_waits_longer_for_discovery_to_be_quiet(
    system: dict[str, Any],
) -> None:
    """A machine that starved an observer's start-up delivers the others' endpoints in
    slow pieces too: the quiet period that proves discovery settled counts the first
    node's delay from the observer's start, not from the settle call (a cold ``ros2
    service type`` on a loaded CI machine settled in 0.25 s, one service short)."""
    with private_node("_slow_observer") as observer:
        started = time.monotonic() - 3.0  # as if rclpy.init and the node had taken 3 s
        graph.discovering_since(observer, started)
        assert graph.wait_for(lambda g: "/talker" in graph.node_names(g), observer, timeout=60)
        called = time.monotonic()
        assert graph.settle(observer)
        waited = time.monotonic() - called
    assert waited >= called - started, f"settled after {waited:.2f} s of quiet"


def test_an_empty_graph_is_trusted_only_after_the_observer_waited_as_long_as_it_took_to_start(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A cold ``ros2 graph`` on a loaded CI machine drew an empty graph beside a running
    talker: its start-up had taken longer than the wait for a first node, so it trusted
    silence at once. The wait for a first node counts from the observer's making, and
    lasts at least as long as that took."""
    with reserve_domain() as empty:
        monkeypatch.setenv("ROS_DOMAIN_ID", str(empty.domain_id))
        with private_node("_starved_observer") as observer:
            started = time.monotonic() - 3.0  # as if rclpy.init and the node had taken 3 s
            graph.discovering_since(observer, started)
            made = time.monotonic()
            assert graph.settle(observer)
            waited = time.monotonic() - made
            assert graph.node_names(observer) == []
    assert waited >= 3.0, f"an empty graph trusted after {waited:.2f} s"


def test_endpoints_whose_node_is_not_yet_named_are_waited_for_not_taken_for_an_empty_graph(
    system: dict[str, Any],
) -> None:
    """Discovery brings a participant's endpoints and its nodes' names separately; the
    names can come seconds later (a lost sample waits for the next heartbeat). A cold
    ``ros2 node list -a -c`` in CI printed 0 beside 11 running nodes: seeing no visible
    node, it trusted an empty graph. Endpoints whose node has no name yet are someone
    on the graph; hidden nodes alone are not (a command's daemon, started with it, is
    seen first). (Which sample is late cannot be chosen on a real graph: this feeds a
    real snapshot, its names as rmw reports them until they arrive.)"""
    observer = graph.observer()
    own = (observer.get_namespace(), observer.get_name())
    assert graph.wait_for(lambda g: "/talker" in graph.node_names(g), timeout=60)
    nodes, topics, endpoints, services = graph.snapshot()
    unnamed = tuple(
        tuple(
            (ns, name, kind) if (ns, name) == own else ("/", graph.UNKNOWN_NODE, kind)
            for ns, name, kind in topic
        )
        for topic in endpoints
    )
    hidden = tuple(n for n in nodes if graph.is_hidden(n))
    long_ago = time.monotonic() - 60.0  # made and discovering for a minute
    since = {"start": long_ago, "at_least": 0.0, "quiet": 0.0, "made": long_ago}
    names_late = (hidden, topics, unnamed, services)
    assert not graph._Watch(names_late, long_ago).settled(names_late, **since)
    # nobody, or hidden nodes alone: trusted once the wait for a first node passed
    for alone in ((hidden, (), (), ()), (hidden, topics, (), services)):
        assert graph._Watch(alone, long_ago).settled(alone, **since)


def test_bad_inputs_raise_one_line_errors(system: dict[str, Any]) -> None:
    with pytest.raises(graph.GraphError, match=r"^topic '/nope' does not exist on the graph"):
        graph.echo("/nope")
    with pytest.raises(graph.GraphError, match=r"^topic '/robot/heard' has no publisher"):
        graph.hz("/robot/heard", duration=0.1)
    with pytest.raises(graph.GraphError, match=r"^node '/nobody' is not on the graph"):
        graph.node_info("/nobody")
    with pytest.raises(interfaces.InterfaceError, match=r"^unknown interface 'std_msgs/msg/Nope'"):
        interfaces.show("std_msgs/msg/Nope")
    with pytest.raises(interfaces.InterfaceError, match="not an interface name"):
        interfaces.show("std_msgs/String")


def test_interface_show_prints_the_msg_file_with_nested_types_expanded() -> None:
    text = interfaces.show("geometry_msgs/msg/Pose")
    assert text.startswith("# A representation of pose in free space")
    assert "Point position\n\tfloat64 x\n\tfloat64 y\n\tfloat64 z\n" in text
    assert "Quaternion orientation\n\tfloat64 x 0\n" in text and text.endswith("\tfloat64 w 1")
    assert interfaces.fields("geometry_msgs/msg/Pose") == {
        "position": "geometry_msgs/Point",
        "orientation": "geometry_msgs/Quaternion",
    }
    assert interfaces.message_class("geometry_msgs/msg/Pose") is Pose
    assert "std_msgs/msg/String" in interfaces.interfaces("std_msgs")
    assert interfaces.show("std_msgs/msg/Float64").endswith("float64 data")


def test_graph_svg_draws_nodes_topics_and_publisher_topic_subscriber_edges(
    system: dict[str, Any],
) -> None:
    edges = collect()
    assert (("node", "/talker"), ("topic", "/chatter")) in edges.edges
    assert (("topic", "/chatter"), ("node", "/robot/listener")) in edges.edges
    assert "/rosout" not in edges.topics and "/parameter_events" not in edges.topics
    assert "/_hidden_helper" not in edges.nodes
    svg = graph_svg()
    assert svg.startswith("<svg") and svg.endswith("</svg>")
    assert '<g class="node" data-name="/talker"><ellipse' in svg
    assert '<g class="topic" data-name="/chatter"><rect' in svg
    assert 'data-from="/talker" data-to="/chatter"' in svg
    assert 'data-from="/chatter" data-to="/robot/listener"' in svg
    assert ">/rosout<" not in svg
    assert ">/rosout<" in graph_svg(include_debug=True)


def test_graph_layout_is_deterministic_and_survives_cycles() -> None:
    planner_loop = GraphEdges(
        nodes=["/mapper", "/planner"],
        topics=["/map", "/path"],
        edges=[
            (("node", "/mapper"), ("topic", "/map")),
            (("topic", "/map"), ("node", "/planner")),
            (("node", "/planner"), ("topic", "/path")),
            (("topic", "/path"), ("node", "/mapper")),
        ],
    )
    svg = to_svg(planner_loop)
    assert svg == to_svg(planner_loop)
    assert svg.count('class="edge"') == 4
    x = {
        name: float(cx)
        for name, cx in re.findall(r'data-name="([^"]+)"><\w+ (?:cx|x)="([\d.]+)"', svg)
    }
    assert x["/mapper"] < x["/map"] < x["/planner"] < x["/path"], x


def test_an_edge_that_skips_columns_is_routed_above_them() -> None:
    relay = GraphEdges(
        nodes=["/listener", "/shouter", "/talker"],
        topics=["/chatter", "/shouted"],
        edges=[
            (("node", "/talker"), ("topic", "/chatter")),
            (("topic", "/chatter"), ("node", "/shouter")),
            (("node", "/shouter"), ("topic", "/shouted")),
            (("topic", "/shouted"), ("node", "/listener")),
            (("topic", "/chatter"), ("node", "/listener")),
        ],
    )
    svg = to_svg(relay)
    (skip,) = re.findall(r'data-from="/chatter" data-to="/listener" d="([^"]+)"', svg)
    shouted_top = float(re.search(r'data-name="/shouted"><rect x="[\d.]+" y="([\d.]+)"', svg)[1])
    (route_y,) = {float(y) for y in re.findall(r"L [\d.]+ ([\d.]+)", skip)}
    assert route_y < shouted_top, (route_y, shouted_top)
