"""Events of a launch and the handlers that answer them (``launch.events``,
``launch.event_handlers``), under upstream's names, arguments and semantics.

An event is emitted (by the launch, or by an ``EmitEvent`` action); every registered
handler whose matcher accepts it gives the actions to visit next, which see the event as
``LocalSubstitution('event.<attribute>')``. A handler's entities are actions, or a
callable that returns them (``on_start(event, context)``; ``on_stdout(event)``).
"""

from __future__ import annotations

import signal as signal_module
from collections.abc import Callable
from typing import Any

from rosbook.launch.substitutions import LaunchContext

Entities = Any  # an action, a LaunchDescription, a list of them, or None


def entities_of(value: Entities) -> list[Any]:
    """``value`` as a list of launch entities (None: none)."""
    if value is None:
        return []
    return list(value) if isinstance(value, (list, tuple)) else [value]


def _is_entity_callable(value: Any) -> bool:
    """A callable that gives entities, not an action (actions are not callable here)."""
    return callable(value) and not hasattr(value, "visit")


# -- events --------------------------------------------------------------------------------


class Event:
    """Something that happened in a launch; ``name`` says what, as upstream names it."""

    name = "launch.Event"


class Shutdown(Event):
    """The launch is asked to shut down (every process gets Ctrl-C)."""

    name = "launch.events.Shutdown"

    def __init__(self, *, reason: str = "reason not given", due_to_sigint: bool = False) -> None:
        self.reason = reason
        self.due_to_sigint = due_to_sigint


class ExecutionComplete(Event):
    """An action finished: at once for most, when its process exits for a process."""

    name = "launch.events.ExecutionComplete"

    def __init__(self, *, action: Any) -> None:
        self.action = action


class IncludeLaunchDescription(Event):
    """A launch description is to be included (``OnIncludeLaunchDescription``)."""

    name = "launch.events.IncludeLaunchDescription"

    def __init__(self, launch_description: Any) -> None:
        self.launch_description = launch_description


class TimerEvent(Event):
    """A ``TimerAction``'s period passed."""

    name = "launch.events.TimerEvent"

    def __init__(self, *, timer_action: Any) -> None:
        self.timer_action = timer_action


class RunningProcessEvent(Event):
    """An event about a running process: its action, name, command line and pid."""

    name = "launch.events.process.RunningProcessEvent"

    def __init__(
        self,
        *,
        action: Any,
        name: str,
        cmd: list[str],
        cwd: str | None,
        env: dict[str, str] | None,
        pid: int,
    ) -> None:
        self.action = action
        self.process_name = name
        self.cmd = cmd
        self.cwd = cwd
        self.env = env
        self.pid = pid

    @property
    def execute_process_action(self) -> Any:
        return self.action


class ProcessStarted(RunningProcessEvent):
    name = "launch.events.process.ProcessStarted"


