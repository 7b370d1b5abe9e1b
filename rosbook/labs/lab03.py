"""Checks for lab tasks about services, actions and parameters.

Each check talks to the student's node from clients of its own (another node, often
another context), bounds every wait, and fails with a ``CheckFailed`` (an
``AssertionError``) that says what was expected, what was seen and the likely ROS cause.

When graded, the same checks run in the judge on handles (``rosbook.labs.remote``): the
student's node runs in the kernel, following the judge's ``/clock`` in lockstep (one
``RemoteClock`` per node, started by the first check that needs the node to answer:
``_followed_clock``), and the judge calls its service, sends goals to its action, sets its
parameters and listens to its topic from nodes of its own, so every answer is the
judge's to read. One thing is the kernel's word: the simulated time at which each action
feedback was sent (it may be sent while the judge holds a time), used for the pacing
only. The student's client function is called in the kernel against a server of the
judge's whose answer carries a nonce: only a real call can return it, and only the judge
counts the calls.
"""

from __future__ import annotations

import re
import secrets
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rclpy.node import Node
from std_srvs.srv import Trigger
from test_msgs.action import Fibonacci

from rosbook.labs.deferral import deferrable
from rosbook.labs.lockstep import (
    LOCKSTEP_GUARD_S,
    SIM_STEP_S,
    RemoteClock,
    remote_clock,
    wait_for,
    wait_until_discovered,
)
from rosbook.labs.probes import *  # noqa: F403 (the shared probes, as checks.X)
from rosbook.labs.probes import CheckFailed, Probe
from rosbook.labs.remote import (
    EVENT_GUARD_S,
    KERNEL_REPLY_GUARD_S,
    JudgeTimeout,
    KernelError,
    RemoteNode,
    Student,
    Unreadable,
    is_student,
    judgement,
    judging,
)
from rosbook.runtime.actions import GoalRun, run_goal
from rosbook.runtime.interfaces import interface_name
from rosbook.runtime.params import ParameterError, get_parameter, list_parameters, set_parameter
from rosbook.runtime.services import (
    BackgroundServer,
    ServiceCallError,
    ServiceTimeout,
    call,
    run_with_deadline,
)
from rosbook.runtime.session import SimClock, ros

#: Simulated seconds a goal may take in a check before it counts as never finishing.
GOAL_SIM_TIMEOUT_S = 12.0
#: Wall-clock hang guard of a check's wait for another node: to discover its server (in
#: another context or process) and for its answer. Generous: a loaded machine takes
#: seconds to discover a node. Passing it raises ``ServiceTimeout``, a timeout, never a
#: wrong answer.
DISCOVERY_S = 30.0
#: The judge's deadlines for the student's client function, each a hang guard (a loaded
#: machine must not decide what "in time" is): answered, and given up (the allowed
#: slack past its timeout_s).
GRADED_ANSWER_S = EVENT_GUARD_S
GRADED_GIVE_UP_S = 5.0
GRADED_SLACK_S = 3.0


def _fq(node: Node) -> str:
    return node.get_fully_qualified_name()


@contextmanager
def call_failing(what: str) -> Iterator[None]:
    """A call from the check that failed fails the check, saying ``what`` failed; one that
    ran out of time goes on as the ``ServiceTimeout`` it is (a timeout, not a verdict)."""
    try:
        yield
    except ServiceTimeout:
        raise
    except (ServiceCallError, ParameterError) as exc:
        raise CheckFailed(f"{what} failed: {exc}") from None


def _raised_in_kernel(exc: KernelError, name: str) -> str:
    """What ``exc`` (a callback of node ``name`` raised it in the kernel) says of the
    likely mistake."""
    kind, _, detail = str(exc).partition(": ")
    if kind == "TypeError":  # rclpy refuses to send what the service callback returned
        return bad_response(TypeError(detail))
    if kind == "ZeroDivisionError":
        return divided_by_rate(0.0)
    return f"a callback of node '{name}' raised {exc}"


