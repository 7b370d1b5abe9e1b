"""``ros2 lifecycle``: upstream's expectations, ported from ros2/ros2cli (jazzy)
``ros2lifecycle/test/test_cli.py`` (each test names the one it ports), against
upstream's fixtures rewritten with rclpy (``tests/fixtures_upstream.py lifecycle``),
started as a process of their own. The commands run in this process, cold
(``rosbook.cli.main``)."""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator
from typing import Any

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.lifecycle import LifecycleNode, State, TransitionCallbackReturn

from rosbook.runtime import graph
from tests.clitools import Run, fixture_process, run_ros2

VISIBLE, HIDDEN = "/test_lifecycle_node", "/_hidden_test_lifecycle_node"

#: ``ALL_LIFECYCLE_NODE_TRANSITIONS`` of upstream's test: rcl_lifecycle's transition graph.
ALL_TRANSITIONS = [
    line
    for label, tid, start, goal in [
        ("configure", 1, "unconfigured", "configuring"),
        ("transition_success", 10, "configuring", "inactive"),
        ("transition_failure", 11, "configuring", "unconfigured"),
        ("transition_error", 12, "configuring", "errorprocessing"),
        ("cleanup", 2, "inactive", "cleaningup"),
        ("transition_success", 20, "cleaningup", "unconfigured"),
        ("transition_failure", 21, "cleaningup", "inactive"),
        ("transition_error", 22, "cleaningup", "errorprocessing"),
        ("activate", 3, "inactive", "activating"),
        ("transition_success", 30, "activating", "active"),
        ("transition_failure", 31, "activating", "inactive"),
        ("transition_error", 32, "activating", "errorprocessing"),
        ("deactivate", 4, "active", "deactivating"),
        ("transition_success", 40, "deactivating", "inactive"),
        ("transition_failure", 41, "deactivating", "active"),
        ("transition_error", 42, "deactivating", "errorprocessing"),
        ("shutdown", 5, "unconfigured", "shuttingdown"),
        ("shutdown", 6, "inactive", "shuttingdown"),
        ("shutdown", 7, "active", "shuttingdown"),
        ("transition_success", 50, "shuttingdown", "finalized"),
        ("transition_failure", 51, "shuttingdown", "finalized"),
        ("transition_error", 52, "shuttingdown", "errorprocessing"),
        ("transition_success", 60, "errorprocessing", "unconfigured"),
        ("transition_failure", 61, "errorprocessing", "finalized"),
        ("transition_error", 62, "errorprocessing", "finalized"),
    ]
    for line in (f"- {label} [{tid}]", f"\tStart: {start}", f"\tGoal: {goal}")
]


@pytest.fixture(scope="module", autouse=True)
def fixture_nodes() -> Iterator[None]:
    """The two lifecycle nodes, up and offering get_state before any command runs."""
    services = {f"{VISIBLE}/get_state", f"{HIDDEN}/get_state"}
    with fixture_process(
        "lifecycle", up=lambda g: services <= {name for name, _ in g.get_service_names_and_types()}
    ):
        yield


def ok(run: Run) -> list[str]:
    assert run.code == 0 and "Traceback" not in run.err, run
    return run.out.splitlines()


def not_found(run: Run) -> None:
    assert (run.code, run.out, run.err) == (1, "", "Node not found\n"), run


def test_list_shows_the_transitions_available_now() -> None:
    # test_list_lifecycle_node_transitions
    assert ok(run_ros2("lifecycle", "list", "test_lifecycle_node")) == [
        "- configure [1]",
        "\tStart: unconfigured",
        "\tGoal: configuring",
        "- shutdown [5]",
        "\tStart: unconfigured",
        "\tGoal: shuttingdown",
    ]


def test_list_all_shows_the_whole_transition_graph() -> None:
    # test_list_all_lifecycle_node_transitions
    assert ok(run_ros2("lifecycle", "list", "test_lifecycle_node", "-a")) == ALL_TRANSITIONS


def test_list_finds_a_hidden_node_only_with_the_hidden_flag() -> None:
    # test_list_all_lifecycle_hidden_node_transitions_{without,with}_hidden_flag
    not_found(run_ros2("lifecycle", "list", "_hidden_test_lifecycle_node", "-a"))
    hidden = "_hidden_test_lifecycle_node"
    run = run_ros2("lifecycle", "list", "--include-hidden-nodes", hidden, "-a")
    assert ok(run) == ALL_TRANSITIONS