class ProcessExited(RunningProcessEvent):
    name = "launch.events.process.ProcessExited"

    def __init__(self, *, returncode: int, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.returncode = returncode


class ProcessIO(RunningProcessEvent):
    """Bytes a process wrote (``fd`` 1: stdout, 2: stderr) or was given (0)."""

    name = "launch.events.process.ProcessIO"

    def __init__(self, *, text: bytes, fd: int, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.text = text
        self.fd = fd

    @property
    def from_stdout(self) -> bool:
        return self.fd == 1

    @property
    def from_stderr(self) -> bool:
        return self.fd == 2

    @property
    def from_stdin(self) -> bool:
        return self.fd == 0


class ProcessStdout(ProcessIO):
    name = "launch.events.process.ProcessStdout"

    def __init__(self, *, text: bytes, **kwargs: Any) -> None:
        super().__init__(text=text, fd=1, **kwargs)


class ProcessStderr(ProcessIO):
    name = "launch.events.process.ProcessStderr"

    def __init__(self, *, text: bytes, **kwargs: Any) -> None:
        super().__init__(text=text, fd=2, **kwargs)


class ProcessStdin(ProcessIO):
    name = "launch.events.process.ProcessStdin"

    def __init__(self, *, text: bytes, **kwargs: Any) -> None:
        super().__init__(text=text, fd=0, **kwargs)


class ProcessTargetedEvent(Event):
    """An event for the processes ``process_matcher(action)`` accepts."""

    name = "launch.events.process.ProcessTargetedEvent"

    def __init__(self, *, process_matcher: Callable[[Any], bool]) -> None:
        self.process_matcher = process_matcher


class SignalProcess(ProcessTargetedEvent):
    """Send ``signal_number`` to the matching processes."""

    name = "launch.events.process.SignalProcess"

    def __init__(
        self, *, signal_number: str | signal_module.Signals, process_matcher: Callable[[Any], bool]
    ) -> None:
        super().__init__(process_matcher=process_matcher)
        if isinstance(signal_number, str):
            signal_number = signal_module.Signals[signal_number]
        self.signal = signal_number

    @property
    def signal_name(self) -> str:
        return self.signal.name


class ShutdownProcess(ProcessTargetedEvent):
    """Stop the matching processes as a shutdown would (Ctrl-C, then escalation)."""

    name = "launch.events.process.ShutdownProcess"


def matches_action(target_action: Any) -> Callable[[Any], bool]:
    """A matcher accepting exactly ``target_action``."""
    return lambda action: action is target_action


def matches_pid(target_pid: int) -> Callable[[Any], bool]:
    return lambda action: getattr(action, "process_details", {}).get("pid") == target_pid


def matches_name(target_name: str) -> Callable[[Any], bool]:
    return lambda action: getattr(action, "process_details", {}).get("name") == target_name


def matches_executable(executable: Any) -> Callable[[Any], bool]:
    return lambda action: action is executable


# -- event handlers ------------------------------------------------------------------------


class BaseEventHandler:
    """Answers the events ``matcher`` accepts; ``handle_once`` removes it after one."""

    def __init__(self, *, matcher: Callable[[Event], bool], handle_once: bool = False) -> None:
        self.matcher = matcher
        self.handle_once = handle_once

    def matches(self, event: Event) -> bool:
        return bool(self.matcher(event))

    def handle(self, event: Event, context: LaunchContext) -> Entities:
        context.extend_locals({"event": event, "event_handler": self})
        return None

    def describe(self) -> tuple[str, list[Any]]:
        return (f"{type(self).__name__}", [])

    def describe_conditional_sub_entities(self) -> list[tuple[str, list[Any]]]:
        return []


class EventHandler(BaseEventHandler):
    """A handler with fixed ``entities``."""

    def __init__(
        self,
        *,
        matcher: Callable[[Event], bool],
        entities: Entities = None,
        handle_once: bool = False,
    ) -> None:
        super().__init__(matcher=matcher, handle_once=handle_once)
        self.entities = entities

    def handle(self, event: Event, context: LaunchContext) -> Entities:
        super().handle(event, context)
        return self.entities

    def describe_conditional_sub_entities(self) -> list[tuple[str, list[Any]]]:
        return [("event", entities_of(self.entities))] if self.entities else []


def event_named(name: str) -> Callable[[Event], bool]:
    """A matcher for events whose ``name`` is ``name``."""
    return lambda event: event.name == name


def _action_matcher(target: Any) -> Callable[[Any], bool]:
    if target is None:
        return lambda action: True
    if _is_entity_callable(target):
        return target
    return lambda action: action is target


class OnActionEventBase(BaseEventHandler):
    """A handler for an event about an action (``target_action``, or any if None)."""

    event_type: type[Event] = Event

    def __init__(self, *, target_action: Any = None, on_event: Any, **kwargs: Any) -> None:
        self._target = _action_matcher(target_action)
        super().__init__(
            matcher=lambda event: (
                isinstance(event, self.event_type) and self._target(getattr(event, "action", None))
            ),
            **kwargs,
        )
        self.target_action = target_action
        self.on_event = on_event

    def handle(self, event: Event, context: LaunchContext) -> Entities:
        super().handle(event, context)
        if _is_entity_callable(self.on_event):
            return self.on_event(event, context)
        return self.on_event

    def describe_conditional_sub_entities(self) -> list[tuple[str, list[Any]]]:
        if _is_entity_callable(self.on_event):
            return []
        return [(f"{type(self).__name__}", entities_of(self.on_event))]


class OnProcessStart(OnActionEventBase):
    """``on_start`` (actions, or ``f(event, context)``) when a process starts."""

    event_type = ProcessStarted

    def __init__(self, *, target_action: Any = None, on_start: Any, **kwargs: Any) -> None:
        super().__init__(target_action=target_action, on_event=on_start, **kwargs)


class OnProcessExit(OnActionEventBase):
    """``on_exit`` (actions, or ``f(event, context)``) when a process exits."""

    event_type = ProcessExited

    def __init__(self, *, target_action: Any = None, on_exit: Any, **kwargs: Any) -> None:
        super().__init__(target_action=target_action, on_event=on_exit, **kwargs)


class OnExecutionComplete(OnActionEventBase):
    """``on_completion`` when an action completes (a process: when it exits)."""

    event_type = ExecutionComplete

    def __init__(self, *, target_action: Any = None, on_completion: Any, **kwargs: Any) -> None:
        super().__init__(target_action=target_action, on_event=on_completion, **kwargs)


class OnProcessIO(OnActionEventBase):
    """``on_stdout(event)`` / ``on_stderr(event)`` / ``on_stdin(event)`` for each line a
    process writes (``event.text``: its bytes)."""

    event_type = ProcessIO

    def __init__(
        self,
        *,
        target_action: Any = None,
        on_stdin: Callable[[ProcessIO], Entities] | None = None,
        on_stdout: Callable[[ProcessIO], Entities] | None = None,
        on_stderr: Callable[[ProcessIO], Entities] | None = None,
        **kwargs: Any,
    ) -> None:
        self.on_stdin = on_stdin
        self.on_stdout = on_stdout
        self.on_stderr = on_stderr
        super().__init__(target_action=target_action, on_event=self._dispatch, **kwargs)

    def _dispatch(self, event: ProcessIO, context: LaunchContext) -> Entities:
        callback = {0: self.on_stdin, 1: self.on_stdout, 2: self.on_stderr}.get(event.fd)
        return None if callback is None else callback(event)


class OnShutdown(BaseEventHandler):
    """``on_shutdown`` (actions, or ``f(event, context)``) when the launch shuts down."""

    def __init__(self, *, on_shutdown: Any, **kwargs: Any) -> None:
        super().__init__(matcher=lambda event: isinstance(event, Shutdown), **kwargs)
        self.on_shutdown = on_shutdown

    def handle(self, event: Event, context: LaunchContext) -> Entities:
        super().handle(event, context)
        if _is_entity_callable(self.on_shutdown):
            return self.on_shutdown(event, context)
        return self.on_shutdown

    def describe_conditional_sub_entities(self) -> list[tuple[str, list[Any]]]:
        if _is_entity_callable(self.on_shutdown):
            return []
        return [("OnShutdown", entities_of(self.on_shutdown))]


class OnIncludeLaunchDescription(EventHandler):
    """Visits the description an ``IncludeLaunchDescription`` event carries."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(matcher=lambda e: isinstance(e, IncludeLaunchDescription), **kwargs)

    def handle(self, event: Event, context: LaunchContext) -> Entities:
        super().handle(event, context)
        return getattr(event, "launch_description", None)
