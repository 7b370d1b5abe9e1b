"""Lab 1's checks as the judge runs them: every verdict from ROS traffic or exit codes.

The same checks as the lab's test cells (visible and hidden), observed from the judge's
process: the student's node runs in the kernel; the judge publishes ``/clock`` and the
stimuli, and judges what arrives on its own subscriptions. The parameters here are the
hidden tests' own; they never enter the kernel except as the arguments of the call.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

from rcl_interfaces.srv import ListParameters
from rclpy.node import Node
from std_msgs.msg import Int64, String

from autograder.judge import (
    EVENT_GUARD_S,
    CheckFailed,
    Judgement,
    JudgeTimeout,
    clock_message,
    clock_publisher,
    own_domain,
    ros_node,
)
from autograder.lockstep import (
    Listener,
    await_discovered_by,
    published_on_sim_time,
    require_endpoint,
    require_name,
    wait_for,
)
from rosbook.labs.lab01 import RosoutLog, assert_hello_world, assert_logged, assert_times
from rosbook.labs.probes import (
    ScriptRun,
    assert_clean_exit,
    assert_sequence,
    assert_still_running,
    explain_silence,
    rclpy_raced,
)
from rosbook.runtime.session import ros, spin_node_until


def check_counter_publisher(j: Judgement) -> None:
    info = j.start_node("CounterPublisher", sim_time=True)
    require_name(info, "CounterPublisher()", "counter_publisher")
    require_endpoint(info, "/counter", Int64, "publisher")
    j.wait_on_graph("counter_publisher", "/counter", "publisher")
    data, _ = published_on_sim_time(j, "counter_publisher", "/counter", Int64, 2.0, step=0.1)
    assert_sequence("'counter' during 2 s with period=0.5", data, [0, 1, 2, 3])

    ros.reset()
    log = RosoutLog()
    info = j.start_node("CounterPublisher", sim_time=True, node_name="fast_counter", period=0.2)
    require_name(info, "CounterPublisher(node_name='fast_counter')", "fast_counter")
    require_endpoint(info, "/counter", Int64, "publisher")
    j.wait_on_graph("fast_counter", "/counter", "publisher")
    data, times = published_on_sim_time(j, "fast_counter", "/counter", Int64, 1.5)
    assert_sequence("'counter' during 1.5 s with period=0.2", data, list(range(7)))
    assert_times("'counter' with period=0.2", times, [0.2 * (k + 1) for k in range(7)])
    seven = lambda: len(log.of("fast_counter")) >= 7  # noqa: E731
    if not ros.spin_until(seven, log.node, timeout=EVENT_GUARD_S):
        lines = log.of("fast_counter")
        if lines and all(str(k) in line for k, line in enumerate(lines)):  # right, but short
            raise JudgeTimeout(
                f"node 'fast_counter' logged {len(lines)} of its 7 lines to /rosout within "
                f"{EVENT_GUARD_S:.0f} s, each right so far"
            )
    assert_logged(log, "fast_counter", [str(v) for v in range(7)])


def relayed(
    j: Judgement,
    name: str,
    values: Sequence[int],
    expected: Sequence[int],
    answer: Callable[[int], list[int]],
) -> list[int]:
    """Publish ``values`` on /counter one at a time, each once the last was handled;
    ``answer(n)`` spins the kernel until n results are in (or a guard) and returns them.

    A result that does not come in the guard is not yet wrong: the next value goes out,
    and if a later one is handled the missing one was skipped (wrong). When the node
    falls silent (two misses in a row, or the last) with every result so far right, it is
    waited for once more; still short, that is a timeout (a starved machine or a stalled
    node), never "wrong"."""
    sender = ros_node("judge_sender_counter")
    pub = sender.create_publisher(Int64, "/counter", 10)
    wait_for(
        lambda: pub.get_subscription_count() > 0,
        sender,
        what=f"node '{name}' did not subscribe to /counter",
    )
    await_discovered_by(j, sender, "/counter", name)
    got: list[int] = []
    misses = 0
    for value in values:
        pub.publish(Int64(data=value))
        before = len(got)
        got = answer(before + 1)
        misses = misses + 1 if len(got) <= before else 0
        if misses == 2:
            break

    def behind() -> bool:
        return len(got) < len(values) and list(got) == list(expected[: len(got)])

    if misses and behind():
        got = answer(len(values))
        if behind():
            raise JudgeTimeout(
                f"node '{name}' handled {len(got)} of the {len(values)} values sent on "
                f"/counter ({list(values)}), each waited for {EVENT_GUARD_S:.0f} s: all "
                "it handled was right, then it fell silent"
            )
    j.kernel.call("spin", 0.1)  # a surplus message would arrive now
    return answer(0)


def check_counter_subscriber(j: Judgement) -> None:
    for kwargs, name, values in (
        ({}, "counter_subscriber", [3, 1, 4]),
        ({"node_name": "listener_b"}, "listener_b", [7, -2, 0, 2**40, *range(10)]),
    ):
        ros.reset()
        call = f"CounterSubscriber({', '.join(f'{k}={v!r}' for k, v in kwargs.items())})"
        info = j.start_node("CounterSubscriber", **kwargs)
        require_name(info, call, name)
        received = j.kernel.call("spin_until_length", "received", 0, 0.0)
        if received != []:
            raise CheckFailed("self.received must be an empty list as soon as the node is built")
        require_endpoint(info, "/counter", Int64, "subscription")
        j.wait_on_graph(name, "/counter", "subscription")
        got = relayed(
            j,
            name,
            values,
            values,
            lambda n: j.kernel.call("spin_until_length", "received", n, EVENT_GUARD_S),
        )
        assert_sequence(f"after publishing {values} on /counter", got, values)


def check_doubler(j: Judgement) -> None:
    for kwargs, name, values in (
        ({}, "doubler", [1, 2, 3]),
        ({"node_name": "doubler_b"}, "doubler_b", [-5, 0, 2**40, 21]),
    ):
        ros.reset()
        call = f"Doubler({', '.join(f'{k}={v!r}' for k, v in kwargs.items())})"
        info = j.start_node("Doubler", **kwargs)
        require_name(info, call, name)
        require_endpoint(info, "/counter", Int64, "subscription")
        require_endpoint(info, "/doubled", Int64, "publisher")
        j.wait_on_graph(name, "/doubled", "publisher")
        listener = Listener("/doubled", Int64)
        wait_for(
            lambda listener=listener: listener.sub.get_publisher_count() > 0,
            listener.node,
            what=f"the judge did not connect to node '{name}' on /doubled",
        )

        def answers(n: int, listener: Listener = listener) -> list[int]:
            def arrived() -> bool:
                j.kernel.call("spin", 0.02)
                listener.drain()
                return len(listener.data) >= n

            ros.spin_until(arrived, listener.node, timeout=EVENT_GUARD_S if n else 0.0)
            return list(listener.data)

        doubled = [2 * v for v in values]
        got = relayed(j, name, values, doubled, answers)
        assert_sequence(f"after publishing {values} on /counter", got, doubled)


def _talker_runs(j: Judgement, started: Callable[[], None]) -> None:
    """talker.py on wall time: 'Hello World: N' on /chatter at 2 Hz, a clean Ctrl-C.
    ``started()`` is called once its publisher is found."""
    ros.reset()
    listener = Listener("/chatter", String)
    with j.script("talker.py") as run:
        wait_for_script(run, listener)
        started()
        arrived = ros.spin_until(
            lambda: len(listener.data) >= 2, listener.node, timeout=SCRIPT_GUARD_S
        )
        assert_still_running(run)
        assert_hello_world(listener.data, at_least=len(listener.data))
        if not arrived:  # a talker at 2 Hz sends 2 in a second: this is a starved machine
            raise JudgeTimeout(
                f"talker.py sent {len(listener.data)} message(s) on /chatter in "
                f"{SCRIPT_GUARD_S:.0f} s; at 2 Hz that would be 2 in one second"
            )
        assert_clean_exit(run)


def _talker_on_sim_time(j: Judgement) -> None:
    """talker.py with use_sim_time: exactly 6 messages in 3 simulated seconds. It runs
    in a ROS domain of its own (``own_domain``), so it can run alongside the wall-time
    part, which waits a second of wall time for its talker's messages."""
    with own_domain() as (domain, context):
        listener = Listener("/chatter", String, context=context)
        try:
            _sim_time_talker(j, domain, listener)
        finally:
            listener.node.destroy_node()


