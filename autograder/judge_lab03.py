"""Lab 3's checks as the judge runs them: verdicts from service calls and what they return.

The student's nodes run in the kernel, following the judge's ``/clock`` in lockstep
(``RemoteClock``); the judge calls their service, sends goals to their action, sets their
parameters and listens to their topic from nodes of its own, so every answer is the
judge's to read. One thing is the kernel's word: the simulated time at which each action
feedback was sent (it may be sent while the judge holds a time), used for the pacing
only; the feedback, the result and the status are what arrived. The student's client
function is called by the agent against a server of the judge's own whose answer carries
a nonce: only a real call can return it, and only the judge counts the calls. The
messages are those of ``rosbook.labs.lab03``, which the in-kernel checks share.
"""

from __future__ import annotations

import secrets
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from std_msgs.msg import Int64
from std_srvs.srv import Trigger

from autograder.judge import (
    EVENT_GUARD_S,
    KERNEL_REPLY_GUARD_S,
    CheckFailed,
    Judgement,
    JudgeTimeout,
    KernelError,
    Unreadable,
    ros_node,
)
from rosbook.labs import lab03 as service_checks
from rosbook.labs.lockstep import (
    LOCKSTEP_GUARD_S,
    RemoteClock,
    RemoteNode,
    remote_clock,
    require_endpoint,
    require_name,
    wait_for,
    wait_until_discovered,
)
from rosbook.labs.probes import Probe, assert_sequence
from rosbook.runtime.actions import GoalRun
from rosbook.runtime.services import BackgroundServer, call
from rosbook.runtime.session import ros


def _raised_in_kernel(exc: KernelError, name: str) -> str:
    """What ``exc`` (a callback of node ``name`` raised it) says of the likely mistake."""
    kind, _, detail = str(exc).partition(": ")
    if kind == "TypeError":  # rclpy refuses to send what the service callback returned
        return service_checks.bad_response(TypeError(detail))
    if kind == "ZeroDivisionError":
        return service_checks.divided_by_rate(0.0)
    return f"a callback of node '{name}' raised {exc}"


@contextmanager
def kernel_errors_explained(name: str) -> Iterator[None]:
    try:
        yield
    except KernelError as exc:
        raise CheckFailed(_raised_in_kernel(exc, name)) from None


def _made(factory: str, kwargs: dict[str, Any]) -> str:
    return f"{factory}({', '.join(f'{k}={v!r}' for k, v in kwargs.items())})"


def check_clock_server(j: Judgement) -> None:
    for kwargs, name, times in (
        ({}, "clock_server", (12.5,)),
        ({"node_name": "clock_b"}, "clock_b", (3.25, 40.0)),
    ):
        ros.reset()
        info = j.start_node("ClockServer", sim_time=True, **kwargs)
        require_name(info, _made("ClockServer", kwargs), name)
        own = j.kernel.call("services")
        service_checks.assert_service_in(name, "/" + name, own, "what_time", Trigger)
        with kernel_errors_explained(name), remote_clock(j, name) as clock:
            for at in times:
                clock.advance(at - clock.now, step=at - clock.now)
                asker = ros_node("what_time_check_client")
                try:
                    with service_checks.call_failing("calling what_time"):
                        response = call(
                            asker, Trigger, "what_time", timeout=service_checks.DISCOVERY_S
                        )
                finally:
                    ros.remove(asker)
                service_checks.assert_told_time(response, at)