@contextmanager
def _explained_clock(name: str) -> Iterator[RemoteClock]:
    """A ``RemoteClock`` for the kernel's node ``name``; what its callbacks raised comes
    out as the likely mistake."""
    try:
        with remote_clock(judgement(), name) as clock:
            yield clock
    except KernelError as exc:
        raise CheckFailed(_raised_in_kernel(exc, name)) from None


#: The clock each judgement's node follows, by its ``running`` stack.
_clocks: dict[int, RemoteClock] = {}


def _followed_clock(node: RemoteNode) -> RemoteClock:
    """The judge's ``/clock`` that the student's ``node`` (the cell's latest) follows in
    the kernel, in lockstep: started at the first call and kept to the cell's end (or
    its next node), so the node answers calls while the judge holds a time and its time
    only moves on."""
    j = judgement()
    key = id(j.running)
    clock = _clocks.get(key)
    if clock is None:
        clock = j.running.enter_context(_explained_clock(node.get_name()))
        _clocks[key] = clock
        j.running.callback(_clocks.pop, key, None)
    return clock


def assert_serves(node: Node, service: str, srv_type: type) -> None:
    """``node`` has a server of ``srv_type`` on ``service``."""
    own = node.get_service_names_and_types_by_node(node.get_name(), node.get_namespace())
    assert_service_in(node.get_name(), _fq(node), own, service, srv_type)


def assert_service_in(name: str, fq_name: str, own: Any, service: str, srv_type: type) -> None:
    """``own`` (node ``name``'s (service, types)) holds a server of ``srv_type`` on ``service``."""
    service = "/" + service.lstrip("/")
    served = {s: list(types) for s, types in own}
    want = interface_name(srv_type)
    if want in served.get(service, []):
        return
    user = sorted(s for s in served if not s.startswith(fq_name + "/"))
    seen = ", ".join(f"{s} ({', '.join(served[s])})" for s in user) or "none"
    raise CheckFailed(
        f"node '{name}' serves no {want} on {service}; its services: {seen}. "
        f"Check the type and the name passed to create_service()."
    )


def assert_tells_time(server: Node, clock: SimClock, at: float) -> None:
    """Move simulated time to ``at`` s and ask ``what_time`` from a client node of the check
    (graded: in one step of the clock the kernel's node follows)."""
    if is_student(server):
        remote = _followed_clock(server)  # type: ignore[arg-type]
        remote.advance(at - remote.now, step=at - remote.now)
    else:
        clock.advance(at - clock.now, step=0.5)
    client = Node("what_time_check_client")
    try:
        with call_failing("calling what_time"):
            response = call(client, Trigger, "what_time", timeout=DISCOVERY_S)
    except TypeError as exc:  # rclpy refuses to send what the callback returned
        raise CheckFailed(bad_response(exc)) from None
    finally:
        ros.remove(client)
    assert_told_time(response, at)


