"""Lifecycle nodes in launch files (``launch_ros.actions.LifecycleNode``,
``launch_ros.events.lifecycle``, ``launch_ros.event_handlers.OnStateTransition``).

A ``LifecycleNode`` runs as a ``Node`` does; the launch then talks to it over its real
lifecycle interfaces, as upstream's does: a ``ChangeState`` event calls the node's
``<node>/change_state`` service, and each message on ``<node>/transition_event`` is
emitted as a ``StateTransition`` event, which ``OnStateTransition`` handlers answer::

    talker = LifecycleNode(package='robot_talk', executable='lifecycle_talker',
                           name='talker', namespace='')
    RegisterEventHandler(OnStateTransition(
        target_lifecycle_node=talker, goal_state='inactive',
        entities=[EmitEvent(event=ChangeState(
            lifecycle_node_matcher=matches_action(talker),
            transition_id=Transition.TRANSITION_ACTIVATE))]))

The launch's own ROS node (``ros_adapters.get_ros_node``) lives in a context of its own,
spun by a thread of the launch; what it hears is handed to the launch's thread as events.
"""

from __future__ import annotations

import os
import queue
import threading
from collections.abc import Callable, Iterable
from typing import Any

import rclpy
from lifecycle_msgs.msg import Transition, TransitionEvent
from lifecycle_msgs.srv import ChangeState as ChangeStateSrv
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node as RclpyNode

from rosbook.launch import events
from rosbook.launch.launcher import Action, EmitEvent, Node
from rosbook.launch.substitutions import (
    LaunchContext,
    LaunchError,
    SomeSubstitutionsType,
    normalize_to_list_of_substitutions,
    perform_substitutions,
)

#: Seconds a transition waits for the node's change_state service (a guard, not a timing).
SERVICE_WAIT = 60.0


class RosAdapter:
    """The launch's ROS node, in a context of its own, spun in a background thread."""

    def __init__(self) -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = RclpyNode(f"launch_ros_{os.getpid()}", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.1)
            except Exception:  # the context shut down under us
                break

    def shutdown(self) -> None:
        """Stop spinning and destroy the node and its context."""
        self.executor.shutdown(timeout_sec=1.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)
        self._thread.join(timeout=5.0)


def get_ros_adapter(context: LaunchContext) -> RosAdapter:
    """The launch's ROS adapter, made on first use and shut down with the launch."""
    launch = context.launch
    adapter = getattr(launch, "ros_adapter", None)
    if adapter is None:
        adapter = RosAdapter()
        launch.ros_adapter = adapter
        launch.add_cleanup(adapter.shutdown)
    return adapter


def get_ros_node(context: LaunchContext) -> RclpyNode:
    """The launch's ROS node (``launch_ros.ros_adapters.get_ros_node``)."""
    return get_ros_adapter(context).node


# -- events --------------------------------------------------------------------------------

#: Transition ids by label, and labels by id, as lifecycle_msgs defines them.
_TRANSITIONS = {
    getattr(Transition, name): name[len("TRANSITION_") :].lower()
    for name in dir(Transition)
    if name.startswith("TRANSITION_") and isinstance(getattr(Transition, name), int)
}


class ChangeState(events.Event):
    """Ask the lifecycle nodes ``lifecycle_node_matcher`` accepts to make a transition."""

    name = "launch_ros.events.lifecycle.ChangeState"
    valid_transitions = _TRANSITIONS

    def __init__(
        self, *, lifecycle_node_matcher: Callable[[Any], bool], transition_id: int
    ) -> None:
        if transition_id not in _TRANSITIONS:
            raise ValueError(
                f"given transition_id of '{transition_id}', expected one of {sorted(_TRANSITIONS)}"
            )
        self.lifecycle_node_matcher = lifecycle_node_matcher
        self.transition_id = transition_id


class StateTransition(events.Event):
    """A lifecycle node made a transition (one ``transition_event`` message)."""

    name = "launch_ros.events.lifecycle.StateTransition"

    def __init__(self, *, action: Any, msg: TransitionEvent) -> None:
        self.action = action
        self.msg = msg
        self.timestamp = msg.timestamp
        self.transition = msg.transition.label
        self.start_state = msg.start_state.label
        self.goal_state = msg.goal_state.label


def matches_node_name(node_name: str) -> Callable[[Any], bool]:
    """A matcher for the lifecycle node whose fully qualified name is ``node_name``."""
    return lambda action: getattr(action, "fully_qualified_name", None) == node_name


