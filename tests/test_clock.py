"""The one lockstep simulated clock shared by the session, the QoS runs and the simulator."""

from __future__ import annotations

import time

import pytest
from rclpy.node import Node

from rosbook.runtime.clock import LockstepClock, now_ns
from rosbook.runtime.session import Session
from rosbook.sim.node import Simulation
from rosbook.sim.physics import World


def test_a_node_that_never_follows_is_a_timeout_naming_it(session: Session) -> None:
    clock = session.sim_clock()
    deaf = Node("deaf")  # on simulated time, but nothing spins it: it never follows
    started = time.monotonic()
    with pytest.raises(TimeoutError, match=r"^timeout: node\(s\) deaf did not follow /clock"):
        clock.clock.set(1_000_000_000, [deaf], timeout=0.5)
    assert time.monotonic() - started < 5.0


def test_set_returns_once_every_node_reads_the_new_time(session: Session) -> None:
    clock = session.sim_clock()
    follower = Node("follower")
    executor_nodes = [follower]

    def spin(timeout: float) -> None:
        session.spin_for(min(timeout, 0.05), *executor_nodes)

    assert clock.clock.set(2_500_000_000, executor_nodes, spin=spin) is True
    assert now_ns(follower) == 2_500_000_000
    assert clock.now == 2.5


def test_one_clock_publisher_for_the_session_and_the_simulator(session: Session) -> None:
    sim = Simulation(World(arena=None))
    probe = Node("probe")
    assert probe.count_publishers("/clock") == 1
    assert isinstance(sim.clock, LockstepClock)
    assert sim.clock.node.get_name() == "sim_clock"
