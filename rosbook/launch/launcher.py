"""A launcher for ROS 2 launch files: the actions of ``launch`` and ``launch_ros``.

There is no ``launch`` / ``launch_ros`` wheel, so this module implements the part of them
the book and the official Jazzy launch tutorials use, under upstream's names, arguments
and semantics; the top-level packages ``launch`` and ``launch_ros`` re-export it, so a
launch file written for a full install runs here unchanged::

    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument
    from launch.substitutions import LaunchConfiguration
    from launch_ros.actions import Node

    def generate_launch_description():
        return LaunchDescription([
            DeclareLaunchArgument('rate', default_value='2.0'),
            Node(package='robot_talk', executable='talker', name='talker',
                 namespace='robot1', parameters=[{'rate': LaunchConfiguration('rate')}],
                 remappings=[('chatter', 'news')], output='screen'),
        ])

Actions are upstream's, every public one of ``launch.actions`` (``DeclareLaunchArgument``,
``IncludeLaunchDescription`` of Python, XML or YAML files, ``GroupAction``,
``ExecuteProcess``, ``TimerAction``, ``EmitEvent``, ``OpaqueFunction``,
``SetEnvironmentVariable``, ...) and of ``launch_ros.actions`` (``Node`` with ``respawn``,
``PushROSNamespace``, ``SetParameter``, ``SetRemap``, ...; lifecycle nodes are in
``rosbook.launch.lifecycle``, composable nodes in ``rosbook.launch.components``). Any
action takes ``condition=``. Events and their handlers are in ``rosbook.launch.events``,
substitutions and conditions in ``rosbook.launch.substitutions``, XML and YAML files in
``rosbook.launch.frontend``.

``launch(description)`` starts every process with the ``--ros-args`` the real
``launch_ros`` passes (``-r __node:=``, ``-r __ns:=``, ``-p name:=value``,
``--params-file``, ``-r from:=to``), merges their output with each line prefixed by the
process name (``[talker-1] ...``), and stops them all with one Ctrl-C: SIGINT to each,
then SIGTERM, then SIGKILL after ``sigterm_timeout`` / ``sigkill_timeout`` seconds
(a second Ctrl-C meanwhile is ignored, as in launch; ``timeout -s INT`` sends two at once).
As in launch, a process without its own timeouts takes the launch configurations of
those names (``ros2 launch FILE sigterm_timeout:=30``), else 5 s each.

Not provided: running composable nodes (C++ components; they are described, and refused
at run time in one sentence), and log files under ``~/.ros/log``.
"""

from __future__ import annotations

import asyncio
import atexit
import ctypes
import importlib.util
import json
import os
import queue
import re
import shlex
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from rosbook.launch import events
from rosbook.launch.descriptions import (
    Executable,
    ParameterFile,
    evaluate_parameter_value,
)
from rosbook.launch.descriptions import Parameter as ParameterDescription
from rosbook.launch.events import (
    BaseEventHandler,
    ExecutionComplete,
    ProcessExited,
    ProcessStarted,
    ProcessStderr,
    ProcessStdout,
    entities_of,
)
from rosbook.launch.substitutions import (
    Condition,
    LaunchContext,
    LaunchError,
    LaunchLogDir,
    SomeSubstitutionsType,
    Substitution,
    SubstitutionFailure,
    normalize_to_list_of_substitutions,
    perform_substitutions,
)
from rosbook.launch.workspace import executable_path
from rosbook.runtime.graph import absolute_name

#: prctl(2) option: the signal a process gets when its parent dies (Linux).
_PR_SET_PDEATHSIG = 1

__all__ = ["LaunchError", "SubstitutionFailure"]  # re-exported: callers catch them from here


def _die_with_launcher() -> None:
    """In a launched child, before exec: SIGTERM when the launcher dies, however it dies.

    Each node runs in a session of its own (our Ctrl-C reaches it once, from us), so a
    launcher killed with SIGKILL would otherwise leave its nodes running.
    """
    ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


Entity = Any  # an Action or a LaunchDescription
SomeActionsType = Any  # an entity or a list of them


class InvalidLaunchFileError(LaunchError):
    """A launch file that cannot be read (its format, or its content)."""


class InvalidPythonLaunchFileError(InvalidLaunchFileError):
    """A Python launch file without ``generate_launch_description()``."""


class InvalidFrontendLaunchFileError(InvalidLaunchFileError):
    """An XML or YAML launch file that cannot be read."""


_entities = entities_of


class LaunchDescriptionEntity:
    """Anything a launch description holds: an action, or a description itself."""

    def describe_sub_entities(self) -> list[Entity]:
        return []

    def describe_conditional_sub_entities(self) -> list[tuple[str, list[Entity]]]:
        return []


class Action(LaunchDescriptionEntity):
    """One step of a launch description; runs when visited if its ``condition`` holds."""

    def __init__(self, *, condition: Condition | None = None) -> None:
        self.condition = condition

    def get_condition(self) -> Condition | None:
        return self.condition

    def describe(self) -> str:
        return f"{type(self).__name__}"

    def visit(self, context: LaunchContext) -> list[Entity] | None:
        if self.condition is None or self.condition.evaluate(context):
            return self.execute(context)
        return None

    def execute(self, context: LaunchContext) -> list[Entity] | None:
        raise NotImplementedError

    def describe_sub_entities(self) -> list[Entity]:
        return []

    def describe_conditional_sub_entities(self) -> list[tuple[str, list[Entity]]]:
        return []


class LaunchDescription(LaunchDescriptionEntity):
    """What ``generate_launch_description()`` returns: actions, in order."""

    def __init__(self, initial_entities: Iterable[Entity] | None = None) -> None:
        self.entities: list[Entity] = list(initial_entities or [])

    def add_entity(self, entity: Entity) -> None:
        self.entities.append(entity)

    add_action = add_entity

    def describe_sub_entities(self) -> list[Entity]:
        return self.entities

    def describe_conditional_sub_entities(self) -> list[tuple[str, list[Entity]]]:
        return []

    def get_launch_arguments(
        self, conditional_inclusion: bool = False
    ) -> list[DeclareLaunchArgument]:
        """Every ``DeclareLaunchArgument`` in it, in included files too (first one of a name);
        ``_conditionally_included`` says whether it is only used under a condition."""
        found: dict[str, DeclareLaunchArgument] = {}

        def walk(entities: Iterable[Entity], conditional: bool) -> None:
            for entity in entities:
                if isinstance(entity, DeclareLaunchArgument) and entity.name not in found:
                    entity._conditionally_included = conditional or entity.condition is not None
                    found[entity.name] = entity
                walk(entity.describe_sub_entities(), False)
                for _, subs in entity.describe_conditional_sub_entities():
                    walk(subs, True)

        walk(self.entities, conditional_inclusion)
        return list(found.values())


def _describe(subs: list[Substitution]) -> str:
    return " + ".join(s.describe() for s in subs)


def format_launch_arguments(description: LaunchDescription) -> str:
    """What ``ros2 launch --show-args`` prints, as upstream words it."""
    lines = ["Arguments (pass arguments as '<name>:=<value>'):"]
    arguments = description.get_launch_arguments()
    for argument in arguments:
        star = "*" if argument._conditionally_included else ""
        lines += ["", f"    '{argument.name}':{star}", f"        {argument.description}"]
        if argument.default_value is not None:
            lines.append(f"        (default: {_describe(argument.default_value)})")
    if not arguments:
        lines += ["", "  No arguments."]
    elif any(a._conditionally_included for a in arguments):
        lines += ["", "* argument(s) which are only used if specific conditions occur"]
    return "\n".join(lines)


# -- launch actions ------------------------------------------------------------------------