def _goal(clock: RemoteClock, order: int, cancel_after: int | None = None) -> GoalRun:
    """A countdown goal from the judge's client; feedback stamped with the kernel node's
    clock at each publish (sent while the judge holds a time, it is that time)."""
    before = len(clock.acked[-1]["feedback_at"])
    arrived = [0]
    clock.arrived = lambda published: arrived[0] >= published.get("feedback", 0) - before
    run = service_checks.countdown(
        clock,
        order,
        cancel_after,
        on_feedback=lambda _: arrived.__setitem__(0, arrived[0] + 1),
        on_ready=lambda: wait_until_discovered(
            clock.acked,
            clock.node,
            "/countdown/_action/feedback",
            service_checks.CLIENT_NODE,
            clock.name,
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


def check_countdown_action(j: Judgement) -> None:
    ros.init(sim_time=True)  # the judge's client reads the judge's /clock
    for kwargs, name, hidden in (
        ({}, "countdown_server", False),
        ({"node_name": "countdown_b"}, "countdown_b", True),
    ):
        ros.reset()
        info = j.start_node("CountdownServer", sim_time=True, **kwargs)
        require_name(info, _made("CountdownServer", kwargs), name)
        with kernel_errors_explained(name), remote_clock(j, name) as clock:
            if not hidden:
                service_checks.assert_counts_down(_goal(clock, 3), order=3, rate_hz=2.0)
                service_checks.assert_cancel_honoured(_goal(clock, 10, 3), rate_hz=2.0)
                continue
            server = RemoteNode(name)
            service_checks.assert_declared(server, "rate_hz", 2.0)  # type: ignore[arg-type]
            result = service_checks.set_from_outside(server, "rate_hz", 5.0)  # type: ignore[arg-type]
            if not result.successful:
                raise CheckFailed(f"setting rate_hz to 5.0 was refused: {result.reason!r}")
            service_checks.assert_counts_down(_goal(clock, 6), order=6, rate_hz=5.0)
            service_checks.assert_counts_down(_goal(clock, 0), order=0, rate_hz=5.0)
            service_checks.assert_cancel_honoured(_goal(clock, 20, 5), rate_hz=5.0)


def check_rate_parameter(j: Judgement) -> None:
    ros.init(sim_time=True)  # the judge's probe stamps ticks with the judge's /clock
    for kwargs, name, hidden in (
        ({}, "rate_publisher", False),
        ({"node_name": "rate_b"}, "rate_b", True),
    ):
        ros.reset()
        info = j.start_node("RatePublisher", sim_time=True, **kwargs)
        require_name(info, _made("RatePublisher", kwargs), name)
        require_endpoint(info, "/ticks", Int64, "publisher")
        j.wait_on_graph(name, "/ticks", "publisher")
        probe = Probe("ticks", Int64)
        with kernel_errors_explained(name), remote_clock(j, name) as clock:
            clock.arrived = lambda published, probe=probe: (
                len(probe.received.messages) >= published.get("/ticks", 0)
            )
            service_checks.assert_rate_follows(RemoteNode(name), clock, probe)  # type: ignore[arg-type]
        if hidden:
            data = [m.data for m in probe.received.messages]
            assert_sequence("'ticks'", data, list(range(len(data))))


def trigger_call(
    j: Judgement, service: str, timeout_s: float, deadline_s: float, server_up: bool
) -> tuple[Any, float]:
    """The student's ``call_trigger(node, service, timeout_s)``, run by the agent on a
    node of its own: (the value it returned, seconds it took)."""
    try:
        got = j.kernel.call(
            "call_trigger",
            "call_trigger",
            service,
            timeout_s,
            deadline_s,
            server_up,
            service_checks.DISCOVERY_S,
            guard=deadline_s + KERNEL_REPLY_GUARD_S,
        )
    except KernelError as exc:
        if "KeyError" in str(exc) and "call_trigger" in str(exc):
            raise CheckFailed("call_trigger is not defined: run its task's cell") from None
        raise
    if not got["discovered"]:
        raise JudgeTimeout(f"the judge's server on {service} was not discovered from the kernel")
    where = f"call_trigger(node, {service!r}, {timeout_s})"
    raised = got["raised"]
    if raised and raised[0] == "NotImplementedError":
        raise CheckFailed(f"{where}: this task is not done yet (NotImplementedError)")
    service_checks.assert_trigger_returned(
        where, deadline_s, got["finished"], got["unblocked"], tuple(raised) if raised else None
    )
    return _response(got["value"]), float(got["seconds"])


def _response(plain: dict[str, Any]) -> Any:
    """The returned value: a Trigger response rebuilt from its fields, None, or what the
    kernel could only describe."""
    if plain.get("type") == "NoneType":
        return None
    fields = plain.get("fields")
    if plain.get("type") == "Trigger_Response" and fields is not None:
        return Trigger.Response(success=bool(fields["success"]), message=str(fields["message"]))
    return Unreadable(plain["type"], plain.get("repr", repr(plain.get("value"))))


def _answering(message: str) -> Callable[[Any, Any], Any]:
    def answer(request: Any, response: Any) -> Any:
        response.success = True
        response.message = message
        return response

    return answer


def check_trigger_client(j: Judgement) -> None:
    for service in ("check_trigger", "/lab/other_trigger"):
        message = f"answered by the judge on {service} ({secrets.token_hex(4)})"
        with BackgroundServer(
            Trigger, service, _answering(message), node_name="trigger_check_server"
        ) as server:
            value, _ = trigger_call(j, service, 2.0, EVENT_GUARD_S, server_up=True)
        service_checks.assert_trigger_answered(value, server.calls, service, message)
    timeout_s = 0.5
    for service, slow_server in (("nobody_home", False), ("slow_trigger", True)):
        stopping = threading.Event()

        def slow(request: Any, response: Any, stopping: threading.Event = stopping) -> Any:
            stopping.wait(timeout_s + 2.0)
            response.success = True
            return response

        server = (
            BackgroundServer(Trigger, service, slow, node_name="slow_check_server")
            if slow_server
            else None
        )
        what = "a server slower than the timeout" if slow_server else "no server"
        try:
            # generous bounds: a loaded machine must not decide what "in time" is
            value, seconds = trigger_call(j, service, timeout_s, timeout_s + 5.0, slow_server)
        finally:
            stopping.set()
            if server is not None:
                server.close()
        service_checks.assert_trigger_gave_up(value, seconds, service, timeout_s, what, slack=3.0)


CHECKS = {
    "test_clock_server": check_clock_server,
    "test_trigger_client": check_trigger_client,
    "test_countdown_action": check_countdown_action,
    "test_rate_parameter": check_rate_parameter,
}