def assert_told_time(response: Trigger.Response, at: float) -> None:
    """``response`` of what_time, asked when the node's ROS clock read ``at`` s."""
    assert response.success is True, (
        f"what_time answered success={response.success!r}: set response.success = True"
    )
    numbers = [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?", response.message)]
    assert numbers, (
        f"what_time answered message={response.message!r}, which holds no number: put the "
        "node's ROS time in seconds in response.message"
    )
    assert any(abs(n - at) < 0.1 for n in numbers), (
        f"what_time answered {response.message!r} when the node's ROS clock read {at:g} s "
        "(simulated time): use self.get_clock().now() (ROS time), not time.time() or "
        "datetime (wall time), and give seconds (nanoseconds / 1e9)"
    )


def _trigger_call(
    call_trigger: Callable[..., Any],
    service: str,
    timeout_s: float,
    deadline_s: float,
    server_up: bool = False,
) -> tuple[Any, float]:
    """Run the student's ``call_trigger`` under a deadline; (returned value, seconds).

    With ``server_up`` the check first waits until its node has discovered the server
    (another DDS participant can take seconds to meet), so that ``timeout_s`` is spent
    on the call, not on discovery. Graded, it runs in the kernel (``_trigger_in_kernel``).
    """
    if isinstance(call_trigger, Student):
        return _trigger_in_kernel(call_trigger, service, timeout_s, deadline_s, server_up)
    node = Node("trigger_check_client")
    try:
        if server_up:
            seen = node.create_client(Trigger, service)
            try:
                if not seen.wait_for_service(timeout_sec=DISCOVERY_S):
                    raise ServiceTimeout(
                        f"the check's own server on {service} was not discovered within "
                        f"{DISCOVERY_S:g} s (a problem of the grading machine, not of "
                        "your code)"
                    )
            finally:
                node.destroy_client(seen)
        outcome = run_with_deadline(lambda: call_trigger(node, service, timeout_s), deadline_s)
        where = f"call_trigger(node, {service!r}, {timeout_s})"
        finished = outcome.finished
        # Spinning the node ourselves delivers a response a blocked call() waits for.
        unblocked = not finished and ros.spin_until(lambda: outcome.finished, node, timeout=1.0)
        error = outcome.error
        raised = None if error is None else (type(error).__name__, str(error))
        assert_trigger_returned(where, deadline_s, finished, unblocked, raised)
        return outcome.value, outcome.seconds
    finally:
        ros.remove(node)


def _trigger_in_kernel(
    call_trigger: Student, service: str, timeout_s: float, deadline_s: float, server_up: bool
) -> tuple[Any, float]:
    """``_trigger_call`` of the student's function in the kernel, run by the agent on a
    node of its own (``JudgeAgent.call_trigger``)."""
    got = judgement().kernel.call(
        "call_trigger",
        call_trigger.name,
        service,
        timeout_s,
        deadline_s,
        server_up,
        DISCOVERY_S,
        guard=deadline_s + KERNEL_REPLY_GUARD_S,
    )
    if not got["discovered"]:
        raise JudgeTimeout(f"the judge's server on {service} was not discovered from the kernel")
    where = f"call_trigger(node, {service!r}, {timeout_s})"
    raised = got["raised"]
    if raised and raised[0] == "NotImplementedError":
        raise CheckFailed(f"{where}: this task is not done yet (NotImplementedError)")
    assert_trigger_returned(
        where, deadline_s, got["finished"], got["unblocked"], tuple(raised) if raised else None
    )
    return _response(got["value"]), float(got["seconds"])


def _response(plain: dict[str, Any]) -> Any:
    """What the kernel's call returned: a Trigger response rebuilt from its fields, None,
    or what the kernel could only describe."""
    if plain.get("type") == "NoneType":
        return None
    fields = plain.get("fields")
    if plain.get("type") == "Trigger_Response" and fields is not None:
        return Trigger.Response(success=bool(fields["success"]), message=str(fields["message"]))
    return Unreadable(plain["type"], plain.get("repr", repr(plain.get("value"))))


def assert_trigger_returned(
    where: str, deadline_s: float, finished: bool, unblocked: bool, raised: tuple[str, str] | None
) -> None:
    """``where`` (a call of call_trigger) returned within ``deadline_s``, without raising;
    ``unblocked``: it returned only once its node was spun by someone else."""
    if not finished:
        cause = (
            "it returned only once the check spun the node: a synchronous "
            "client.call() (or a wait on the future without spinning) blocks the one "
            "thread that could spin the node and receive the response. This is the "
            "deadlock of a synchronous call inside a callback on a single-threaded "
            "executor. "
            if unblocked
            else "something in it waits without a bound (wait_for_service() with no "
            "timeout_sec, or a synchronous client.call()): a deadlock. "
        )
        raise CheckFailed(
            f"{where} did not return within {deadline_s:g} s; {cause}Send the request "
            "with client.call_async(request) and wait with "
            "rclpy.spin_until_future_complete(node, future, timeout_sec=timeout_s)."
        )
    if raised is not None:
        raise CheckFailed(f"{where} raised {raised[0]}: {raised[1]}")


def assert_call_trigger_answers(call_trigger: Callable[..., Any], service: str) -> None:
    """With a server of the check's own up, ``call_trigger`` returns its response (graded:
    one carrying a nonce, which only a real call can return)."""
    graded = is_student(call_trigger)
    message = f"answered by the check on {service}"
    message += f" ({secrets.token_hex(4)})" if graded else ""

    def answer(request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        response.success = True
        response.message = message
        return response

    with BackgroundServer(Trigger, service, answer, node_name="trigger_check_server") as server:
        value, _ = _trigger_call(
            call_trigger,
            service,
            timeout_s=2.0,
            deadline_s=GRADED_ANSWER_S if graded else 4.0,
            server_up=True,
        )
    assert_trigger_answered(value, server.calls, service, message)


def assert_trigger_answered(value: Any, calls: int, service: str, message: str) -> None:
    """call_trigger returned ``value`` after ``calls`` calls reached the server on
    ``service``, which answered success=True and ``message``."""
    assert calls >= 1, (
        f"call_trigger returned {value!r} without calling {service}: create a client "
        "for the service_name argument and send a request"
    )
    assert isinstance(value, Trigger.Response), (
        f"call_trigger returned {value!r} ({type(value).__name__}); it must return the "
        "Trigger.Response (future.result()) when the server answers"
    )
    assert value.message == message and value.success, (
        f"call_trigger returned {value!r}, not the server's response"
    )


def assert_call_trigger_gives_up(
    call_trigger: Callable[..., Any], service: str, timeout_s: float, slow_server: bool
) -> None:
    """With no server (or one slower than ``timeout_s``), ``call_trigger`` returns None in time."""
    server = None
    if slow_server:

        def slow(request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
            assert server is not None
            server.stopping.wait(timeout_s + 2.0)
            response.success = True
            return response

        server = BackgroundServer(Trigger, service, slow, node_name="slow_check_server")
    what = "a server slower than the timeout" if slow_server else "no server"
    graded = is_student(call_trigger)
    deadline_s = timeout_s + (GRADED_GIVE_UP_S if graded else 1.5)
    try:
        value, seconds = _trigger_call(
            call_trigger, service, timeout_s, deadline_s, server_up=slow_server
        )
    finally:
        if server is not None:
            server.close()
    slack = GRADED_SLACK_S if graded else 1.0
    assert_trigger_gave_up(value, seconds, service, timeout_s, what, slack=slack)


def assert_trigger_gave_up(
    value: Any, seconds: float, service: str, timeout_s: float, what: str, slack: float = 1.0
) -> None:
    """call_trigger, with ``what`` on ``service``, returned ``value`` after ``seconds``."""
    assert value is None, (
        f"call_trigger(node, {service!r}, {timeout_s}) with {what} returned {value!r}; "
        "it must return None when no response came within timeout_s"
    )
    assert seconds < timeout_s + slack, (
        f"call_trigger with {what} took {seconds:.1f} s for timeout_s={timeout_s}: bound "
        "the waits by timeout_s"
    )


# -- actions -----------------------------------------------------------------------------
def sim_spinner(
    clock: SimClock | RemoteClock, step: float = SIM_STEP_S
) -> Callable[[Callable[[], bool], float], bool]:
    """A ``spin(condition, timeout)`` for ``run_goal`` that advances simulated time.

    ``timeout`` counts simulated seconds.
    """

    def spin(condition: Callable[[], bool], timeout: float) -> bool:
        end = clock.now + timeout
        while not condition():
            if clock.now >= end - 1e-9:
                return False
            clock.advance(min(step, end - clock.now), step=step)
        return True

    return spin


#: The node of the check's action client.
CLIENT_NODE = "countdown_check_client"


def countdown(
    clock: SimClock,
    order: int,
    cancel_after: int | None = None,
    on_feedback: Callable[[Any], None] | None = None,
    on_ready: Callable[[], None] | None = None,
) -> GoalRun:
    """Send a countdown goal to ``countdown`` from a client node of the check
    (``CLIENT_NODE``); ``on_ready`` as for ``run_goal``. Graded, to the node the cell
    started in the kernel, on the clock it follows (``_followed_clock``)."""
    j = judging()
    if j is not None and j.started is not None:
        return _countdown_in_kernel(_followed_clock(j.started), order, cancel_after, on_feedback)
    return _countdown(clock, order, cancel_after, on_feedback, on_ready)


def _countdown(
    clock: SimClock | RemoteClock,
    order: int,
    cancel_after: int | None,
    on_feedback: Callable[[Any], None] | None,
    on_ready: Callable[[], None] | None,
) -> GoalRun:
    client = Node(CLIENT_NODE)
    try:
        with call_failing("sending a goal to 'countdown'"):
            return run_goal(
                client,
                Fibonacci,
                "countdown",
                Fibonacci.Goal(order=order),
                timeout=GOAL_SIM_TIMEOUT_S,
                discovery=DISCOVERY_S,
                cancel_after=cancel_after,
                on_feedback=on_feedback,
                on_ready=on_ready,
                spin=sim_spinner(clock),
            )
    finally:
        ros.remove(client)


def _countdown_in_kernel(
    clock: RemoteClock,
    order: int,
    cancel_after: int | None,
    on_feedback: Callable[[Any], None] | None,
) -> GoalRun:
    """A countdown goal to the kernel's node: each step waits for the feedback the node
    said it sent; each feedback is stamped with the node's clock when it was sent (sent
    while the judge holds a time, it is that time)."""
    before = len(clock.acked[-1]["feedback_at"])
    arrived = [0]
    clock.arrived = lambda published: arrived[0] >= published.get("feedback", 0) - before

    def counted(feedback: Any) -> None:
        arrived[0] += 1
        if on_feedback is not None:
            on_feedback(feedback)

    run = _countdown(
        clock,
        order,
        cancel_after,
        counted,
        lambda: wait_until_discovered(
            clock.acked, clock.node, "/countdown/_action/feedback", CLIENT_NODE, clock.name
        ),
    )
    wait_for(
        lambda: len(clock.acked[-1]["feedback_at"]) >= before + len(run.feedback),
        clock.node,
        what="the kernel did not say when it sent the feedback",
        guard=LOCKSTEP_GUARD_S,
    )
    sent_at = clock.acked[-1]["feedback_at"][before : before + len(run.feedback)]
    run.feedback_times = [t / 1e9 for t in sent_at]
    return run


def bad_response(exc: Exception) -> str:
    """The likely mistake behind rclpy's TypeError on sending a service response."""
    detail = f" ({type(exc).__name__}: {exc})" if str(exc) else ""
    return (
        "the service callback returned nothing (None), or something that is not a "
        "Trigger response, so no answer could be sent: fill in `response` and end the "
        f"callback with `return response`{detail}"
    )


def _pacing_hint(gaps: list[float], rate_hz: float) -> str:
    """Why steps were paced ``gaps`` apart instead of ``1 / rate_hz``."""
    if len(gaps) >= 2 and max(gaps) - min(gaps) <= 0.021 and gaps[0] > 0.021:
        seen = 1.0 / gaps[0]
        return (
            f"the steps were evenly paced at {gaps[0]:g} s, the pace of rate_hz={seen:g}, "
            f"not of rate_hz={rate_hz:g}: read the parameter at each step "
            "(self.get_parameter('rate_hz').value inside the loop), not once in __init__, "
            "so a change made while the node runs takes effect"
        )
    return (
        "pace the steps with the node's clock (await rosbook.runtime.actions.sleep(self, 1.0 / "
        "rate) or a timer), not time.sleep(), which blocks the executor and ignores "
        "simulated time"
    )


def _sequences(run: GoalRun) -> list[list[int]]:
    return [list(f.sequence) for f in run.feedback]


def assert_counts_down(run: GoalRun, order: int, rate_hz: float) -> None:
    """The goal succeeded with feedback [N], [N, N-1], ... paced at ``rate_hz``."""
    expected = list(range(order, -1, -1))
    assert run.accepted, f"the goal order={order} was rejected: accept goals (the default does)"
    assert run.status_name == "SUCCEEDED", (
        f"the goal order={order} ended {run.status_name} after feedback {_sequences(run)}; "
        "expected SUCCEEDED (goal_handle.succeed() when the count reaches 0)"
    )
    got = list(run.result.sequence)
    assert got == expected, f"result.sequence for order={order}: expected {expected}, got {got}"
    want = [expected[: k + 1] for k in range(len(expected))]
    assert _sequences(run) == want, (
        f"feedback for order={order}: expected one message per step {want}, got {_sequences(run)}"
    )
    period = 1.0 / rate_hz
    gaps = [round(b - a, 3) for a, b in zip(run.feedback_times, run.feedback_times[1:])]
    assert all(abs(g - period) <= 0.021 for g in gaps), (
        f"feedback came {gaps} s apart (simulated time) with rate_hz={rate_hz:g}; expected "
        f"{period:g} s: {_pacing_hint(gaps, rate_hz)}"
    )


def assert_cancel_honoured(run: GoalRun, rate_hz: float) -> None:
    """Cancelled mid-way, the goal ended CANCELED within one step."""
    counted = _sequences(run)
    at = counted[run.cancel_sent_at - 1] if run.cancel_sent_at else []
    assert run.cancel_sent_at is not None, (
        f"the goal ended ({run.status_name}) before the check could cancel it"
    )
    assert run.status_name != "SUCCEEDED", (
        f"after a cancel request at {at} the goal went on to SUCCEEDED "
        f"({list(run.result.sequence)}): the cancel was ignored. Pass "
        "cancel_callback=... returning CancelResponse.ACCEPT to the ActionServer (the "
        "default rejects every cancel), check goal_handle.is_cancel_requested at each "
        "step and end with goal_handle.canceled()"
    )
    assert run.status_name == "CANCELED", (
        f"after a cancel request at {at} the goal's final status was {run.status_name}; "
        "expected CANCELED (goal_handle.canceled() when is_cancel_requested)"
    )
    assert run.end_time is not None and run.cancel_time is not None
    late = run.end_time - run.cancel_time
    # One step, plus the simulated clock's granularity in reading the result's arrival;
    # a server that checks only every other step is a whole step later still.
    assert late <= 1.0 / rate_hz + 0.2, (
        f"the goal stopped {late:.2f} s after the cancel request; expected within one "
        f"step ({1.0 / rate_hz:g} s): check is_cancel_requested at every step"
    )
    assert len(counted) <= run.cancel_sent_at + 1, (
        f"after the cancel request at {at} the server still sent {counted[run.cancel_sent_at :]}"
    )


# -- parameters --------------------------------------------------------------------------
def assert_declared(node: Node, name: str, default: Any, via: Node | None = None) -> None:
    """``node`` declared ``name`` and it reads ``default``, as seen from another node."""
    if is_student(node):
        _followed_clock(node)  # type: ignore[arg-type]
    asker = via or Node("param_check_client")
    try:
        with call_failing(f"reading the parameters of '{node.get_name()}'"):
            names = list_parameters(asker, _fq(node), timeout=DISCOVERY_S)
            assert name in names, (
                f"node '{node.get_name()}' has no parameter '{name}' (its parameters: "
                f"{', '.join(names)}): declare it in __init__ with "
                f"self.declare_parameter('{name}', {default!r})"
            )
            value = get_parameter(asker, _fq(node), name, timeout=DISCOVERY_S)
    finally:
        if via is None:
            ros.remove(asker)
    assert value == default and type(value) is type(default), (
        f"parameter '{name}' reads {value!r} ({type(value).__name__}); its default must "
        f"be {default!r} ({type(default).__name__})"
    )


def set_from_outside(target: Node, name: str, value: Any, via: Node | None = None) -> Any:
    """Set ``target``'s parameter from a node of the check, as ``ros2 param set`` does."""
    if is_student(target):
        _followed_clock(target)  # type: ignore[arg-type]
    setter = via or Node("param_check_client")
    try:
        with call_failing(f"setting '{name}' from outside"):
            return set_parameter(setter, _fq(target), name, value, timeout=DISCOVERY_S)
    finally:
        if via is None:
            ros.remove(setter)


def divided_by_rate(bad: float) -> str:
    """The likely mistake when setting rate_hz to ``bad`` raised ZeroDivisionError."""
    return (
        f"setting rate_hz to {bad} was accepted and the node then divided by it "
        "(ZeroDivisionError): the on-set parameters callback must reject every "
        "value <= 0, zero included, with SetParametersResult(successful=False, "
        "reason=...) before the value is used"
    )


def tick_gaps(probe: Probe, clock: SimClock | RemoteClock, seconds: float) -> list[float]:
    """Advance ``seconds`` and return the gaps between the messages that arrived."""
    start = len(probe.received.times)
    clock.advance(seconds, step=SIM_STEP_S)
    times = probe.received.times[start:]
    return [round(b - a, 3) for a, b in zip(times, times[1:])]


def assert_rate_follows(node: Node, clock: SimClock, probe: Probe) -> None:
    """The timer runs at ``rate_hz``, follows a change from outside and refuses rates <= 0
    (graded: on the clock the kernel's node follows, each step held until what the node
    sent has reached ``probe``)."""
    if is_student(node) and probe.topic in dict(
        node.get_publisher_names_and_types_by_node(node.get_name(), node.get_namespace())
    ):  # what it said it publishes is on the graph before the probe is judged silent
        judgement().wait_on_graph(node.get_name(), probe.topic, "publisher")
    probe.wait_for_publisher()
    if is_student(node):
        clock = _followed_clock(node)  # type: ignore[arg-type,assignment]
        clock.arrived = lambda published: (  # type: ignore[attr-defined]
            len(probe.received.messages) >= published.get(probe.topic, 0)
        )
    outsider = Node("param_check_client")
    try:
        _assert_rate_follows(node, clock, probe, outsider)
    finally:
        ros.remove(outsider)


def _assert_rate_follows(
    node: Node, clock: SimClock | RemoteClock, probe: Probe, outsider: Node
) -> None:
    assert_declared(node, "rate_hz", 2.0, via=outsider)
    gaps = tick_gaps(probe, clock, 2.0)
    assert len(gaps) >= 2 and all(abs(g - 0.5) < 0.015 for g in gaps), (
        f"at the default rate_hz=2.0 'ticks' came {gaps} s apart; expected 0.5 s"
    )
    result = set_from_outside(node, "rate_hz", 5.0, via=outsider)
    assert result.successful, (
        f"setting rate_hz to 5.0 from outside was refused ({result.reason!r}): only "
        "values <= 0 may be rejected"
    )
    gaps = tick_gaps(probe, clock, 2.0)
    assert len(gaps) >= 6 and all(abs(g - 0.2) < 0.015 for g in gaps[-5:]), (
        f"after rate_hz was set to 5.0 'ticks' came {gaps} s apart; expected 0.2 s: "
        "the timer must follow the parameter (re-create it, or change its period, when "
        "the value changes)"
    )
    for bad in (-1.0, 0.0):
        try:
            result = set_from_outside(node, "rate_hz", bad, via=outsider)
        except ZeroDivisionError:
            raise AssertionError(divided_by_rate(bad)) from None
        assert not result.successful, (
            f"setting rate_hz to {bad} was accepted: an on-set parameters callback "
            "(add_on_set_parameters_callback) must return SetParametersResult("
            "successful=False, reason=...) for values <= 0"
        )
        assert result.reason, f"rejecting rate_hz={bad} must give a reason"
    with call_failing(f"reading the parameters of '{node.get_name()}'"):
        value = get_parameter(outsider, _fq(node), "rate_hz", timeout=DISCOVERY_S)
    assert value == 5.0, f"after refused changes rate_hz reads {value!r}; expected 5.0"
    gaps = tick_gaps(probe, clock, 1.0)
    assert gaps and all(abs(g - 0.2) < 0.015 for g in gaps), (
        f"after refused changes 'ticks' came {gaps} s apart; expected 0.2 s still"
    )


deferrable(globals())