def test_nodes_lists_lifecycle_nodes_hidden_ones_with_all() -> None:
    # test_list_lifecycle_nodes, test_list_all_lifecycle_nodes
    assert ok(run_ros2("lifecycle", "nodes")) == [VISIBLE]
    assert ok(run_ros2("lifecycle", "nodes", "-a")) == [HIDDEN, VISIBLE]


def test_nodes_count_counts_lifecycle_nodes() -> None:
    # test_count_lifecycle_nodes, test_count_all_lifecycle_nodes
    assert ok(run_ros2("lifecycle", "nodes", "-c")) == ["1"]
    assert ok(run_ros2("lifecycle", "nodes", "-a", "-c")) == ["2"]


def test_nodes_leaves_out_a_node_without_lifecycle() -> None:
    # ros2lifecycle/api: a lifecycle node is one with <node>/get_state of GetState
    assert not any("ros2cli" in line for line in ok(run_ros2("lifecycle", "nodes", "-a")))


def test_set_an_unknown_transition_lists_the_available_ones() -> None:
    # test_set_lifecycle_node_invalid_transition
    run = run_ros2("lifecycle", "set", VISIBLE, "noop")
    assert (run.code, run.out) == (1, ""), run
    assert run.err.splitlines() == [
        "Unknown transition requested, available ones are:",
        "- configure [1]",
        "- shutdown [5]",
    ]


def test_set_and_get_say_node_not_found_for_a_missing_or_hidden_node() -> None:
    # test_set_nonexistent_lifecycle_node_state, test_set_hidden_lifecycle_node_transition,
    # test_get_nonexistent_lifecycle_node_state, test_get_hidden_lifecycle_node_state
    not_found(run_ros2("lifecycle", "set", "/nonexistent_test_lifecycle_node", "configure"))
    not_found(run_ros2("lifecycle", "set", HIDDEN, "configure"))
    not_found(run_ros2("lifecycle", "get", "/nonexistent_test_lifecycle_node"))
    not_found(run_ros2("lifecycle", "get", HIDDEN))


def test_get_prints_the_state_with_its_id() -> None:
    # test_get_lifecycle_node_state, test_get_hidden_lifecycle_node_state
    assert ok(run_ros2("lifecycle", "get", VISIBLE)) == ["unconfigured [1]"]
    assert ok(run_ros2("lifecycle", "get", "--include-hidden-nodes", HIDDEN)) == [
        "unconfigured [1]"
    ]


def test_get_without_a_name_prefixes_each_node() -> None:
    # ros2lifecycle/verb/get.py: every lifecycle node, "<node>: <label> [<id>]"
    assert ok(run_ros2("lifecycle", "get")) == [f"{VISIBLE}: unconfigured [1]"]


def test_node_lifecycle_goes_round_by_labels_and_by_ids() -> None:
    # test_node_lifecycle; a transition may also be named by its id (ros2lifecycle set)
    steps = [
        ("unconfigured [1]", "configure"),
        ("inactive [2]", "activate"),
        ("active [3]", "4"),  # deactivate, by its id
        ("inactive [2]", "cleanup"),
    ]
    for state, transition in steps:
        assert ok(run_ros2("lifecycle", "get", "--include-hidden-nodes", HIDDEN)) == [state]
        run = run_ros2("lifecycle", "set", "--include-hidden-nodes", HIDDEN, transition)
        assert ok(run) == ["Transitioning successful"], run
    assert ok(run_ros2("lifecycle", "get", "--include-hidden-nodes", HIDDEN)) == [
        "unconfigured [1]"
    ]


class FailingDriver(LifecycleNode):
    """A lifecycle node whose configuring always fails (its device is missing)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("failing_driver", **kwargs)

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        return TransitionCallbackReturn.FAILURE


def test_set_says_transitioning_failed_on_stderr_and_exits_0_when_the_node_refuses() -> None:
    # ros2lifecycle/verb/set.py: a ChangeState answered with success false
    context = rclpy.Context()
    rclpy.init(context=context)
    node = FailingDriver(context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        run = run_ros2("lifecycle", "set", "/failing_driver", "configure")
        assert (run.code, run.out, run.err) == (0, "", "Transitioning failed\n"), run
        assert ok(run_ros2("lifecycle", "get", "/failing_driver")) == ["unconfigured [1]"]
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        spinner.join(timeout=10)
    # rclpy's lifecycle state machine and its node refer to each other: the node stays on
    # the graph until that cycle is collected, and the next test file of this process
    # (pytest-xdist) would find it there
    del node, executor
    gc.collect()
    gone = graph.wait_for(lambda g: "/failing_driver" not in graph.node_names(g), timeout=60.0)
    assert gone, "timeout: /failing_driver stayed on the graph after it was destroyed"
