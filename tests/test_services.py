"""rosbook.runtime services / actions / params / interfaces and lab 3 checks on live nodes."""

from __future__ import annotations

import time
import warnings

import pytest
from action_msgs.msg import GoalStatus
from rcl_interfaces.msg import SetParametersResult
from rclpy.action import ActionServer
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data, qos_profile_services_default
from std_msgs.msg import Int64
from std_srvs.srv import SetBool, Trigger
from test_msgs.action import Fibonacci

from rosbook.demos.nodes import ClockServer, CountdownServer
from rosbook.labs import lab03 as service_checks
from rosbook.labs.probes import Probe
from rosbook.runtime.actions import clients_listen, run_goal, sleep
from rosbook.runtime.executors import SingleThreadedExecutor
from rosbook.runtime.interfaces import InterfaceError, definition, from_yaml, message_class
from rosbook.runtime.params import ParameterError, get_parameter, list_parameters, set_parameter
from rosbook.runtime.services import BackgroundServer, ServiceCallError, call, run_with_deadline
from rosbook.runtime.session import Session


def test_call_returns_the_response_of_a_server_in_the_session(session: Session) -> None:
    server = ClockServer()
    response = call(Node("asker"), SetBool, "switch", SetBool.Request(data=True))
    assert (response.success, response.message, server.switched_on) == (True, "on", True)


def test_call_without_a_server_fails_in_time_naming_service_and_type(session: Session) -> None:
    start = time.monotonic()
    with pytest.raises(ServiceCallError, match=r"no server for '/nobody \(std_srvs/srv/Trigger\)'"):
        call(Node("asker"), Trigger, "nobody", timeout=0.3)
    assert time.monotonic() - start < 10.0  # bounded by its timeout, not hanging


def test_a_synchronous_call_in_the_spinning_thread_is_stuck_and_bounded(session) -> None:
    ClockServer()
    asker = Node("asker")
    client = asker.create_client(Trigger, "what_time")
    assert client.wait_for_service(timeout_sec=2.0)
    stuck = run_with_deadline(lambda: client.call(Trigger.Request()), 1.0)
    assert not stuck.finished and 1.0 <= stuck.seconds < 10.0
    # Spinning (server and client) is what was missing: the blocked call then returns.
    assert session.spin_until(lambda: stuck.finished, timeout=2.0)
    assert stuck.value.success