def _sim_time_talker(j: Judgement, domain: int, listener: Listener) -> None:
    clock = clock_publisher(listener.node)
    with j.script("talker.py", "-p", "use_sim_time:=true", domain=domain) as run:
        wait_for_script(run, listener)
        wait_until_talker_hears(listener)
        if not spin_node_until(
            listener.node,
            lambda: clock.get_subscription_count() > 0 or not run.alive(),
            EVENT_GUARD_S,
        ):
            raise CheckFailed(
                "talker.py does not listen to /clock when started with --ros-args -p "
                "use_sim_time:=true: does main() pass its args to rclpy.init(args=args)?"
            )
        assert_still_running(run)
        waiting = True  # a right talker is waited for at every 0.5 s; a wrong one once
        for k in range(1, 61):
            t = 0.05 * k
            clock.publish(clock_message(t))
            if waiting and k % 10 == 0:
                waiting = _spin_republishing(
                    clock, t, lambda k=k: len(listener.data) >= k // 10, listener.node
                )
            else:
                listener.drain()
        spin_node_until(listener.node, lambda: False, 0.2)
        assert_hello_world(listener.data, at_least=1)
        if len(listener.data) != 6:
            raise CheckFailed(
                f"talker.py sent {len(listener.data)} messages in 3 simulated seconds; at 2 Hz "
                "that is 6: is the timer period 0.5 s?"
            )
        assert_clean_exit(run)