class OnStateTransition(events.EventHandler):
    """``entities`` when a lifecycle node makes a transition (those given must match)."""

    def __init__(
        self,
        *,
        entities: Any,
        target_lifecycle_node: Any = None,
        transition: SomeSubstitutionsType | None = None,
        start_state: SomeSubstitutionsType | None = None,
        goal_state: SomeSubstitutionsType | None = None,
        matcher: Callable[[events.Event], bool] | None = None,
        **kwargs: Any,
    ) -> None:
        wanted = {
            "transition": transition,
            "start_state": start_state,
            "goal_state": goal_state,
        }
        texts = {k: v for k, v in wanted.items() if v is not None}

        def default_matcher(event: events.Event) -> bool:
            if not isinstance(event, StateTransition):
                return False
            if target_lifecycle_node is not None and event.action is not target_lifecycle_node:
                return False
            context = LaunchContext()
            return all(
                getattr(event, k) == perform_substitutions(context, v) for k, v in texts.items()
            )

        super().__init__(matcher=matcher or default_matcher, entities=entities, **kwargs)


# -- actions -------------------------------------------------------------------------------


class LifecycleNode(Node):
    """A lifecycle node (``rclpy.lifecycle.Node``) run as a process, its transitions
    driven by ``ChangeState`` events and reported as ``StateTransition`` events."""

    def __init__(
        self, *, name: SomeSubstitutionsType, namespace: SomeSubstitutionsType, **kwargs: Any
    ) -> None:
        super().__init__(name=name, namespace=namespace, **kwargs)
        self.fully_qualified_name: str | None = None
        self._requests: queue.Queue[int | None] = queue.Queue()

    def execute(self, context: LaunchContext) -> None:
        name = self.node_name(context)
        namespace = self.node_namespace(context) or "/"
        if not name:
            raise LaunchError("a LifecycleNode needs a name")
        self.fully_qualified_name = f"{namespace.rstrip('/')}/{name}"
        adapter = get_ros_adapter(context)
        launch = context.launch
        self._subscription = adapter.node.create_subscription(
            TransitionEvent,
            f"{self.fully_qualified_name}/transition_event",
            lambda msg: launch.post_event(StateTransition(action=self, msg=msg)),
            10,
        )
        self._client = adapter.node.create_client(
            ChangeStateSrv, f"{self.fully_qualified_name}/change_state"
        )
        threading.Thread(target=self._transitions, args=(launch,), daemon=True).start()
        launch.add_cleanup(lambda: self._requests.put(None))  # the thread ends with the launch
        launch.handlers.append(
            (
                events.EventHandler(
                    matcher=lambda e: isinstance(e, ChangeState) and e.lifecycle_node_matcher(self),
                    entities=[_RequestTransition(self)],
                ),
                context,
            )
        )
        super().execute(context)

    def _transitions(self, launch: Any) -> None:
        """Call change_state for each requested transition, in order (a thread's work)."""
        while (transition_id := self._requests.get()) is not None:
            label = _TRANSITIONS[transition_id]
            if not self._client.wait_for_service(timeout_sec=SERVICE_WAIT):
                launch.say(
                    f"[ERROR] [{self.fully_qualified_name}]: timeout: no service "
                    f"'{self._client.srv_name}' after {SERVICE_WAIT:.0f} s; transition "
                    f"'{label}' not made"
                )
                continue
            request = ChangeStateSrv.Request()
            request.transition.id = transition_id
            done = threading.Event()
            future = self._client.call_async(request)
            future.add_done_callback(lambda _, done=done: done.set())
            if not done.wait(SERVICE_WAIT) or future.result() is None:
                launch.say(f"[ERROR] [launch_ros]: timeout: transition '{label}' not answered")
            elif not future.result().success:
                launch.say(
                    f"[ERROR] [launch_ros]: Failed to make transition '{label}' for "
                    f"LifecycleNode '{self.fully_qualified_name}'"
                )


class _RequestTransition(Action):
    """Queue the transition of the ``ChangeState`` event being handled."""

    def __init__(self, node: LifecycleNode) -> None:
        super().__init__()
        self.node = node

    def execute(self, context: LaunchContext) -> None:
        self.node._requests.put(context.locals.event.transition_id)


class LifecycleTransition(Action):
    """Make these transitions, in order, on the lifecycle nodes of these names."""

    def __init__(
        self,
        *,
        lifecycle_node_names: Iterable[SomeSubstitutionsType],
        transition_ids: Iterable[int | SomeSubstitutionsType],
        **kwargs: Any,
    ) -> None:
        super().__init__(**kwargs)
        self.lifecycle_node_names = [
            normalize_to_list_of_substitutions(n) for n in lifecycle_node_names
        ]
        self.transition_ids = list(transition_ids)

    def execute(self, context: LaunchContext) -> list[Action]:
        found = []
        for name in self.lifecycle_node_names:
            node_name = perform_substitutions(context, name)
            for transition in self.transition_ids:
                if not isinstance(transition, int):
                    transition = int(perform_substitutions(context, transition))
                found.append(
                    EmitEvent(
                        event=ChangeState(
                            lifecycle_node_matcher=matches_node_name(node_name),
                            transition_id=transition,
                        )
                    )
                )
        return found