def test_background_server_answers_without_the_session_spinning_it(session) -> None:
    def answer(request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success, response.message = True, "from the background"
        return response

    with BackgroundServer(Trigger, "bg", answer) as server:
        response = call(Node("asker"), Trigger, "bg", timeout=10.0)  # another participant
    assert (response.message, server.calls) == ("from the background", 1)


def test_countdown_on_simulated_time_has_exact_steps_and_no_timer_left(session) -> None:
    clock = session.sim_clock()
    server = CountdownServer()
    timers = len(list(server.timers))
    run = service_checks.countdown(clock, order=3)
    service_checks.assert_counts_down(run, order=3, rate_hz=2.0)
    gaps = [round(b - a, 3) for a, b in zip(run.feedback_times, run.feedback_times[1:])]
    assert gaps == [0.5, 0.5, 0.5]
    assert len(list(server.timers)) == timers, "sleep() must destroy its one-shot timers"


def test_cancel_is_honoured_within_one_step(session) -> None:
    clock = session.sim_clock()
    CountdownServer()
    run = service_checks.countdown(clock, order=10, cancel_after=3)
    service_checks.assert_cancel_honoured(run, rate_hz=2.0)
    assert list(run.result.sequence) == [10, 9, 8]


class DeafCountdown(CountdownServer):
    """The usual mistake: no cancel_callback, so every cancel request is rejected."""

    def __init__(self) -> None:
        Node.__init__(self, "countdown_server")
        self.declare_parameter("rate_hz", 2.0)
        self.server = ActionServer(self, Fibonacci, "countdown", self.execute)


def test_ignored_cancel_is_reported(session) -> None:
    clock = session.sim_clock()
    DeafCountdown()
    run = service_checks.countdown(clock, order=4, cancel_after=2)
    assert run.status_name == "SUCCEEDED"
    with pytest.raises(AssertionError, match="the cancel was ignored"):
        service_checks.assert_cancel_honoured(run, rate_hz=2.0)


class SlowToCancel(CountdownServer):
    """Honours a cancel, but looks for one only every other step (one step late)."""

    async def execute(self, goal_handle):  # type: ignore[no-untyped-def]
        counted = [goal_handle.request.order]
        goal_handle.publish_feedback(Fibonacci.Feedback(sequence=counted))
        while counted[-1] > 0:
            await sleep(self, 0.5)
            if goal_handle.is_cancel_requested and len(counted) % 2 == 0:
                goal_handle.canceled()
                return Fibonacci.Result(sequence=counted)
            counted.append(counted[-1] - 1)
            goal_handle.publish_feedback(Fibonacci.Feedback(sequence=counted))
        goal_handle.succeed()
        return Fibonacci.Result(sequence=counted)


def test_a_cancel_honoured_a_step_late_is_reported(session) -> None:
    clock = session.sim_clock()
    SlowToCancel()
    run = service_checks.countdown(clock, order=10, cancel_after=3)
    assert run.status_name == "CANCELED"
    with pytest.raises(AssertionError, match=r"the goal stopped 1\.\d+ s after the cancel"):
        service_checks.assert_cancel_honoured(run, rate_hz=2.0)


def test_run_goal_wall_time_prints_feedback(session) -> None:
    CountdownServer().set_parameters([Parameter("rate_hz", value=20.0)])
    seen: list[list[int]] = []
    run = run_goal(
        Node("user"),
        Fibonacci,
        "countdown",
        Fibonacci.Goal(order=2),
        on_feedback=lambda f: seen.append(list(f.sequence)),
    )
    assert (run.status_name, seen) == ("SUCCEEDED", [[2], [2, 1], [2, 1, 0]])


def test_a_server_waits_for_a_goal_senders_feedback_subscription(session) -> None:
    """A goal sender whose feedback subscription is not known yet is waited for."""
    server = Node("server")

    def waited(guard: float) -> bool:
        executor = SingleThreadedExecutor()
        executor.add_node(server)
        task = executor.create_task(clients_listen(server, "countdown", guard))
        executor.spin_until_future_complete(task, timeout_sec=60.0)
        executor.shutdown()
        assert task.done(), "clients_listen outlived its guard"
        return task.result()

    assert waited(0.1)  # nobody sends goals: nobody to wait for
    # A goal sender's request writer, without its feedback subscription (yet)
    Node("sender").create_client(Fibonacci.Impl.SendGoalService, "countdown/_action/send_goal")
    assert not waited(0.3)
    Node("listener").create_subscription(
        Fibonacci.Impl.FeedbackMessage, "countdown/_action/feedback", lambda _: None, 10
    )
    assert waited(10.0)


class RecordingCountdown(CountdownServer):
    """The countdown server, remembering how each goal ended."""

    def __init__(self) -> None:
        super().__init__()
        self.ended: list[int] = []

    async def execute(self, goal_handle):  # type: ignore[no-untyped-def]
        result = await super().execute(goal_handle)
        self.ended.append(goal_handle.status)
        return result


def converted_interrupt() -> BaseException:
    """Ctrl-C while rclpy's C++ code turns a message into Python: pybind11 raises this."""
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt as exc:
        error = TypeError("Unable to convert function return value to a Python type!")
        error.__cause__ = exc
        return error


@pytest.mark.parametrize(
    "interrupt", [KeyboardInterrupt, converted_interrupt], ids=["plain", "converted"]
)
def test_interrupting_run_goal_cancels_the_goal_before_the_interrupt_goes_on(
    session, interrupt
) -> None:
    server = RecordingCountdown()
    server.set_parameters([Parameter("rate_hz", value=20.0)])
    seen: list[int] = []
    interrupted = []

    def spin(condition, timeout):  # type: ignore[no-untyped-def]
        def check() -> bool:
            if len(seen) >= 2 and not interrupted:
                interrupted.append(True)
                raise interrupt()  # as Ctrl-C would, in the middle of the wait
            return condition()

        return session.spin_until(check, timeout=timeout)

    with pytest.raises(KeyboardInterrupt):
        run_goal(
            Node("user"),
            Fibonacci,
            "countdown",
            Fibonacci.Goal(order=50),
            on_feedback=lambda f: seen.append(f.sequence[-1]),
            spin=spin,
        )
    assert session.spin_until(lambda: bool(server.ended), timeout=5.0)
    assert server.ended == [GoalStatus.STATUS_CANCELED]
    assert len(seen) < 10, "the countdown stopped soon after the interrupt"


def test_parameters_from_outside(session) -> None:
    ClockServer()
    outsider = Node("outsider")
    assert "rate_hz" in list_parameters(outsider, "/clock_server")
    assert get_parameter(outsider, "/clock_server", "rate_hz") == 2.0
    assert set_parameter(outsider, "/clock_server", "rate_hz", "4.5").successful
    assert get_parameter(outsider, "/clock_server", "rate_hz") == 4.5
    refused = set_parameter(outsider, "/clock_server", "rate_hz", -1.0)
    assert (refused.successful, refused.reason) == (False, "rate_hz must be > 0")
    with pytest.raises(ParameterError, match="has no parameter 'rate'"):
        get_parameter(outsider, "/clock_server", "rate")


def test_interfaces_by_name_yaml_and_definition() -> None:
    assert message_class("std_srvs/srv/SetBool") is SetBool
    assert from_yaml(SetBool.Request, "{data: true}").data is True
    goal = from_yaml(Fibonacci.Goal, "order: 5")
    assert goal.order == 5
    assert "bool success" in definition("std_srvs/srv/Trigger")
    assert definition("test_msgs/action/Fibonacci").count("---") == 2
    for bad, message in [
        ("std_srvs/Trigger", "is not an interface name"),
        ("no_pkg/srv/X", "no package 'no_pkg'"),
        ("std_srvs/srv/Nope", "'std_srvs' has no srv 'Nope'"),
    ]:
        with pytest.raises(InterfaceError, match=message):
            message_class(bad)
    with pytest.raises(InterfaceError, match="cannot be 'yes please'"):
        from_yaml(Fibonacci.Goal, "{order: 'yes please'}")


def sync_call_trigger(node: Node, service_name: str, timeout_s: float):  # noqa: ANN201
    """A student's call_trigger with the blocking call: deadlocks when nobody spins."""
    client = node.create_client(Trigger, service_name)
    if not client.wait_for_service(timeout_sec=timeout_s):
        return None
    return client.call(Trigger.Request())


def test_check_names_the_deadlock_of_a_synchronous_call_quickly(session) -> None:
    start = time.monotonic()
    with pytest.raises(AssertionError, match="deadlock of a synchronous call inside a callback"):
        service_checks.assert_call_trigger_answers(sync_call_trigger, "check_trigger")
    assert time.monotonic() - start < 20.0  # named well before the grader's cell limit


def test_check_of_undeclared_parameter_says_declare_it(session) -> None:
    clock = session.sim_clock()

    class Undeclared(Node):
        def __init__(self) -> None:
            super().__init__("rate_publisher")
            self.rate_hz = 2.0

    node = Undeclared()
    with pytest.raises(AssertionError, match=r"declare it in __init__ with self.declare_parameter"):
        service_checks.assert_declared(node, "rate_hz", 2.0)
    assert clock.now == 0.0


class SilentClock(Node):
    """The usual mistake: the service callback fills in the response but returns nothing."""

    def __init__(self) -> None:
        super().__init__("clock_server")
        self.create_service(Trigger, "what_time", self.on_what_time)

    def on_what_time(self, request, response):  # type: ignore[no-untyped-def]
        response.success = True
        response.message = f"It is {self.get_clock().now().nanoseconds / 1e9:.3f} s"


def test_a_service_callback_that_returns_nothing_is_named(session) -> None:
    clock = session.sim_clock()
    server = SilentClock()
    with pytest.raises(AssertionError, match=r"returned nothing \(None\).*return response"):
        service_checks.assert_tells_time(server, clock, at=1.5)


class RateReadOnce(CountdownServer):
    """The usual mistake: rate_hz read once in __init__, so a later change is ignored."""

    def __init__(self) -> None:
        super().__init__()
        self.rate_at_start = super().get_parameter("rate_hz")

    def get_parameter(self, name: str):  # type: ignore[no-untyped-def]
        """What the countdown reads at each step: the value from __init__."""
        return self.rate_at_start if name == "rate_hz" else super().get_parameter(name)


def test_a_rate_read_once_is_named_not_blamed_on_time_sleep(session) -> None:
    clock = session.sim_clock()
    server = RateReadOnce()
    assert service_checks.set_from_outside(server, "rate_hz", 5.0).successful
    run = service_checks.countdown(clock, order=3)
    with pytest.raises(AssertionError, match="not once in __init__") as raised:
        service_checks.assert_counts_down(run, order=3, rate_hz=5.0)
    assert "time.sleep" not in str(raised.value)


class ZeroRateAccepted(Node):
    """The usual mistake: only negative rates are refused, so 0 reaches 1.0 / rate."""

    def __init__(self) -> None:
        super().__init__("rate_publisher")
        self.declare_parameter("rate_hz", 2.0)
        self.publisher_ = self.create_publisher(Int64, "ticks", 10)
        self.count = 0
        self.timer = self.create_timer(0.5, self.tick)
        self.add_on_set_parameters_callback(self.on_set)

    def tick(self) -> None:
        self.publisher_.publish(Int64(data=self.count))
        self.count += 1

    def on_set(self, parameters):  # type: ignore[no-untyped-def]
        for parameter in parameters:
            if parameter.value < 0:
                return SetParametersResult(successful=False, reason="negative")
            self.destroy_timer(self.timer)
            self.timer = self.create_timer(1.0 / parameter.value, self.tick)
        return SetParametersResult(successful=True)


def test_accepting_a_zero_rate_is_named_not_only_zero_division(session) -> None:
    clock = session.sim_clock()
    node = ZeroRateAccepted()
    probe = Probe("ticks", Int64)
    with pytest.raises(AssertionError, match="every value <= 0, zero included"):
        service_checks.assert_rate_follows(node, clock, probe)


def test_a_server_waits_for_its_clients_reply_reader_before_it_drops_the_reply(session) -> None:
    # A reply sent before the server has discovered the client's reply reader is
    # dropped, and the caller waits forever; a busy machine widens that race. The
    # book's Fast DDS profile makes a server wait up to 5 s for the reader (0.1 s by
    # default). A client whose reply reader can never match (it asks for a reliable
    # reply; the server offers best effort) shows the wait: the server gives up only then.
    server = Node("lossy_server")
    server.create_service(Trigger, "lossy", lambda _, r: r, qos_profile=qos_profile_sensor_data)
    asker = Node("asker")
    client = asker.create_client(Trigger, "lossy", qos_profile=qos_profile_services_default)
    # one participant (one context): its endpoints match as they are made, and a client
    # that can never hear its server is never "ready", so it calls at once
    client.call_async(Trigger.Request())
    start = time.monotonic()
    with warnings.catch_warnings(record=True) as seen:  # rclpy warns that it dropped the reply
        warnings.simplefilter("always")
        dropped = session.spin_until(  # the limit only guards against a hang
            lambda: any("client will not receive response" in str(w.message) for w in seen),
            timeout=300.0,
        )
    waited = time.monotonic() - start
    assert dropped, "timeout: the server neither answered nor dropped the reply"
    assert waited >= 4.5, f"the server dropped the reply after {waited:.2f} s"