def wait_until_talker_hears(listener: Listener) -> None:
    """Wait until the talker's publisher on /chatter has found the judge's subscription.

    Matching runs on each side on its own: the judge seeing the talker's publisher does
    not mean the talker sees the judge's subscription, and what the talker sends before
    that is lost (its first message, at 0.5 s of simulated time, is never sent again:
    a right talker would be judged wrong). The talker's side cannot be asked, but its
    node answers its parameter services: a reply can only come once the talker has
    taken in the judge's service client, which the judge announced after the
    subscription, in order. A talker without those services is not waited for."""
    node = listener.node
    named = lambda: [  # noqa: E731
        i for i in node.get_publishers_info_by_topic("/chatter") if not i.node_name.startswith("_")
    ]
    if not spin_node_until(node, lambda: bool(named()), EVENT_GUARD_S):
        return
    talker = named()[0]
    service = f"{talker.node_namespace.rstrip('/')}/{talker.node_name}/list_parameters"
    client = node.create_client(ListParameters, service)
    try:
        if spin_node_until(node, client.service_is_ready, EVENT_GUARD_S):
            reply = client.call_async(ListParameters.Request())
            spin_node_until(node, reply.done, EVENT_GUARD_S)
    finally:
        node.destroy_client(client)


def _spin_republishing(clock: Any, t: float, condition: Callable[[], bool], node: Node) -> bool:
    """Spin until ``condition``, publishing /clock at ``t`` again every 0.2 s meanwhile.

    The talker's /clock subscription can be matched on the judge's side before the
    judge's publisher is matched on the talker's: the first times are then lost, and
    without a repeat a right talker is only waited out (the guard: 10 s). The same time
    again moves nothing, so a wrong talker still sends what it would."""
    deadline = time.monotonic() + EVENT_GUARD_S
    while not spin_node_until(node, condition, 0.2):
        if time.monotonic() > deadline:
            return False
        clock.publish(clock_message(t))
    return True


def _once_more_on_race(part: Callable[[], None]) -> None:
    try:
        part()
    except AssertionError as exc:
        if not rclpy_raced(str(exc)):
            raise
        part()


def check_talker_script(j: Judgement) -> None:
    """Both parts, the simulated-time one in a thread from the moment the wall-time
    part's talker is up (their scripts do not start at once in the sandbox's one CPU).
    The wall-time part's failure is said first, as when they ran one after the other."""
    failed: list[BaseException] = []

    def sim_part() -> None:
        try:
            _once_more_on_race(lambda: _talker_on_sim_time(j))
        except BaseException as exc:  # noqa: BLE001 - said once the wall-time part ended
            failed.append(exc)

    alongside = threading.Thread(target=sim_part, name="talker-on-sim-time")

    def start_alongside() -> None:
        if alongside.ident is None:  # not on the wall-time part's second try
            alongside.start()

    try:
        _once_more_on_race(lambda: _talker_runs(j, start_alongside))
    finally:
        if alongside.ident is not None:
            alongside.join()
    if alongside.ident is None:  # never started alongside: it runs now, all the same
        sim_part()
    if failed:
        raise failed[0]


#: Wall-clock guard on a script's start and first messages (a Python interpreter and
#: rclpy starting in a sandbox that shares one CPU, on a busy machine).
SCRIPT_GUARD_S = 60.0


def wait_for_script(run: ScriptRun, listener: Listener) -> None:
    """Wait until talker.py's publisher on /chatter is found; a /chatter of another type
    fails at once, nothing found in ``SCRIPT_GUARD_S`` is a timeout (never wrong: it may
    be a starved machine), which says what the graph shows."""

    def wrong_type() -> bool:
        types = dict(listener.node.get_topic_names_and_types()).get("/chatter", [])
        return any(t != "std_msgs/msg/String" for t in types)

    spin_node_until(
        listener.node,
        lambda: listener.sub.get_publisher_count() > 0 or not run.alive() or wrong_type(),
        SCRIPT_GUARD_S,
    )
    assert_still_running(run)
    if listener.sub.get_publisher_count() > 0:
        return
    silence = explain_silence(listener.node, "/chatter", String)
    if wrong_type():
        raise CheckFailed(f"talker.py runs but {silence}")
    raise JudgeTimeout(f"talker.py runs but after {SCRIPT_GUARD_S:.0f} s there is still {silence}")


CHECKS = {
    "test_counter_publisher": check_counter_publisher,
    "test_counter_subscriber": check_counter_subscriber,
    "test_doubler": check_doubler,
    "test_talker_script": check_talker_script,
}