class DeclareLaunchArgument(Action):
    """A launch argument (``name:=value`` on the command line), with an optional default."""

    def __init__(
        self,
        name: str,
        *,
        default_value: SomeSubstitutionsType | None = None,
        description: str | None = None,
        choices: Sequence[str] | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(**kwargs)
        self.name = name
        self.default_value = (
            None if default_value is None else normalize_to_list_of_substitutions(default_value)
        )
        if choices is not None and not choices:
            raise LaunchError("Provided choices arg is empty. Use None to ignore the choice list.")
        if choices is not None and isinstance(default_value, str) and default_value not in choices:
            raise LaunchError(
                f'Provided default_value "{default_value}" is not in provided choices '
                f'"{list(choices)}".'
            )
        self.choices = None if choices is None else list(choices)
        if description is None:
            description = "no description given" if choices is None else f"One of: {self.choices}"
        elif choices is not None:
            description += ("" if description.endswith(".") else ".") + (
                f" Valid choices are: {self.choices}"
            )
        self.description = description
        self._conditionally_included = False

    def execute(self, context: LaunchContext) -> None:
        configs = context.launch_configurations
        if self.name not in configs:
            if self.default_value is None:
                raise LaunchError(f'Required launch argument "{self.name}" was not provided.')
            configs[self.name] = perform_substitutions(context, self.default_value)
        if self.choices is not None and configs[self.name] not in self.choices:
            raise LaunchError(
                f'Argument "{self.name}" provided value "{configs[self.name]}" is not valid. '
                f"Valid options are: {self.choices}"
            )


class SetLaunchConfiguration(Action):
    def __init__(
        self, name: SomeSubstitutionsType, value: SomeSubstitutionsType, **kwargs: Any
    ) -> None:
        super().__init__(**kwargs)
        self.name = normalize_to_list_of_substitutions(name)
        self.value = normalize_to_list_of_substitutions(value)

    def execute(self, context: LaunchContext) -> None:
        name = perform_substitutions(context, self.name)
        context.launch_configurations[name] = perform_substitutions(context, self.value)


class LaunchDescriptionSource:
    """A launch file to include, its path given as substitutions."""

    def __init__(
        self,
        launch_description: LaunchDescription | None = None,
        location: SomeSubstitutionsType = "<string>",
        method: str = "unspecified mechanism from a script",
    ) -> None:
        self._description = launch_description
        self.location = normalize_to_list_of_substitutions(location)
        self.method = method

    def path(self, context: LaunchContext) -> Path:
        return Path(perform_substitutions(context, self.location)).absolute()

    def get_launch_description(self, context: LaunchContext) -> LaunchDescription:
        if self._description is not None:
            return self._description
        return self._load(self.path(context))

    def _load(self, path: Path) -> LaunchDescription:
        return load_launch_file(path)

    def try_get_launch_description_without_context(self) -> LaunchDescription | None:
        try:
            return self.get_launch_description(LaunchContext())
        except Exception:  # a path that needs the launch's configurations: not described
            return None


class PythonLaunchDescriptionSource(LaunchDescriptionSource):
    """A Python launch file (``*.launch.py``) to include."""

    def __init__(self, launch_file_path: SomeSubstitutionsType) -> None:
        super().__init__(None, launch_file_path, "interpreted python launch file")

    def _load(self, path: Path) -> LaunchDescription:
        return load_python_launch_file(path)


class FrontendLaunchDescriptionSource(LaunchDescriptionSource):
    """An XML or YAML launch file (``*.launch.xml``, ``*.launch.yaml``) to include."""

    #: The format to read it as (None: told by its extension).
    kind: str | None = None

    def __init__(self, launch_file_path: SomeSubstitutionsType, parser: Any = None) -> None:
        super().__init__(None, launch_file_path, "interpreted frontend launch file")

    def _load(self, path: Path) -> LaunchDescription:
        from rosbook.launch.frontend import load_frontend_launch_file  # it builds our actions

        return load_frontend_launch_file(path, self.kind)


class XMLLaunchDescriptionSource(FrontendLaunchDescriptionSource):
    """An XML launch file to include (``launch_xml.launch_description_sources``)."""

    kind = "xml"

    def __init__(self, launch_file_path: SomeSubstitutionsType) -> None:
        super().__init__(launch_file_path)


class YAMLLaunchDescriptionSource(FrontendLaunchDescriptionSource):
    """A YAML launch file to include (``launch_yaml.launch_description_sources``)."""

    kind = "yaml"

    def __init__(self, launch_file_path: SomeSubstitutionsType) -> None:
        super().__init__(launch_file_path)


class AnyLaunchDescriptionSource(LaunchDescriptionSource):
    """A launch file of any format, told by its extension (``.py``, ``.xml``, ``.yaml``)."""

    def __init__(self, launch_file_path: SomeSubstitutionsType) -> None:
        super().__init__(None, launch_file_path, "interpreted launch file")


class IncludeLaunchDescription(Action):
    """Another launch file's description, its ``launch_arguments`` set as configurations
    first (not scoped, as upstream: wrap it in a ``GroupAction`` to keep them in)."""

    def __init__(
        self,
        launch_description_source: LaunchDescriptionSource | SomeSubstitutionsType,
        *,
        launch_arguments: Iterable[tuple[SomeSubstitutionsType, SomeSubstitutionsType]]
        | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(**kwargs)
        if not isinstance(launch_description_source, LaunchDescriptionSource):
            launch_description_source = AnyLaunchDescriptionSource(launch_description_source)
        self.launch_description_source = launch_description_source
        self.launch_arguments = tuple(launch_arguments or ())

    def describe_sub_entities(self) -> list[Entity]:
        found = self.launch_description_source.try_get_launch_description_without_context()
        return [] if found is None else [found]

    def execute(self, context: LaunchContext) -> list[Entity]:
        source = self.launch_description_source
        path = source.path(context)
        description = source.get_launch_description(context)
        given = [perform_substitutions(context, name) for name, _ in self.launch_arguments]
        for argument in description.get_launch_arguments():
            if argument._conditionally_included or argument.default_value is not None:
                continue
            if argument.name not in given and argument.name not in context.launch_configurations:
                raise LaunchError(
                    f"Included launch description missing required argument '{argument.name}' "
                    f"(description: '{argument.description}'), given: [{', '.join(given)}]"
                )
        for name, value in self.launch_arguments:
            SetLaunchConfiguration(name, value).execute(context)
        context.launch.visit([description], context.reading(path))
        return None


class GroupAction(Action):
    """Actions in a scope of their own: launch configurations, ``PushRosNamespace`` and
    ``SetParameter`` inside it end with it (``scoped=True``, the default)."""

    def __init__(
        self,
        actions: Iterable[Entity],
        *,
        scoped: bool = True,
        forwarding: bool = True,
        launch_configurations: Mapping[SomeSubstitutionsType, SomeSubstitutionsType] | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(**kwargs)
        self.actions = list(actions)
        self.scoped = scoped
        self.forwarding = forwarding
        self.launch_configurations = dict(launch_configurations or {})

    def describe_sub_entities(self) -> list[Entity]:
        return self.actions

    def execute(self, context: LaunchContext) -> list[Entity] | None:
        inner = context.scoped() if self.scoped else context
        given = {  # worked out where the group is, before a non-forwarding one clears
            perform_substitutions(context, name): perform_substitutions(context, value)
            for name, value in self.launch_configurations.items()
        }
        if self.scoped and not self.forwarding:
            inner.launch_configurations.clear()
        inner.launch_configurations.update(given)
        if not self.scoped:
            return self.actions
        context.launch.visit(self.actions, inner)
        return None


class LogInfo(Action):
    """Print ``msg`` as the ``launch.user`` logger."""

    def __init__(self, *, msg: SomeSubstitutionsType, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.msg = normalize_to_list_of_substitutions(msg)

    def execute(self, context: LaunchContext) -> None:
        context.launch.say(f"[INFO] [launch.user]: {perform_substitutions(context, self.msg)}")


class TimerAction(Action):
    """Run ``actions`` ``period`` seconds (wall time) after this action is visited."""

    def __init__(
        self,
        *,
        period: float | SomeSubstitutionsType,
        actions: Iterable[Entity],
        cancel_on_shutdown: bool | SomeSubstitutionsType = True,
        **kwargs: Any,
    ) -> None:
        super().__init__(**kwargs)
        self.period = period
        self.actions = list(actions)
        self.cancel_on_shutdown = cancel_on_shutdown

    def describe_conditional_sub_entities(self) -> list[tuple[str, list[Entity]]]:
        return [(f"{self.period} seconds pass", self.actions)]

    def execute(self, context: LaunchContext) -> None:
        period = self.period
        if not isinstance(period, (int, float)):
            period = float(perform_substitutions(context, period))
        cancel = self.cancel_on_shutdown
        if not isinstance(cancel, bool):
            cancel = perform_substitutions(context, cancel).strip().lower() in ("true", "1")
        context.launch.add_timer(float(period), self.actions, context, cancel_on_shutdown=cancel)


class Shutdown(Action):
    """Shut the whole launch down (as an action, or as ``Node(on_exit=Shutdown())``): it
    emits ``launch.events.Shutdown``, as ``EmitEvent(event=Shutdown(reason=...))`` does."""

    def __init__(self, *, reason: SomeSubstitutionsType = "reason not given", **kwargs: Any):
        super().__init__(**kwargs)
        self.reason = normalize_to_list_of_substitutions(reason)

    def execute(self, context: LaunchContext) -> None:
        reason = perform_substitutions(context, self.reason)
        context.launch.emit_event(events.Shutdown(reason=reason), context)


class RegisterEventHandler(Action):
    """Answer events with ``event_handler`` from now on (``launch.event_handlers``)."""

    def __init__(self, event_handler: BaseEventHandler, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.event_handler = event_handler

    def describe_conditional_sub_entities(self) -> list[tuple[str, list[Entity]]]:
        return self.event_handler.describe_conditional_sub_entities()

    def execute(self, context: LaunchContext) -> None:
        context.launch.handlers.append((self.event_handler, context))


class UnregisterEventHandler(Action):
    """Stop answering events with ``event_handler``."""

    def __init__(self, event_handler: BaseEventHandler, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.event_handler = event_handler

    def execute(self, context: LaunchContext) -> None:
        handlers = context.launch.handlers
        kept = [(h, c) for h, c in handlers if h is not self.event_handler]
        if len(kept) == len(handlers):
            raise LaunchError(f"event handler {self.event_handler!r} is not registered")
        handlers[:] = kept


class EmitEvent(Action):
    """Emit ``event`` (``launch.events.Shutdown(reason=...)``, a process event, ...)."""

    def __init__(self, *, event: events.Event, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        if not isinstance(event, events.Event):
            raise TypeError(f"EmitEvent expected a launch Event, got {type(event).__name__}")
        self.event = event

    def execute(self, context: LaunchContext) -> None:
        context.launch.emit_event(self.event, context)


class OpaqueFunction(Action):
    """Call ``function(context, *args, **kwargs)``; the actions it returns run next."""

    def __init__(
        self,
        *,
        function: Callable[..., Any],
        args: Iterable[Any] | None = None,
        kwargs: Mapping[str, Any] | None = None,
        **left_over_kwargs: Any,
    ) -> None:
        super().__init__(**left_over_kwargs)
        if not callable(function):
            raise TypeError(f"OpaqueFunction expected a callable, got {function!r}")
        self.function = function
        self.args = list(args or [])
        self.kwargs = dict(kwargs or {})

    def execute(self, context: LaunchContext) -> list[Entity] | None:
        return _entities(self.function(context, *self.args, **self.kwargs)) or None


class OpaqueCoroutine(Action):
    """Run ``coroutine(context, *args, **kwargs)`` (without the context if
    ``ignore_context``) beside the launch, in a thread of its own."""

    def __init__(
        self,
        *,
        coroutine: Callable[..., Any],
        args: Iterable[Any] | None = None,
        kwargs: Mapping[str, Any] | None = None,
        ignore_context: bool = False,
        **left_over_kwargs: Any,
    ) -> None:
        super().__init__(**left_over_kwargs)
        if not asyncio.iscoroutinefunction(coroutine):
            raise TypeError(f"OpaqueCoroutine expected a coroutine function, got {coroutine!r}")
        self.coroutine = coroutine
        self.args = list(args or [])
        self.kwargs = dict(kwargs or {})
        self.ignore_context = ignore_context

    def execute(self, context: LaunchContext) -> None:
        args = self.args if self.ignore_context else [context, *self.args]
        run = lambda: asyncio.run(self.coroutine(*args, **self.kwargs))  # noqa: E731
        threading.Thread(target=run, daemon=True).start()


class SetEnvironmentVariable(Action):
    """Set an environment variable for the processes after it (in its scope)."""

    def __init__(
        self, name: SomeSubstitutionsType, value: SomeSubstitutionsType, **kwargs: Any
    ) -> None:
        super().__init__(**kwargs)
        self.name = normalize_to_list_of_substitutions(name)
        self.value = normalize_to_list_of_substitutions(value)

    def execute(self, context: LaunchContext) -> None:
        name = perform_substitutions(context, self.name)
        context.environment[name] = perform_substitutions(context, self.value)


class AppendEnvironmentVariable(Action):
    """Append (or ``prepend``) a value to an environment variable, ``separator`` between."""

    def __init__(
        self,
        name: SomeSubstitutionsType,
        value: SomeSubstitutionsType,
        prepend: bool | SomeSubstitutionsType = False,
        separator: SomeSubstitutionsType = os.pathsep,
        **kwargs: Any,
    ) -> None:
        super().__init__(**kwargs)
        self.name = normalize_to_list_of_substitutions(name)
        self.value = normalize_to_list_of_substitutions(value)
        self.prepend = prepend
        self.separator = normalize_to_list_of_substitutions(separator)

    def execute(self, context: LaunchContext) -> None:
        name = perform_substitutions(context, self.name)
        value = perform_substitutions(context, self.value)
        prepend = self.prepend
        if not isinstance(prepend, bool):
            prepend = perform_substitutions(context, prepend).strip().lower() in ("true", "1")
        old = context.environment.get(name)
        if old:
            separator = perform_substitutions(context, self.separator)
            value = f"{value}{separator}{old}" if prepend else f"{old}{separator}{value}"
        context.environment[name] = value


class UnsetEnvironmentVariable(Action):
    """Unset an environment variable for the processes after it."""

    def __init__(self, name: SomeSubstitutionsType, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.name = normalize_to_list_of_substitutions(name)

    def execute(self, context: LaunchContext) -> None:
        context.environment.pop(perform_substitutions(context, self.name), None)


class PushEnvironment(Action):
    """Save the environment; ``PopEnvironment`` restores it."""

    def execute(self, context: LaunchContext) -> None:
        context.push_environment()


class PopEnvironment(Action):
    """Restore the environment the last ``PushEnvironment`` saved."""

    def execute(self, context: LaunchContext) -> None:
        context.pop_environment()


class ResetEnvironment(Action):
    """Back to the environment the launch started with."""

    def execute(self, context: LaunchContext) -> None:
        context.environment.clear()
        context.environment.update(context.launch.env)


class PushLaunchConfigurations(Action):
    """Save the launch configurations; ``PopLaunchConfigurations`` restores them."""

    def execute(self, context: LaunchContext) -> None:
        context.push_configurations()


class PopLaunchConfigurations(Action):
    """Restore the launch configurations the last ``PushLaunchConfigurations`` saved."""

    def execute(self, context: LaunchContext) -> None:
        context.pop_configurations()


class ResetLaunchConfigurations(Action):
    """Clear the launch configurations, keeping only ``launch_configurations`` (their
    values worked out before the clear)."""

    def __init__(
        self,
        launch_configurations: Mapping[SomeSubstitutionsType, SomeSubstitutionsType] | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(**kwargs)
        self.launch_configurations = dict(launch_configurations or {})

    def execute(self, context: LaunchContext) -> None:
        kept = {
            perform_substitutions(context, k): perform_substitutions(context, v)
            for k, v in self.launch_configurations.items()
        }
        context.launch_configurations.clear()
        context.launch_configurations.update(kept)


class UnsetLaunchConfiguration(Action):
    """Remove a launch configuration."""

    def __init__(self, name: SomeSubstitutionsType, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.name = normalize_to_list_of_substitutions(name)

    def execute(self, context: LaunchContext) -> None:
        context.launch_configurations.pop(perform_substitutions(context, self.name), None)


class ExecuteProcess(Action):
    """A process to run: ``cmd`` is a list of arguments, each substitutions."""

    def __init__(
        self,
        *,
        cmd: Iterable[SomeSubstitutionsType],
        prefix: SomeSubstitutionsType | None = None,
        name: SomeSubstitutionsType | None = None,
        cwd: SomeSubstitutionsType | None = None,
        env: Mapping[str, str] | None = None,
        additional_env: Mapping[str, SomeSubstitutionsType] | None = None,
        shell: bool = False,
        sigterm_timeout: float | SomeSubstitutionsType | None = None,
        sigkill_timeout: float | SomeSubstitutionsType | None = None,
        emulate_tty: bool = False,
        output: str = "log",
        output_format: str = "[{this.process_description.final_name}] {line}",
        cached_output: bool = False,
        log_cmd: bool = False,
        on_exit: Any = None,
        respawn: bool | SomeSubstitutionsType = False,
        respawn_delay: float | None = None,
        respawn_max_retries: int = -1,
        **kwargs: Any,
    ) -> None:
        super().__init__(**kwargs)
        self.cmd = [normalize_to_list_of_substitutions(part) for part in cmd]
        self.prefix = None if prefix is None else normalize_to_list_of_substitutions(prefix)
        self.output_format = output_format
        self.cached_output = cached_output
        self.log_cmd = log_cmd
        self.respawn = respawn
        self.respawn_delay = respawn_delay
        self.respawn_max_retries = respawn_max_retries
        self.process_details: dict[str, Any] | None = None
        self.process_name = name
        self.cwd = cwd
        self.env = env
        self.additional_env = dict(additional_env or {})
        self.shell = shell
        self.sigterm_timeout = sigterm_timeout
        self.sigkill_timeout = sigkill_timeout
        self.emulate_tty = emulate_tty  # output is line-buffered here anyway
        self.output = output
        self.on_exit = on_exit

    def escalation_timeout(self, name: str, context: LaunchContext) -> float:
        """Seconds before ``sigterm_timeout`` / ``sigkill_timeout`` escalates: this
        action's own, else the launch configuration of that name, else 5."""
        value = getattr(self, name)
        if value is None:
            value = context.launch_configurations.get(name, "5")
        if not isinstance(value, (int, float)):
            value = perform_substitutions(context, value)
        try:
            return float(value)
        except ValueError:
            raise LaunchError(f"{name} must be a number of seconds, not {value!r}") from None

    def describe_conditional_sub_entities(self) -> list[tuple[str, list[Entity]]]:
        exits = [] if self.on_exit is None or callable(self.on_exit) else _entities(self.on_exit)
        return [("on_exit", exits)] if exits else []

    def label(self, cmd: list[str], context: LaunchContext) -> str:
        if self.process_name is not None:
            return perform_substitutions(context, self.process_name)
        first = cmd[0].split()[0] if self.shell and cmd else cmd[0]
        return Path(first).name

    def command(self, context: LaunchContext) -> list[str]:
        return [perform_substitutions(context, part) for part in self.cmd]

    def _prefix(self, cmd: list[str], context: LaunchContext) -> str:
        """The launch prefix (``gdb -ex run --args``, ``xterm -e``): the action's own, else
        the ``launch-prefix`` configuration (``ros2 launch --launch-prefix``) if the
        executable's name matches ``launch-prefix-filter``, as upstream applies them."""
        if self.prefix is not None:
            return perform_substitutions(context, self.prefix)
        configs = context.launch_configurations
        prefix = str(configs.get("launch-prefix", ""))
        prefix_filter = str(configs.get("launch-prefix-filter", ""))
        if prefix and cmd and re.match(prefix_filter, os.path.basename(cmd[0])) is None:
            return ""
        return prefix

    def shows_stdout(self) -> bool:
        """Whether stdout goes to the screen: ``output`` 'screen' or 'both', unless
        ``OVERRIDE_LAUNCH_PROCESS_OUTPUT`` says otherwise (``ros2 launch -a``)."""
        return os.environ.get("OVERRIDE_LAUNCH_PROCESS_OUTPUT", self.output) in ("screen", "both")

    def respawns(self, context: LaunchContext) -> bool:
        """Whether the process is started again when it exits (``respawn``)."""
        if isinstance(self.respawn, bool):
            return self.respawn
        return perform_substitutions(context, self.respawn).strip().lower() in ("true", "1")

    def execute(self, context: LaunchContext) -> None:
        cmd = self.command(context)
        cmd = [*shlex.split(self._prefix(cmd, context)), *cmd]
        env = dict(context.environment if self.env is None else self.env)
        env.update({k: perform_substitutions(context, v) for k, v in self.additional_env.items()})
        cwd = None if self.cwd is None else perform_substitutions(context, self.cwd)
        context.launch.plan(Planned(self, cmd, self.label(cmd, context), env, cwd, context))


# -- launch_ros actions ----------------------------------------------------------------------


def _prefix_namespace(base: str | None, namespace: str) -> str:
    if base is None or namespace.startswith("/"):
        return absolute_name(namespace or "/")
    return absolute_name(f"{base.rstrip('/')}/{namespace}".rstrip("/") or "/")


class PushROSNamespace(Action):
    """Put the nodes after it (in its scope) in ``namespace`` (relative ones nest)."""

    def __init__(self, namespace: SomeSubstitutionsType, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.namespace = normalize_to_list_of_substitutions(namespace)

    def execute(self, context: LaunchContext) -> None:
        pushed = perform_substitutions(context, self.namespace)
        base = context.launch_configurations.get("ros_namespace")
        context.launch_configurations["ros_namespace"] = _prefix_namespace(base, pushed)


_parameter_value = evaluate_parameter_value


#: Jazzy's older spelling, still exported by launch_ros.
PushRosNamespace = PushROSNamespace


class RosTimer(TimerAction):
    """A ``TimerAction`` (ROS time is wall time for the launch itself here, as it is
    upstream unless the launch sets ``use_sim_time``)."""


#: launch_ros's other spelling.
ROSTimer = RosTimer


class SetParameter(Action):
    """Set a parameter on every node after it in its scope."""

    def __init__(self, name: SomeSubstitutionsType, value: Any, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.name = name
        self.value = value

    def execute(self, context: LaunchContext) -> None:
        name = perform_substitutions(context, self.name)
        params = context.launch_configurations.setdefault("global_params", [])
        params.append((name, _parameter_value(context, self.value)))


class SetParametersFromFile(Action):
    """Give every node after it in its scope this parameter file."""

    def __init__(self, filename: SomeSubstitutionsType, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.filename = normalize_to_list_of_substitutions(filename)

    def execute(self, context: LaunchContext) -> None:
        params = context.launch_configurations.setdefault("global_params", [])
        params.append(ParameterFile(perform_substitutions(context, self.filename)))


class SetUseSimTime(SetParameter):
    """``use_sim_time`` for every node after it in its scope."""

    def __init__(self, value: bool | SomeSubstitutionsType, **kwargs: Any) -> None:
        super().__init__("use_sim_time", value, **kwargs)


class SetRemap(Action):
    """Remap ``src`` to ``dst`` in every node after it in its scope."""

    def __init__(
        self, src: SomeSubstitutionsType, dst: SomeSubstitutionsType, **kwargs: Any
    ) -> None:
        super().__init__(**kwargs)
        self.src = normalize_to_list_of_substitutions(src)
        self.dst = normalize_to_list_of_substitutions(dst)

    def execute(self, context: LaunchContext) -> None:
        remaps = context.launch_configurations.setdefault("ros_remaps", [])
        remaps.append(
            (perform_substitutions(context, self.src), perform_substitutions(context, self.dst))
        )


class SetROSLogDir(Action):
    """``ROS_LOG_DIR`` of the nodes after it (relative: under the current one)."""

    def __init__(self, new_log_dir: SomeSubstitutionsType, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.new_log_dir = normalize_to_list_of_substitutions(new_log_dir)

    def execute(self, context: LaunchContext) -> None:
        new = perform_substitutions(context, self.new_log_dir)
        if not os.path.isabs(new):
            new = os.path.join(LaunchLogDir().perform(context), new)
        context.environment["ROS_LOG_DIR"] = new


def yaml_value(value: Any) -> str:
    """A parameter value as YAML text for ``-p name:=value`` (rcl parses it as YAML)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(yaml_value(v) for v in value) + "]"
    raise LaunchError(f"parameter value {value!r} ({type(value).__name__}) is not supported")


def _flatten(params: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for key, value in params.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            flat.update(_flatten(value, name + "."))
        else:
            flat[name] = value
    return flat


class Node(ExecuteProcess):
    """A ROS node to run as its own process (``launch_ros.actions.Node``)."""

    def __init__(
        self,
        *,
        executable: SomeSubstitutionsType,
        package: SomeSubstitutionsType | None = None,
        name: SomeSubstitutionsType | None = None,
        namespace: SomeSubstitutionsType | None = None,
        exec_name: SomeSubstitutionsType | None = None,
        parameters: Sequence[Mapping[str, Any] | SomeSubstitutionsType | os.PathLike[str]]
        | None = None,
        remappings: Sequence[tuple[SomeSubstitutionsType, SomeSubstitutionsType]] | None = None,
        ros_arguments: Sequence[SomeSubstitutionsType] | None = None,
        arguments: Sequence[SomeSubstitutionsType] | None = None,
        **kwargs: Any,
    ) -> None:
        super().__init__(cmd=[executable], name=exec_name, **kwargs)
        self.package = package
        self.executable = executable
        self.name = name
        self.namespace = namespace
        self.exec_name = exec_name
        self.parameters = list(parameters or [])
        self.remappings = list(remappings or [])
        self.ros_arguments = list(ros_arguments or [])
        self.arguments = list(arguments or [])

    def node_name(self, context: LaunchContext) -> str | None:
        return None if self.name is None else perform_substitutions(context, self.name)

    def node_namespace(self, context: LaunchContext) -> str | None:
        namespace = (
            None if self.namespace is None else perform_substitutions(context, self.namespace)
        )
        base = context.launch_configurations.get("ros_namespace")
        if base is None:
            return absolute_name(namespace) if namespace else None
        return _prefix_namespace(base, namespace or "")

    def command(self, context: LaunchContext | None = None) -> list[str]:
        """The command line launch_ros builds for this node."""
        context = context or LaunchContext()
        perform = lambda value: perform_substitutions(context, value)  # noqa: E731
        if self.package is None:
            executable = perform(self.executable)
        else:
            package, name = perform(self.package), perform(self.executable)
            try:
                executable = str(executable_path(package, name, context.environment))
            except LookupError as error:
                raise LaunchError(str(error)) from None
        ros_args: list[str] = []
        name = self.node_name(context)
        if name:
            ros_args += ["-r", f"__node:={name}"]
        namespace = self.node_namespace(context)
        if namespace and namespace != "/":
            ros_args += ["-r", f"__ns:={namespace}"]
        for entry in context.launch_configurations.get("global_params", []):
            if isinstance(entry, ParameterFile):
                ros_args += ["--params-file", str(entry.evaluate(context))]
            else:
                ros_args += ["-p", f"{entry[0]}:={yaml_value(entry[1])}"]
        for entry in self.parameters:
            ros_args += self._parameter_arguments(entry, context)
        for source, target in context.launch_configurations.get("ros_remaps", []):
            ros_args += ["-r", f"{source}:={target}"]
        for source, target in self.remappings:
            ros_args += ["-r", f"{perform(source)}:={perform(target)}"]
        ros_args += [perform(a) for a in self.ros_arguments]
        argv = [executable, *(perform(a) for a in self.arguments)]
        return [*argv, "--ros-args", *ros_args] if ros_args else argv

    @staticmethod
    def _parameter_arguments(entry: Any, context: LaunchContext) -> list[str]:
        """``-p name:=value`` or ``--params-file PATH`` for one entry of ``parameters``: a
        dict, a ``Parameter``, a ``ParameterFile``, or a path (str, substitutions)."""
        if isinstance(entry, Mapping):
            arguments = []
            for key, value in _flatten(entry).items():
                name = perform_substitutions(context, key)
                arguments += ["-p", f"{name}:={yaml_value(_parameter_value(context, value))}"]
            return arguments
        if isinstance(entry, ParameterDescription):
            name, value = entry.evaluate(context)
            return ["-p", f"{name}:={yaml_value(value)}"]
        if isinstance(entry, ParameterFile):
            return ["--params-file", str(entry.evaluate(context))]
        path = os.fspath(entry) if isinstance(entry, os.PathLike) else entry
        return ["--params-file", perform_substitutions(context, path)]

    def label(self, cmd: list[str], context: LaunchContext) -> str:
        if self.exec_name is not None:
            return perform_substitutions(context, self.exec_name)
        return Path(cmd[0]).name


@dataclass
class Planned:
    """A process to start: its action, command line, label, environment and context."""

    action: ExecuteProcess
    cmd: list[str]
    label: str
    env: dict[str, str]
    cwd: str | None
    context: LaunchContext
    respawns: int = 0


class _Respawn(Action):
    """Start a planned process again (what ``respawn=True`` schedules)."""

    def __init__(self, planned: Planned) -> None:
        super().__init__()
        self.planned = planned

    def execute(self, context: LaunchContext) -> None:
        context.launch.plan(self.planned)


@dataclass
class Process:
    """One launched process."""

    node: ExecuteProcess
    name: str
    cmd: list[str]
    popen: subprocess.Popen[bytes]
    context: LaunchContext
    node_name: str | None = None
    namespace: str | None = None
    lines: list[str] = field(default_factory=list)
    reported: bool = False
    readers: list[threading.Thread] = field(default_factory=list)
    planned: Planned | None = None

    @property
    def pid(self) -> int:
        return self.popen.pid

    def output_read(self) -> bool:
        """Its output is all read (an exit is handled after the lines before it)."""
        return not any(reader.is_alive() for reader in self.readers)

    def event_details(self) -> dict[str, Any]:
        """What its process events carry (``event.action``, ``.pid``, ...)."""
        return {
            "action": self.node,
            "name": self.name,
            "cmd": self.cmd,
            "cwd": None if self.planned is None else self.planned.cwd,
            "env": None if self.planned is None else self.planned.env,
            "pid": self.pid,
        }

    @property
    def returncode(self) -> int | None:
        return self.popen.poll()

    def alive(self) -> bool:
        return self.popen.poll() is None


#: What the launcher says of a process Ctrl-C did not stop, before the signal's name.
ESCALATING = "still running: sending "
#: In a launch's output: a process Ctrl-C did not stop (callers run such a launch again
#: when honest nodes can hang on their way out: Fast DDS's teardown hang, eProsima/Fast-DDS#6513).
ESCALATED = f"{ESCALATING}SIGTERM"

#: Launches not shut down yet: stopped when the interpreter exits.
_running: set[Launch] = set()


@atexit.register
def _stop_all_at_exit() -> None:
    for system in list(_running):
        system.shutdown(sigterm_timeout=1.0, sigkill_timeout=1.0)


@dataclass
class _Timer:
    period: float
    actions: list[Entity]
    context: LaunchContext
    cancel_on_shutdown: bool = True
    due: float | None = None


class Launch:
    """A running launch: its processes and their merged, prefixed output.

    The description is visited when the launch is made (launch arguments, substitutions,
    conditions and includes are worked out, and every command line checked, before
    anything starts); ``start`` starts the processes; timers and event handlers visit
    their actions later, while ``pump`` runs. Output is read by background threads into
    a queue; ``pump`` (and ``wait``, ``shutdown``) take the lines from it in the caller's
    thread, record them in ``output`` and pass them to ``echo``, so a notebook cell shows
    them where it runs.
    """

    def __init__(
        self,
        description: LaunchDescription,
        *,
        env: Mapping[str, str] | None = None,
        echo: Callable[[str], None] | None = print,
        launch_arguments: Iterable[tuple[str, str]] = (),
    ) -> None:
        if not isinstance(description, LaunchDescription):
            raise LaunchError(
                f"expected a LaunchDescription, got {type(description).__name__}: "
                "generate_launch_description() must return LaunchDescription([...])"
            )
        self.description = description
        self.env = dict(os.environ if env is None else env)
        self.echo = echo
        self.output: list[str] = []
        self.processes: list[Process] = []
        self.shutting_down: str | None = None
        self.handlers: list[tuple[Any, LaunchContext]] = []
        self._queue: queue.Queue[tuple[Process | None, str]] = queue.Queue()
        self._readers: list[threading.Thread] = []
        self._plan: list[Planned] = []
        self._timers: list[_Timer] = []
        self._posted: queue.Queue[events.Event] = queue.Queue()
        self._cleanups: list[Callable[[], None]] = []
        self.ros_adapter: Any = None  # the launch's own ROS node, made when one is needed
        self._started = False
        context = LaunchContext(self.env, launch=self)
        context.launch_configurations.update(launch_arguments)
        self.visit([description], context)

    # -- visiting --------------------------------------------------------------------
    def visit(self, entities: Iterable[Entity], context: LaunchContext) -> None:
        """Visit ``entities`` in order, each one's sub-entities right after it."""
        for entity in entities:
            if isinstance(entity, LaunchDescription):
                children = entity.entities
            elif isinstance(entity, Action):
                children = entity.visit(context)
                if not isinstance(entity, ExecuteProcess):  # a process completes on exit
                    self._complete(entity)
            else:
                raise LaunchError(
                    f"cannot launch {entity!r}: expected an action of launch or launch_ros"
                )
            if children:
                self.visit(children, context)

    def _visit_later(self, entities: list[Entity], context: LaunchContext) -> None:
        """Visit what a timer or an event brought; an error is logged and stops the launch."""
        try:
            self.visit(entities, context)
        except LaunchError as error:
            self.say(f"[ERROR] [launch]: {error}")
            self.begin_shutdown(f"error in a launch action: {error}")

    def plan(self, planned: Planned) -> None:
        """Start this process now if the launch runs, else when it starts."""
        if not self._started:
            self._plan.append(planned)
        elif self.shutting_down is None:
            self._start(planned)

    def add_timer(
        self,
        period: float,
        actions: list[Entity],
        context: LaunchContext,
        *,
        cancel_on_shutdown: bool = True,
    ) -> None:
        """Visit ``actions`` ``period`` seconds after the launch starts (or now, if it
        has); a shutdown cancels them unless ``cancel_on_shutdown`` is false."""
        timer = _Timer(period, actions, context, cancel_on_shutdown)
        if self._started:
            timer.due = time.monotonic() + period
        self._timers.append(timer)

    def _fire_timers(self) -> None:
        now = time.monotonic()
        for timer in [t for t in self._timers if t.due is not None and t.due <= now]:
            self._timers.remove(timer)
            if self.shutting_down is None or not timer.cancel_on_shutdown:
                self._visit_later(timer.actions, timer.context)

    def emit_event(self, event: events.Event, context: LaunchContext | None = None) -> None:
        """Emit ``event``: every handler that matches it visits the actions it gives (they
        see it as ``LocalSubstitution('event....')``); then the launch's own answer
        (a ``Shutdown`` shuts down, a process event signals its processes)."""
        if isinstance(event, events.Shutdown):
            self.begin_shutdown(event.reason, event=event)
            return
        self._handle(event)
        if isinstance(event, events.SignalProcess):
            for process in self.running():
                if event.process_matcher(process.node):
                    self._signal(process, event.signal)
        elif isinstance(event, events.ShutdownProcess):
            for process in self.running():
                if event.process_matcher(process.node):
                    self._signal(process, signal.SIGINT)
        elif isinstance(event, events.IncludeLaunchDescription) and context is not None:
            self._visit_later([event.launch_description], context)

    def _handle(self, event: events.Event) -> None:
        """Visit what each registered handler matching ``event`` gives, in a copy of the
        context it was registered in (its locals: ``event``)."""
        for handler, handler_context in list(self.handlers):
            if not handler.matches(event):
                continue
            if handler.handle_once:
                self.handlers[:] = [(h, c) for h, c in self.handlers if h is not handler]
            local = handler_context.with_locals({})
            self._visit_later(_entities(handler.handle(event, local)), local)

    def _complete(self, action: Action) -> None:
        """``ExecutionComplete`` of ``action``, if a handler waits for one."""
        if self.handlers:
            self._handle(ExecutionComplete(action=action))

    # -- starting ----------------------------------------------------------------
    def start(self) -> Launch:
        """Start every process planned, in order, and the timers."""
        self._started = True
        _running.add(self)
        for planned in self._plan if self.shutting_down is None else []:
            self._start(planned)  # (a Shutdown while the description was visited: none)
        for timer in self._timers:
            timer.due = time.monotonic() + timer.period
        return self

    def _start(self, planned: Planned) -> None:
        action = planned.action
        name = f"{planned.label}-{len(self.processes) + 1}"
        env = dict(planned.env)
        env.setdefault("PYTHONUNBUFFERED", "1")  # as launch does
        env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "1")  # log lines, not blocks
        cmd = planned.cmd
        popen = subprocess.Popen(
            " ".join(cmd) if action.shell else cmd,
            shell=action.shell,
            cwd=planned.cwd,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            start_new_session=True,  # our Ctrl-C is forwarded once, by us
            preexec_fn=_die_with_launcher,
        )
        process = Process(action, name, cmd, popen, planned.context)
        if isinstance(action, Node):
            process.node_name = action.node_name(planned.context)
            process.namespace = action.node_namespace(planned.context)
        process.planned = planned
        self.processes.append(process)
        action.process_details = {"name": name, "cmd": cmd, "cwd": planned.cwd, "pid": popen.pid}
        self.say(f"[INFO] [{name}]: process started with pid [{popen.pid}]")
        for stream, fd in ((popen.stdout, 1), (popen.stderr, 2)):
            reader = threading.Thread(target=self._read, args=(process, stream, fd), daemon=True)
            reader.start()
            process.readers.append(reader)
            self._readers.append(reader)
        self._handle(ProcessStarted(**process.event_details()))

    def _read(self, process: Process, stream: IO[bytes] | None, fd: int) -> None:
        assert stream is not None
        for raw in iter(stream.readline, b""):
            process.lines.append(raw.decode(errors="replace").rstrip("\n"))
            self._queue.put((process, raw, fd))
        stream.close()

    def say(self, line: str) -> None:
        """Print a line of the launch's own (``[INFO] [launch]: ...``) in order."""
        self._queue.put((None, line.encode(), 0))

    def post_event(self, event: events.Event) -> None:
        """Emit ``event`` from another thread: ``pump`` emits it in the launch's thread."""
        self._posted.put(event)

    def add_cleanup(self, cleanup: Callable[[], None]) -> None:
        """Call ``cleanup`` once when the launch ends (its ROS node's shutdown, say)."""
        self._cleanups.append(cleanup)

    def _clean_up(self) -> None:
        while self._cleanups:
            self._cleanups.pop()()

    # -- running -----------------------------------------------------------------
    def pump(self, timeout: float = 0.0) -> list[str]:
        """Handle output, exits and timers for up to ``timeout`` seconds; the new lines."""
        new: list[str] = []
        deadline = time.monotonic() + timeout
        while True:
            while not self._posted.empty():
                self.emit_event(self._posted.get_nowait())
            self._check_exits()
            self._fire_timers()
            remaining = deadline - time.monotonic()
            try:
                if remaining > 0:
                    process, raw, fd = self._queue.get(timeout=min(0.05, remaining))
                else:
                    process, raw, fd = self._queue.get_nowait()
            except queue.Empty:
                if remaining <= 0:
                    break
                continue
            line = raw.decode(errors="replace").rstrip("\n")
            if process is not None:
                io_event = ProcessStdout if fd == 1 else ProcessStderr
                self._handle(io_event(text=raw, **process.event_details()))
                if fd == 1 and not process.node.shows_stdout():
                    continue  # output='log': to the log only, as upstream
            text = f"[{process.name}] {line}" if process is not None else line
            self.output.append(text)
            new.append(text)
            if self.echo is not None:
                self.echo(text)
        return new

    def _check_exits(self) -> None:
        for process in list(self.processes):
            code = process.returncode
            if code is None or process.reported or not process.output_read():
                continue
            process.reported = True
            if code == 0:
                self.say(
                    f"[INFO] [{process.name}]: process has finished cleanly [pid {process.pid}]"
                )
            else:
                self.say(
                    f"[ERROR] [{process.name}]: process has died [pid {process.pid}, exit code "
                    f"{code}, cmd '{' '.join(process.cmd)}']."
                )
            event = ProcessExited(returncode=code, **process.event_details())
            self._handle(event)
            on_exit = process.node.on_exit
            if callable(on_exit) and not isinstance(on_exit, Action):
                on_exit = on_exit(event, process.context)
            if on_exit:
                self._visit_later(_entities(on_exit), process.context.with_locals({"event": event}))
            self._complete(process.node)
            self._respawn(process)

    def _respawn(self, process: Process) -> None:
        """Start an exited process again if its action says ``respawn`` (after
        ``respawn_delay`` seconds, at most ``respawn_max_retries`` times; -1: always)."""
        action, planned = process.node, process.planned
        if self.shutting_down is not None or planned is None:
            return
        if not action.respawns(planned.context):
            return
        if 0 <= action.respawn_max_retries <= planned.respawns:
            return
        planned.respawns += 1
        self.add_timer(action.respawn_delay or 0.0, [_Respawn(planned)], planned.context)

    def running(self) -> list[Process]:
        return [p for p in self.processes if p.alive()]

    def busy(self) -> bool:
        """Processes still run (or their exit is still to handle), or timers are to fire."""
        unhandled = any(not p.reported for p in self.processes)
        if self.shutting_down is not None:
            return unhandled or any(not t.cancel_on_shutdown for t in self._timers)
        return unhandled or bool(self._timers)

    def wait(self, timeout: float | None = None) -> bool:
        """Pump until every process has exited and every timer fired; whether they did
        within ``timeout``."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.busy():
            if deadline is not None and time.monotonic() >= deadline:
                return False
            self.pump(0.1)
        self._drain()
        return True

    def spin(self) -> int:
        """Run in the foreground until every process exits or Ctrl-C; the exit status."""
        try:
            self.wait()
            if self.shutting_down is None:  # idle: OnShutdown handlers still run, as upstream
                self.shutting_down = "idle"
                self._handle(events.Shutdown(reason="idle"))
        except KeyboardInterrupt:
            self.say("[WARNING] [launch]: user interrupted with ctrl-c (SIGINT)")
            while True:
                try:
                    self.shutdown()
                    break
                except KeyboardInterrupt:  # as launch does: SIGTERM, SIGKILL come in time
                    self.say(
                        "[WARNING] [launch]: user interrupted with ctrl-c (SIGINT) again, "
                        "ignoring..."
                    )
        self._drain()
        self._clean_up()
        _running.discard(self)  # ended: nothing to stop at exit
        return 0 if all(p.returncode == 0 for p in self.processes) else 1

    # -- stopping ----------------------------------------------------------------
    def begin_shutdown(self, reason: str, *, event: events.Shutdown | None = None) -> None:
        """Answer ``OnShutdown`` handlers, then Ctrl-C every process (once: a second
        request while stopping changes nothing)."""
        if self.shutting_down is not None:
            return
        self.shutting_down = reason
        self.say(f"[INFO] [launch]: shutting down: {reason}")
        self._handle(event if event is not None else events.Shutdown(reason=reason))
        for process in self.running():
            self._signal(process, signal.SIGINT)

    def _signal(self, process: Process, sig: signal.Signals) -> None:
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            pass

    def shutdown(
        self, sigterm_timeout: float | None = None, sigkill_timeout: float | None = None
    ) -> dict[str, int]:
        """Ctrl-C every process, escalate to SIGTERM then SIGKILL; exit code by name."""
        if self.shutting_down is None:
            self.begin_shutdown("stop requested (Ctrl-C)")
        for sig, attr, override in (
            (signal.SIGTERM, "sigterm_timeout", sigterm_timeout),
            (signal.SIGKILL, "sigkill_timeout", sigkill_timeout),
        ):
            waits = [
                override if override is not None else p.node.escalation_timeout(attr, p.context)
                for p in self.processes
            ]
            deadline = time.monotonic() + max(waits, default=0.0)
            while self.running() and time.monotonic() < deadline:
                self.pump(0.05)
            for process in self.running():
                self.say(f"[WARNING] [{process.name}]: {ESCALATING}{sig.name}")
                self._signal(process, sig)
        for process in self.processes:
            process.popen.wait()
            self._signal(process, signal.SIGKILL)  # anything it started in its group
        self._drain()
        self._clean_up()
        _running.discard(self)
        return {p.name: p.popen.returncode for p in self.processes}

    def _drain(self) -> None:
        for reader in self._readers:
            reader.join(timeout=1.0)
        self._check_exits()
        self.pump(0.0)

    # -- reading -------------------------------------------------------------------
    def process(self, name: str) -> Process:
        """The process named ``name`` (``talker-1``) or whose node is named ``name``."""
        for process in self.processes:
            if name in (process.name, process.node_name):
                return process
        raise KeyError(f"no process {name!r}: {[p.name for p in self.processes]}")

    def __enter__(self) -> Launch:
        return self

    def __exit__(self, *exc: object) -> None:
        self.shutdown()


def launch(
    description: LaunchDescription,
    *,
    env: Mapping[str, str] | None = None,
    echo: Callable[[str], None] | None = print,
    launch_arguments: Iterable[tuple[str, str]] = (),
) -> Launch:
    """Start ``description``; use as ``with launch(ld) as system: ...`` (stops on exit)."""
    return Launch(description, env=env, echo=echo, launch_arguments=launch_arguments).start()


#: This project's upstream-named front ends, which launch files import.
FRONT_ENDS = ("launch", "launch_ros")


def _front_ends_for_launch_files() -> None:
    """Make ``import launch`` / ``import launch_ros`` give this project's packages.

    A ROS package's ``launch/`` folder on ``sys.path`` (its ``--symlink-install`` build
    folder is on ``PYTHONPATH`` once the workspace is sourced) is a namespace package to
    Python's path finder, which comes before the finder of an editable install: the
    launch file would get that empty folder. A full install's ``launch`` is a regular
    package, which wins over such folders; here the editable finder is asked directly.
    """
    for name in FRONT_ENDS:
        loaded = sys.modules.get(name)
        if loaded is not None and getattr(loaded, "__file__", None):
            continue
        for finder in sys.meta_path:
            find_spec = getattr(finder, "find_spec", None)
            spec = find_spec(name, None) if find_spec else None
            if spec is not None and spec.loader is not None and spec.has_location:
                module = importlib.util.module_from_spec(spec)
                sys.modules[name] = module
                spec.loader.exec_module(module)
                break


#: Extensions of XML and YAML launch files (anything else is read as Python, as upstream).
FRONTEND_SUFFIXES = (".xml", ".yaml", ".yml")


def load_launch_file(path: str | os.PathLike[str]) -> LaunchDescription:
    """The ``LaunchDescription`` of a launch file: Python, XML or YAML by its extension."""
    source = Path(path)
    if not source.is_file():
        raise LaunchError(f"no launch file '{source}'")
    if source.suffix in FRONTEND_SUFFIXES:
        return FrontendLaunchDescriptionSource(str(source))._load(source)
    return load_python_launch_file(source)


def load_python_launch_file(path: str | os.PathLike[str]) -> LaunchDescription:
    """Run a Python launch file and return its ``generate_launch_description()``."""
    source = Path(path)
    if not source.is_file():
        raise LaunchError(f"no launch file '{source}'")
    _front_ends_for_launch_files()
    namespace: dict[str, Any] = {"__file__": str(source), "__name__": "__launch_file__"}
    exec(compile(source.read_text(), str(source), "exec"), namespace)  # noqa: S102
    generate = namespace.get("generate_launch_description")
    if not callable(generate):
        raise LaunchError(f"{source} has no function generate_launch_description()")
    return generate()


def include(
    path: str | os.PathLike[str], launch_arguments: Iterable[tuple[str, str]] = ()
) -> LaunchDescription:
    """A description that includes the launch file ``path`` with these arguments (what
    ``ros2 launch`` runs, as upstream: required arguments are checked, the file's folder
    is ``ThisLaunchFileDir``)."""
    source = AnyLaunchDescriptionSource(os.fspath(path))
    return LaunchDescription([IncludeLaunchDescription(source, launch_arguments=launch_arguments)])


class ExecuteLocal(ExecuteProcess):
    """A process given as a ``launch.descriptions.Executable`` (what ``ExecuteProcess``
    builds from its ``cmd``), with the same options."""

    def __init__(self, *, process_description: Executable, **kwargs: Any) -> None:
        description = process_description
        super().__init__(
            cmd=[*description.cmd, *description.arguments],
            prefix=description.prefix,
            name=description.name,
            cwd=description.cwd,
            env=None if description.env is None else dict(description.env),
            additional_env=None
            if description.additional_env is None
            else dict(description.additional_env),
            **kwargs,
        )
        self.process_description = description


#: What ``LaunchDescription`` holds: an entity, or a list of them.
SomeEntitiesType = LaunchDescriptionEntity | Iterable[LaunchDescriptionEntity]
SomeEntitiesType_types_tuple = (LaunchDescriptionEntity, Iterable)


def _walk(entity: Entity, depth: int, lines: list[str]) -> None:
    pad = "    " * depth
    if isinstance(entity, LaunchDescription):
        lines.append(f"{pad}<launch.LaunchDescription object>")
    else:
        condition = "" if getattr(entity, "condition", None) is None else " (conditional)"
        lines.append(f"{pad}{entity.describe()}{condition}")
    for sub in entity.describe_sub_entities():
        _walk(sub, depth + 1, lines)
    for reason, subs in entity.describe_conditional_sub_entities():
        lines.append(f"{pad}    on {reason}:")
        for sub in subs:
            if isinstance(sub, LaunchDescriptionEntity):
                _walk(sub, depth + 2, lines)
            else:
                lines.append(f"{pad}        {sub!r}")


def format_launch_description(description: LaunchDescription) -> str:
    """The tree of a description's entities, as ``LaunchIntrospector`` shows it."""
    lines: list[str] = []
    _walk(description, 0, lines)
    return "\n".join(lines)


class LaunchIntrospector:
    """Shows a description's entities without running it."""

    def format_launch_description(self, launch_description: LaunchDescription) -> str:
        return format_launch_description(launch_description)


class LaunchService:
    """Runs launch descriptions (what ``ros2 launch`` uses): include them, then ``run``."""

    def __init__(
        self,
        *,
        argv: Iterable[str] | None = None,
        noninteractive: bool = False,
        debug: bool = False,
    ) -> None:
        self.argv = list(argv or [])
        self.noninteractive = noninteractive
        self.debug = debug
        self._descriptions: list[LaunchDescription] = []
        self._launch: Launch | None = None

    def include_launch_description(self, launch_description: LaunchDescription) -> None:
        self._descriptions.append(launch_description)

    def run(self, *, shutdown_when_idle: bool = True) -> int:
        """Run everything included until every process exits (or Ctrl-C): 0 if all did
        cleanly."""
        arguments = [tuple(a.split(":=", 1)) for a in self.argv if ":=" in a]
        self._launch = Launch(
            LaunchDescription(self._descriptions),
            launch_arguments=[(name, value) for name, value in arguments],
            echo=lambda line: print(line, flush=True),
        )
        return self._launch.start().spin()

    def shutdown(self, force_sync: bool = False) -> None:
        if self._launch is not None:
            self._launch.begin_shutdown("LaunchService.shutdown() called")


def get_launch_description_from_python_launch_file(
    python_launch_file_path: str,
) -> LaunchDescription:
    return load_python_launch_file(python_launch_file_path)


def get_launch_description_from_frontend_launch_file(
    frontend_launch_file_path: str, *, parser: Any = None
) -> LaunchDescription:
    return FrontendLaunchDescriptionSource(frontend_launch_file_path)._load(
        Path(frontend_launch_file_path)
    )


def get_launch_description_from_any_launch_file(
    launch_file_path: str | os.PathLike[str],
) -> LaunchDescription:
    return load_launch_file(launch_file_path)


def load_python_launch_file_as_module(python_launch_file_path: str) -> Any:
    """A Python launch file run as a module (``generate_launch_description`` on it)."""
    path = Path(python_launch_file_path)
    _front_ends_for_launch_files()
    spec = importlib.util.spec_from_file_location(path.stem.replace(".", "_"), path)
    if spec is None or spec.loader is None:
        raise InvalidPythonLaunchFileError(f"cannot load '{path}' as a Python module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
