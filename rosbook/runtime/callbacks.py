"""Running a lockstep's callbacks at a lockstep's cost.

A simulated tick's work is a few messages (``/clock``, the sensors, ``cmd_vel``) and the
controllers' timers. rclpy's executor builds a wait set, a task and a coroutine for every
callback, and wakes once more after each (it triggers its own guard condition when a
callback is taken and when it is done): most of a tick went there. ``Callbacks`` runs the
ready callbacks of some nodes in the calling thread as rclpy's executor would, and waits
for the next one on an rcl wait set it builds again only when the entities change. The
simulator (``rosbook.sim.node.Simulation``) runs its controllers with it, and the
grader's agent in a student's kernel runs the student's node with it while it follows
the judge's ``/clock``.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any, NamedTuple

from rclpy.client import Client
from rclpy.event_handler import EventHandler
from rclpy.exceptions import InvalidHandle
from rclpy.executors import TimeoutException
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.service import Service
from rclpy.subscription import Subscription
from rclpy.task import Task
from rclpy.timer import Timer
from rclpy.waitable import NumberOfEntities, Waitable

from rosbook.runtime.executors import SingleThreadedExecutor
from rosbook.runtime.session import spin_while_waiting


def run_round(executor: SingleThreadedExecutor) -> bool:
    """Run the callbacks of one wait (everything ready now); whether any ran.

    Re-raises what a callback raised.
    """
    ran = False
    while True:
        try:
            handler, _, _ = executor.wait_for_ready_callbacks(timeout_sec=0.0)
        except TimeoutException:
            # rclpy ends every zero-timeout wait with this, after yielding its work.
            return ran
        ran = True
        handler()
        if handler.exception() is not None:
            raise handler.exception()  # type: ignore[misc]


class WakingExecutor(SingleThreadedExecutor):
    """rclpy's single-threaded executor that notes when it has work of its own.

    A task to run (a future's done callback, a coroutine to resume) or a changed node
    wakes it; ``woken`` says so until the next full round.
    """

    def __init__(self) -> None:
        super().__init__()
        self.woken = True

    def create_task(self, callback: Callable[..., Any], *args: Any, **kwargs: Any) -> Task:
        self.woken = True
        return super().create_task(callback, *args, **kwargs)

    def wake(self) -> None:
        self.woken = True
        super().wake()

    @property
    def pending(self) -> bool:
        """Whether a task is not done yet: a coroutine (an action's execute callback, say)
        awaiting a future. rclpy's executor resumes such tasks at every wait; nothing
        wakes it when their future completes."""
        with self._tasks_lock:
            return any(not task.done() for task, _, _ in self._tasks)

    @property
    def guard(self) -> GuardCondition:
        """rclpy's guard condition of this executor, triggered when it has work of its own
        (a task, a node added or removed, a callback it ran is done)."""
        return self._guard  # type: ignore[no-any-return]


class _Plan(NamedTuple):
    timers: list[Timer]
    subs: list[Subscription]
    services: list[Service]
    others: list[Any]


class Callbacks:
    """Runs the ready callbacks of ``nodes`` in this thread, at a lockstep's cost.

    A tick's work is a few messages (``/clock``, the sensors, ``cmd_vel``) and the
    controllers' timers. rclpy's executor builds a wait set, a task and a coroutine for
    every callback, and most of a tick went there. Here a pass does for timers,
    subscriptions and services what rclpy's executor does once they are ready (call
    the timer, or take the message or request; then the callback, and the response),
    in its order (due timers, then one message or request per entity, node by node);
    a take that finds nothing costs a microsecond, a wait a hundred. Passes follow until
    one finds nothing to do. The rest is rclpy's: one wait set (built again only when the
    entities change) tells whether a client, a guard condition, a waitable (an action,
    say) or a coroutine callback is ready, and then ``executor`` runs a full round; so
    it does when it has tasks of its own (a future's callbacks). QoS event handlers only
    report endpoints discovered meanwhile: ``run_round`` now and then serves them.
    """

    def __init__(self, nodes: list[Node], executor: WakingExecutor) -> None:
        self.nodes = nodes
        self.executor = executor
        self._plan: _Plan | None = None
        self._others: _WaitSet | None = None  # what the passes do not serve
        self._all: _WaitSet | None = None  # everything, and the executor's guard

    def round(self) -> bool:
        """Run every callback that is ready, and those they make ready; whether any ran."""
        ran = False
        full_round = False  # one since the last progress of the passes or requests
        while True:
            if self.executor.woken:  # a node changed, or the executor has tasks
                self._plan = None
            while self._pass():
                ran, full_round = True, False
            if self._serve_requests():
                ran, full_round = True, False
                continue
            if self.executor.woken:  # new tasks (a future's callbacks): run them
                pass
            elif self.executor.pending and not full_round:  # resume them, once a round
                pass
            elif full_round or not self._others_ready():
                # After a full round without progress, what is still ready waits for
                # the next round (a task that awaits what never comes, say a deadlock
                # in its callback group, leaves the executor ready for ever).
                return ran
            self.executor.woken = False
            self._plan = None  # the executor's tasks may hold entities until they finish
            ran = run_round(self.executor) or ran
            full_round = True

    def spin(self, timeout: float) -> None:
        """Run what is ready; if nothing was, wait up to ``timeout`` s until something is
        (the next call runs it). The wait is one of rcl's, on a wait set built again only
        when the entities change: rclpy's executor would build one for each callback,
        and wake once more after it."""
        if self.round():
            return
        if self._plan is None:
            self._plan = self._make_plan()
        if self._all is None:
            plan = self._plan
            entities = [*plan.timers, *plan.subs, *plan.services, *plan.others]
            self._all = _WaitSet([*entities, self.executor.guard], self.executor.context)
        self._all.wait(int(timeout * 1e9))

    def spin_until(self, condition: Callable[[], bool], timeout: float) -> bool:
        """Spin until ``condition()`` holds or ``timeout`` s have passed; whether it holds."""
        return spin_while_waiting(self.spin, condition, timeout)

    def _make_plan(self) -> _Plan:
        """What this serves (timers, subscriptions, services), what it leaves to rclpy."""
        timers: list[Timer] = []
        subs: list[Subscription] = []
        services: list[Service] = []
        others: list[Any] = []
        for node in self.nodes:
            for timer in node.timers:
                (timers if self._served_here(timer) else others).append(timer)
            for sub in node.subscriptions:
                (subs if self._served_here(sub) else others).append(sub)
            for service in node.services:
                (services if self._served_here(service) else others).append(service)
            others += node.clients
            others += node.guards
            others += (w for w in node.waitables if not isinstance(w, EventHandler))
        self._others = self._all = None
        return _Plan(timers, subs, services, others)

    def _pass(self) -> bool:
        """Call the timers due now, then take one message per subscription; whether any."""
        if self._plan is None or self.executor.woken:  # an entity was made or destroyed
            self._plan = self._make_plan()
        due = [timer for timer in self._plan.timers if _timer_ready(timer)]
        for timer in due:
            self._call_timer(timer)
        taken = False
        for sub in self._plan.subs:
            taken = self._take(sub) or taken
        return bool(due) or taken

    def _serve_requests(self) -> bool:
        """Serve one request per service (once the lockstep work is done); whether any."""
        if self._plan is None:
            self._plan = self._make_plan()
        served = False
        for service in self._plan.services:
            served = self._serve(service) or served
        return served

    def _others_ready(self) -> bool:
        """Whether something the passes do not serve is ready (one wait of rcl)."""
        if self._plan is None:
            self._plan = self._make_plan()
        if not self._plan.others:
            return False
        if self._others is None:
            self._others = _WaitSet(self._plan.others, self.executor.context)
        self._others.wait(0)
        return self._others.any_ready()

    @staticmethod
    def _served_here(entity: Timer | Subscription | Service) -> bool:
        return not (
            entity._executor_event  # an executor task holds it
            or inspect.iscoroutinefunction(entity.callback)
            or not entity.callback_group.can_execute(entity)
        )

    def _call_timer(self, timer: Timer) -> None:
        try:
            with timer.handle:
                if not timer.handle.is_timer_ready():  # cancelled or reset by a callback
                    return
                timer.handle.call_timer()
        except InvalidHandle:  # destroyed by a callback
            return
        self._run(timer, ())

    def _take(self, sub: Subscription) -> bool:
        try:
            with sub.handle:
                got = sub.handle.take_message(sub.msg_type, sub.raw)
        except InvalidHandle:  # destroyed by a callback
            return False
        if got is None:
            return False
        with_info = sub._callback_type is Subscription.CallbackType.WithMessageInfo
        self._run(sub, got if with_info else (got[0],))
        return True

    def _serve(self, service: Service) -> bool:
        try:
            with service.handle:
                request, header = service.handle.service_take_request(service.srv_type.Request)
        except InvalidHandle:
            return False
        if header is None:
            return False
        response = self._run(service, (request, service.srv_type.Response()))
        service.send_response(response, header)
        return True

    @staticmethod
    def _run(entity: Timer | Subscription | Service, args: tuple[Any, ...]) -> Any:
        group = entity.callback_group
        if not group.beginning_execution(entity):
            raise RuntimeError(f"callback group refused {entity!r} in a single thread")
        try:
            return entity.callback(*args)
        finally:
            group.ending_execution(entity)


def _timer_ready(timer: Timer) -> bool:
    try:
        with timer.handle:
            return bool(timer.handle.is_timer_ready())
    except InvalidHandle:  # destroyed by a callback of this pass
        return False


#: How to add each kind of entity to an rcl wait set.
_KINDS: dict[type, Callable[[Any, Any], Any]] = {
    Subscription: lambda ws, e: ws.add_subscription(e.handle),
    GuardCondition: lambda ws, e: ws.add_guard_condition(e.handle),
    Timer: lambda ws, e: ws.add_timer(e.handle),
    Client: lambda ws, e: ws.add_client(e.handle),
    Service: lambda ws, e: ws.add_service(e.handle),
    Waitable: lambda ws, e: e.add_to_wait_set(ws),
}


def timer_due(nodes: list[Node]) -> bool:
    """Whether a timer of ``nodes`` is due now (its callback has not run yet)."""
    for node in nodes:
        for timer in node.timers:
            left = timer.time_until_next_call()
            if left is not None and left <= 0 and not timer.is_canceled():
                return True
    return False


class _WaitSet:
    """An rcl wait set of fixed entities: sized once, filled again for each wait."""

    def __init__(self, entities: list[Any], context: Any) -> None:
        self.kinds = {kind: [e for e in entities if isinstance(e, kind)] for kind in _KINDS}
        size = NumberOfEntities(
            len(self.kinds[Subscription]), len(self.kinds[GuardCondition]),
            len(self.kinds[Timer]), len(self.kinds[Client]), len(self.kinds[Service]),
        )  # fmt: skip
        for waitable in self.kinds[Waitable]:
            size += waitable.get_num_entities()
        self.handle = _rclpy.WaitSet(
            size.num_subscriptions, size.num_guard_conditions, size.num_timers,
            size.num_clients, size.num_services, size.num_events, context.handle,
        )  # fmt: skip

    def wait(self, timeout_ns: int) -> None:
        """Wait until one of the entities is ready, or ``timeout_ns`` (0: just look)."""
        handle = self.handle
        handle.clear_entities()
        for kind, add in _KINDS.items():
            for entity in self.kinds[kind]:
                add(handle, entity)
        handle.wait(timeout_ns)

    def any_ready(self) -> bool:
        """Whether the last wait found an entity ready."""
        return any(
            self.handle.get_ready_entities(name)
            for name in ("subscription", "guard_condition", "timer", "client", "service")
        ) or any(w.is_ready(self.handle) for w in self.kinds[Waitable])
