"""Substitutions and conditions of launch files: text worked out when the launch runs.

The names, arguments and semantics are upstream's (``launch.substitutions``,
``launch.conditions``, ``launch_ros.substitutions``) for the part the book and the
official Jazzy tutorials use; ``launch`` and ``launch_ros`` re-export them. A value a
launch action takes as *substitutions* is a ``str``, a ``Substitution`` or a list of
them, concatenated when performed::

    PathJoinSubstitution([FindPackageShare('robot_talk'), 'launch', 'talk.launch.py'])
    ['/', LaunchConfiguration('robot'), '/chatter']
"""

from __future__ import annotations

import copy
import importlib
import math
import os
import random
import shlex
import shutil
import socket
import subprocess
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from rosbook.launch.workspace import executable_path, package_prefix


class LaunchError(RuntimeError):
    """The description cannot be launched (unknown package or executable, bad entity)."""


class SubstitutionFailure(LaunchError):
    """A substitution cannot be performed (an unset launch configuration, say)."""


class InvalidConditionExpressionError(LaunchError):
    """A condition's expression is none of 'true', '1', 'false', '0'."""


class LaunchContext:
    """What a running launch knows while it visits actions: its launch configurations
    (with ``ros_namespace`` and ``global_params`` for ``launch_ros``, as upstream), the
    environment, the launch file being read and the launch that starts the processes."""

    def __init__(self, environment: dict[str, str] | None = None, launch: Any = None) -> None:
        self.launch_configurations: dict[str, Any] = {}
        self.environment: dict[str, str] = dict(os.environ if environment is None else environment)
        self.launch_file: Path | None = None
        self.launch = launch
        self._locals: dict[str, Any] = {}
        self._config_stack: list[dict[str, Any]] = []
        self._env_stack: list[dict[str, str]] = []

    @property
    def locals(self) -> SimpleNamespace:
        """What an event handler gave its actions (``locals.event``), as attributes."""
        return SimpleNamespace(**self._locals)

    def get_locals_as_dict(self) -> dict[str, Any]:
        return dict(self._locals)

    def extend_locals(self, new_locals: dict[str, Any]) -> None:
        self._locals = {**self._locals, **new_locals}

    def with_locals(self, new_locals: dict[str, Any]) -> LaunchContext:
        """This context, ``new_locals`` added, in a copy (what a handler's actions see)."""
        child = copy.copy(self)
        child._locals = {**self._locals, **new_locals}
        return child

    def scoped(self) -> LaunchContext:
        """A copy whose configurations and environment changes stay in it (a group's)."""
        child = copy.copy(self)
        child.launch_configurations = {
            k: copy.copy(v) for k, v in self.launch_configurations.items()
        }
        child.environment = dict(self.environment)
        child._config_stack = list(self._config_stack)
        child._env_stack = list(self._env_stack)
        return child

    def push_configurations(self) -> None:
        """Save the launch configurations (``PushLaunchConfigurations``)."""
        self._config_stack.append({k: copy.copy(v) for k, v in self.launch_configurations.items()})

    def pop_configurations(self) -> None:
        """Restore what the last ``push_configurations`` saved."""
        if not self._config_stack:
            raise LaunchError("PopLaunchConfigurations without a PushLaunchConfigurations")
        self.launch_configurations.clear()
        self.launch_configurations.update(self._config_stack.pop())

    def push_environment(self) -> None:
        """Save the environment (``PushEnvironment``)."""
        self._env_stack.append(dict(self.environment))

    def pop_environment(self) -> None:
        """Restore what the last ``push_environment`` saved."""
        if not self._env_stack:
            raise LaunchError("PopEnvironment without a PushEnvironment")
        self.environment.clear()
        self.environment.update(self._env_stack.pop())

    def reading(self, path: Path) -> LaunchContext:
        """The same configurations, while the launch file ``path`` is read."""
        child = copy.copy(self)
        child.launch_file = path
        return child

    def perform_substitution(self, substitution: Substitution) -> str:
        return substitution.perform(self)

    @property
    def is_shutdown(self) -> bool:
        """Whether the launch is shutting down."""
        return self.launch is not None and self.launch.shutting_down is not None

    def register_event_handler(self, event_handler: Any) -> None:
        """Answer events with ``event_handler`` from now on (in this context)."""
        self.launch.handlers.append((event_handler, self))

    def unregister_event_handler(self, event_handler: Any) -> None:
        handlers = self.launch.handlers
        handlers[:] = [(h, c) for h, c in handlers if h is not event_handler]

    def emit_event_sync(self, event: Any) -> None:
        """Emit ``event`` once the action being visited is done (from any thread)."""
        self.launch.post_event(event)


class Substitution:
    """Text worked out when the launch runs."""

    def perform(self, context: LaunchContext) -> str:
        raise NotImplementedError

    def describe(self) -> str:
        return repr(self)


SomeSubstitutionsType = str | Substitution | Iterable[str | Substitution]
SomeSubstitutionsType_types_tuple = (str, Substitution, Iterable)


def normalize_to_list_of_substitutions(value: SomeSubstitutionsType) -> list[Substitution]:
    """``'a'`` -> ``[TextSubstitution(text='a')]``; a substitution or a list of them, as is."""
    if isinstance(value, (str, Substitution)):
        value = [value]
    result: list[Substitution] = []
    for item in value:
        if isinstance(item, str):
            result.append(TextSubstitution(text=item))
        elif isinstance(item, Substitution):
            result.append(item)
        else:
            raise TypeError(f"expected str or Substitution, got {type(item).__name__} ({item!r})")
    return result


def perform_substitutions(context: LaunchContext, value: SomeSubstitutionsType) -> str:
    """The text of ``value``: its substitutions performed and concatenated."""
    return "".join(s.perform(context) for s in normalize_to_list_of_substitutions(value))


def is_substitution(value: Any) -> bool:
    """A substitution, or a list holding one (a value to perform, not a literal)."""
    if isinstance(value, Substitution):
        return True
    return isinstance(value, (list, tuple)) and any(isinstance(v, Substitution) for v in value)


def _describe(subs: list[Substitution]) -> str:
    return " + ".join(s.describe() for s in subs)


class TextSubstitution(Substitution):
    def __init__(self, *, text: str) -> None:
        if not isinstance(text, str):
            raise TypeError(f"TextSubstitution expected Text object got '{type(text)}' instead.")
        self.text = text

    def perform(self, context: LaunchContext) -> str:
        return self.text

    def describe(self) -> str:
        return f"'{self.text}'"


class LaunchConfiguration(Substitution):
    """The value of a launch configuration (a launch argument, say), else ``default``."""

    def __init__(
        self, variable_name: SomeSubstitutionsType, *, default: SomeSubstitutionsType | None = None
    ) -> None:
        self.variable_name = normalize_to_list_of_substitutions(variable_name)
        self.default = None if default is None else normalize_to_list_of_substitutions(default)

    def perform(self, context: LaunchContext) -> str:
        name = perform_substitutions(context, self.variable_name)
        if name in context.launch_configurations:
            return str(context.launch_configurations[name])
        if self.default is None:
            raise SubstitutionFailure(f"launch configuration '{name}' does not exist")
        return perform_substitutions(context, self.default)

    def describe(self) -> str:
        return f"LaunchConfig({_describe(self.variable_name)})"


class PathJoinSubstitution(Substitution):
    """Its parts joined as a path (``os.path.join``)."""

    def __init__(self, substitutions: Iterable[str | Substitution]) -> None:
        self.substitutions = normalize_to_list_of_substitutions(list(substitutions))

    def perform(self, context: LaunchContext) -> str:
        return os.path.join(*(s.perform(context) for s in self.substitutions))

    def describe(self) -> str:
        return f"PathJoin('{_describe(self.substitutions)}')"


class PythonExpression(Substitution):
    """A Python expression's value as text; ``math``'s names are in scope, as upstream."""

    def __init__(
        self, expression: SomeSubstitutionsType, python_modules: SomeSubstitutionsType = ("math",)
    ) -> None:
        self.expression = normalize_to_list_of_substitutions(expression)
        self.python_modules = normalize_to_list_of_substitutions(list(python_modules))

    def perform(self, context: LaunchContext) -> str:
        scope: dict[str, Any] = {}
        for sub in self.python_modules:
            module = importlib.import_module(sub.perform(context))
            if module.__name__ == "math":
                scope.update(vars(module))
            scope[module.__name__] = module
        return str(eval(perform_substitutions(context, self.expression), {}, scope))  # noqa: S307

    def describe(self) -> str:
        modules = ", ".join(s.describe() for s in self.python_modules)
        return f"PythonExpr({_describe(self.expression)}, [{modules}])"


class EnvironmentVariable(Substitution):
    """An environment variable of the launch, else ``default_value``."""

    def __init__(
        self, name: SomeSubstitutionsType, *, default_value: SomeSubstitutionsType | None = None
    ) -> None:
        self.name = normalize_to_list_of_substitutions(name)
        self.default_value = (
            None if default_value is None else normalize_to_list_of_substitutions(default_value)
        )

    def perform(self, context: LaunchContext) -> str:
        name = perform_substitutions(context, self.name)
        if name in context.environment:
            return context.environment[name]
        if self.default_value is None:
            raise SubstitutionFailure(f"environment variable '{name}' does not exist")
        return perform_substitutions(context, self.default_value)

    def describe(self) -> str:
        return f"EnvVar({_describe(self.name)})"


class FindExecutable(Substitution):
    """The path of an executable on the launch's ``PATH``."""

    def __init__(self, *, name: SomeSubstitutionsType) -> None:
        self.name = normalize_to_list_of_substitutions(name)

    def perform(self, context: LaunchContext) -> str:
        name = perform_substitutions(context, self.name)
        found = shutil.which(name, path=context.environment.get("PATH"))
        if found is None:
            raise SubstitutionFailure(f"executable '{name}' not found on the PATH")
        return found

    def describe(self) -> str:
        return f"FindExec({_describe(self.name)})"


class ThisLaunchFileDir(Substitution):
    """The folder of the launch file being read."""

    def perform(self, context: LaunchContext) -> str:
        if context.launch_file is None:
            raise SubstitutionFailure("ThisLaunchFileDir used outside of a launch file")
        return str(context.launch_file.parent)

    def describe(self) -> str:
        return "ThisLaunchFileDir()"


def _as_bool(context: LaunchContext, value: list[Substitution]) -> bool:
    """A substitution's text read as a boolean, as launch's typed substitutions read it."""
    text = perform_substitutions(context, value).strip().lower()
    if text in ("true", "1"):
        return True
    if text in ("false", "0"):
        return False
    raise SubstitutionFailure(f"'{text}' is not a boolean (one of 'true', 'false', '1', '0')")


def _text(value: bool) -> str:
    return "true" if value else "false"


class NotSubstitution(Substitution):
    """'true' if ``value`` is false."""

    def __init__(self, value: SomeSubstitutionsType) -> None:
        self.value = normalize_to_list_of_substitutions(value)

    def perform(self, context: LaunchContext) -> str:
        return _text(not _as_bool(context, self.value))

    def describe(self) -> str:
        return f"NotSubstitution({_describe(self.value)})"


class AndSubstitution(Substitution):
    """'true' if both ``left`` and ``right`` are."""

    def __init__(self, left: SomeSubstitutionsType, right: SomeSubstitutionsType) -> None:
        self.left = normalize_to_list_of_substitutions(left)
        self.right = normalize_to_list_of_substitutions(right)

    def perform(self, context: LaunchContext) -> str:
        return _text(_as_bool(context, self.left) and _as_bool(context, self.right))

    def describe(self) -> str:
        return f"{type(self).__name__}({_describe(self.left)} {_describe(self.right)})"


class OrSubstitution(AndSubstitution):
    """'true' if ``left`` or ``right`` is."""

    def perform(self, context: LaunchContext) -> str:
        return _text(_as_bool(context, self.left) or _as_bool(context, self.right))


class AllSubstitution(Substitution):
    """'true' if every argument is."""

    def __init__(self, *args: SomeSubstitutionsType) -> None:
        self.args = [normalize_to_list_of_substitutions(a) for a in args]

    def perform(self, context: LaunchContext) -> str:
        return _text(all(_as_bool(context, a) for a in self.args))

    def describe(self) -> str:
        return f"{type(self).__name__}({', '.join(_describe(a) for a in self.args)})"


class AnySubstitution(AllSubstitution):
    """'true' if any argument is."""

    def perform(self, context: LaunchContext) -> str:
        return _text(any(_as_bool(context, a) for a in self.args))


def _operand(value: Any) -> list[Substitution]:
    """An operand of an equality: None is '', a bool 'true'/'false', anything else str()."""
    if not is_substitution(value):
        value = "" if value is None else _text(value) if isinstance(value, bool) else str(value)
    return normalize_to_list_of_substitutions(value)


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def values_equal(left: str, right: str) -> bool:
    """Equal as launch compares: booleans as booleans, numbers within ``math.isclose``."""
    flags = ("true", "false", "1", "0")
    if left.lower() in flags and right.lower() in flags:
        return (left.lower() in ("true", "1")) == (right.lower() in ("true", "1"))
    if _is_float(left) and _is_float(right):
        return math.isclose(float(left), float(right))
    return left == right


class EqualsSubstitution(Substitution):
    """'true' if ``left`` and ``right`` are equal (booleans and numbers by value)."""

    def __init__(self, left: Any, right: Any) -> None:
        self.left = _operand(left)
        self.right = _operand(right)

    def perform(self, context: LaunchContext) -> str:
        left = perform_substitutions(context, self.left)
        return _text(values_equal(left, perform_substitutions(context, self.right)))

    def describe(self) -> str:
        return f"{type(self).__name__}({_describe(self.left)} {_describe(self.right)})"


class NotEqualsSubstitution(EqualsSubstitution):
    """'true' if ``left`` and ``right`` differ."""

    def perform(self, context: LaunchContext) -> str:
        return _text(super().perform(context) == "false")


class IfElseSubstitution(Substitution):
    """``if_value`` if ``condition`` is true, else ``else_value``."""

    def __init__(
        self,
        condition: SomeSubstitutionsType,
        if_value: SomeSubstitutionsType = "",
        else_value: SomeSubstitutionsType = "",
    ) -> None:
        if if_value == else_value == "":
            raise RuntimeError("One of if_value and else_value must be specified")
        self.condition = normalize_to_list_of_substitutions(condition)
        self.if_value = normalize_to_list_of_substitutions(if_value)
        self.else_value = normalize_to_list_of_substitutions(else_value)

    def perform(self, context: LaunchContext) -> str:
        chosen = self.if_value if _as_bool(context, self.condition) else self.else_value
        return perform_substitutions(context, chosen)


class Command(Substitution):
    """The standard output of a command (split with ``shlex``); stderr per ``on_stderr``:
    'fail', 'ignore', 'warn' or 'capture'."""

    def __init__(
        self, command: SomeSubstitutionsType, *, on_stderr: SomeSubstitutionsType = "fail"
    ) -> None:
        self.command = normalize_to_list_of_substitutions(command)
        self.on_stderr = normalize_to_list_of_substitutions(on_stderr)

    def perform(self, context: LaunchContext) -> str:
        command = perform_substitutions(context, self.command)
        on_stderr = perform_substitutions(context, self.on_stderr)
        if on_stderr not in ("fail", "ignore", "warn", "capture"):
            raise SubstitutionFailure(
                "expected 'on_stderr' to be one of: 'fail', 'ignore', 'warn' or 'capture'"
            )
        try:
            result = subprocess.run(
                shlex.split(command),
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT if on_stderr == "capture" else subprocess.PIPE,
                text=True,
                env=context.environment,
                check=False,
            )
        except FileNotFoundError as error:
            raise SubstitutionFailure(f"file not found: {error}") from None
        if result.returncode != 0:
            message = f"executed command failed. Command: {command}"
            if result.stderr:
                message += f"\nCaptured stderr output: {result.stderr}"
            raise SubstitutionFailure(message)
        if result.stderr and on_stderr in ("fail", "warn"):
            message = (
                f"executed command showed stderr output. Command: {command}\n"
                f"Captured stderr output:\n{result.stderr}"
            )
            if on_stderr == "fail":
                raise SubstitutionFailure(message)
            print(f"[WARNING] [launch.substitutions.Command]: {message}", file=sys.stderr)
        return result.stdout

    def describe(self) -> str:
        return f"Command({_describe(self.command)})"


class FileContent(Substitution):
    """The text of the file at ``path``."""

    def __init__(self, path: SomeSubstitutionsType) -> None:
        self.path = normalize_to_list_of_substitutions(path)

    def perform(self, context: LaunchContext) -> str:
        path = perform_substitutions(context, self.path)
        try:
            return Path(path).read_text()
        except FileNotFoundError:
            raise SubstitutionFailure(f"File not found: {path}") from None


class PathSubstitution(Substitution):
    """A path (``pathlib.Path``) as text; ``/`` joins more parts, as ``Path`` does."""

    def __init__(self, path: str | os.PathLike[str] | Substitution | list[Any]) -> None:
        self.path = path

    def perform(self, context: LaunchContext) -> str:
        if isinstance(self.path, (str, os.PathLike)):
            return os.fspath(self.path)
        return perform_substitutions(context, self.path)

    def __truediv__(self, other: str | Substitution) -> PathJoinSubstitution:
        return PathJoinSubstitution([self, other])


class LocalSubstitution(Substitution):
    """An attribute of the context's locals, e.g. ``'event.reason'`` in an event's actions."""

    def __init__(self, expression: str, description: str | None = None) -> None:
        if not isinstance(expression, str):
            raise TypeError(f"LocalSubstitution expected str for 'expression', got {expression!r}")
        self.expression = expression
        self.description = description

    def perform(self, context: LaunchContext) -> str:
        value: Any = context.locals
        for part in self.expression.split("."):
            try:
                value = value[int(part)] if part.isdigit() else getattr(value, part)
            except (AttributeError, IndexError):
                raise SubstitutionFailure(
                    f"LocalSubstitution('{self.expression}'): no local '{part}' here"
                ) from None
        return str(value)

    def describe(self) -> str:
        return f"LocalVar('{self.description or self.expression}')"


class AnonName(Substitution):
    """A name made unique for this launch from ``name`` (the same for the same name)."""

    def __init__(self, name: SomeSubstitutionsType) -> None:
        self.name = normalize_to_list_of_substitutions(name)

    def perform(self, context: LaunchContext) -> str:
        name = perform_substitutions(context, self.name)
        key = "anon" + name
        if key not in context.launch_configurations:
            unique = f"{name}_{socket.gethostname()}_{os.getpid()}_{random.randint(0, sys.maxsize)}"
            context.launch_configurations[key] = (
                unique.replace(".", "_").replace("-", "_").replace(":", "_")
            )
        return str(context.launch_configurations[key])


#: Where launch logs would go (``ROS_LOG_DIR``, else ``~/.ros/log``); nothing is written.
def _log_dir(environment: dict[str, str]) -> str:
    if environment.get("ROS_LOG_DIR"):
        return environment["ROS_LOG_DIR"]
    home = environment.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
    return os.path.join(home, "log")


class LaunchLogDir(Substitution):
    """The launch's log folder (``ROS_LOG_DIR``, else ``$ROS_HOME/log``)."""

    def perform(self, context: LaunchContext) -> str:
        return _log_dir(context.environment)


class ThisLaunchFile(Substitution):
    """The path of the launch file being read."""

    def perform(self, context: LaunchContext) -> str:
        if context.launch_file is None:
            raise SubstitutionFailure("ThisLaunchFile used outside of a launch file")
        return str(context.launch_file)

    def describe(self) -> str:
        return "ThisLaunchFile()"


class FindPackagePrefix(Substitution):
    """The install prefix of a package (``launch_ros``)."""

    def __init__(self, package: SomeSubstitutionsType) -> None:
        self.package = normalize_to_list_of_substitutions(package)

    def find(self, package: str, context: LaunchContext) -> Path:
        try:
            return package_prefix(package, context.environment)
        except LookupError as error:
            raise SubstitutionFailure(str(error)) from None

    def perform(self, context: LaunchContext) -> str:
        return str(self.find(perform_substitutions(context, self.package), context))

    def describe(self) -> str:
        return f"Pkg('{_describe(self.package)}')"


FindPackage = FindPackagePrefix


class FindPackageShare(FindPackagePrefix):
    """``<prefix>/share/<package>`` of an installed package (``launch_ros``)."""

    def perform(self, context: LaunchContext) -> str:
        package = perform_substitutions(context, self.package)
        return str(self.find(package, context) / "share" / package)


class ExecutableInPackage(Substitution):
    """The path of an executable of a package (``launch_ros``)."""

    def __init__(self, executable: SomeSubstitutionsType, package: SomeSubstitutionsType) -> None:
        self.executable = normalize_to_list_of_substitutions(executable)
        self.package = normalize_to_list_of_substitutions(package)

    def perform(self, context: LaunchContext) -> str:
        package = perform_substitutions(context, self.package)
        name = perform_substitutions(context, self.executable)
        try:
            return str(executable_path(package, name, context.environment))
        except LookupError as error:
            raise SubstitutionFailure(str(error)) from None

    def describe(self) -> str:
        return f"ExecInPkg(pkg={_describe(self.package)}, exec={_describe(self.executable)})"


class Parameter(Substitution):
    """A parameter set with ``SetParameter`` before it (``launch_ros``), else ``default``."""

    def __init__(self, name: SomeSubstitutionsType, *, default: Any = None) -> None:
        self.name = normalize_to_list_of_substitutions(name)
        self.default = default

    def perform(self, context: LaunchContext) -> str:
        name = perform_substitutions(context, self.name)
        for key, value in reversed(context.launch_configurations.get("global_params", [])):
            if key == name:
                return str(value)
        if self.default is None:
            raise SubstitutionFailure(f"parameter '{name}' not found")
        return perform_substitutions(context, _operand(self.default))


# -- conditions --------------------------------------------------------------------------


class Condition:
    """Whether an action runs (its ``condition=``): ``predicate(context)``, as upstream."""

    def __init__(self, *, predicate: Callable[[LaunchContext], bool] | None = None) -> None:
        self._predicate = predicate

    def evaluate(self, context: LaunchContext) -> bool:
        if self._predicate is None:
            raise NotImplementedError("a Condition needs a predicate or its own evaluate()")
        return bool(self._predicate(context))

    def describe(self) -> str:
        return repr(self)


def evaluate_condition_expression(context: LaunchContext, expression: list[Substitution]) -> bool:
    """'true' or '1' (any case) is true, 'false' or '0' false, anything else an error."""
    text = perform_substitutions(context, expression).strip().lower()
    if text in ("true", "1"):
        return True
    if text in ("false", "0"):
        return False
    raise InvalidConditionExpressionError(
        f"Unexpected value for condition expression '{_describe(expression)}': "
        f"'{text}' is none of ['true', '1', 'false', '0']"
    )


class IfCondition(Condition):
    def __init__(self, predicate_expression: SomeSubstitutionsType) -> None:
        self.predicate_expression = normalize_to_list_of_substitutions(predicate_expression)

    def evaluate(self, context: LaunchContext) -> bool:
        return evaluate_condition_expression(context, self.predicate_expression)


class UnlessCondition(IfCondition):
    def evaluate(self, context: LaunchContext) -> bool:
        return not super().evaluate(context)


class LaunchConfigurationEquals(Condition):
    """Whether a launch configuration is ``expected_value`` (None: it is not set)."""

    def __init__(
        self, launch_configuration_name: str, expected_value: SomeSubstitutionsType | None
    ) -> None:
        self.launch_configuration_name = launch_configuration_name
        self.expected_value = (
            None if expected_value is None else normalize_to_list_of_substitutions(expected_value)
        )

    def evaluate(self, context: LaunchContext) -> bool:
        expected = self.expected_value
        if expected is not None:
            expected = perform_substitutions(context, expected)
        return context.launch_configurations.get(self.launch_configuration_name) == expected


class LaunchConfigurationNotEquals(LaunchConfigurationEquals):
    """Whether a launch configuration is not ``expected_value``."""

    def evaluate(self, context: LaunchContext) -> bool:
        return not super().evaluate(context)


# -- the substitution language of XML and YAML launch files: `$(var name)` -------------------


class _SubstitutionSyntaxError(LaunchError):
    """A ``$(...)`` in launch-file text that cannot be read."""


class _Dirname(Substitution):
    """``$(dirname)``: the folder of the launch file being read."""

    def perform(self, context: LaunchContext) -> str:
        return ThisLaunchFileDir().perform(context)


def _make_env(args: list[list[Substitution]]) -> Substitution:
    if len(args) not in (1, 2):
        raise _SubstitutionSyntaxError("env takes a name and an optional default")
    return EnvironmentVariable(args[0], default_value=args[1] if len(args) == 2 else None)


def _make_var(args: list[list[Substitution]]) -> Substitution:
    if len(args) not in (1, 2):
        raise _SubstitutionSyntaxError("var takes a name and an optional default")
    return LaunchConfiguration(args[0], default=args[1] if len(args) == 2 else None)


def _arity(name: str, cls: Callable[..., Substitution], *counts: int) -> Any:
    def make(args: list[list[Substitution]]) -> Substitution:
        if len(args) not in counts:
            raise _SubstitutionSyntaxError(
                f"{name} takes {' or '.join(map(str, counts))} argument(s)"
            )
        return cls(*args)

    return make


def _make_eval(args: list[list[Substitution]]) -> Substitution:
    if len(args) not in (1, 2):
        raise _SubstitutionSyntaxError("eval takes an expression and optional modules")
    modules = ("math",) if len(args) == 1 else [perform_substitutions(LaunchContext(), args[1])]
    return PythonExpression(args[0], modules[0].split() if len(args) == 2 else modules)


#: The ``$(name ...)`` substitutions of launch files, by name, as upstream exposes them.
FRONTEND_SUBSTITUTIONS: dict[str, Callable[[list[list[Substitution]]], Substitution]] = {
    "var": _make_var,
    "env": _make_env,
    "optenv": lambda args: EnvironmentVariable(
        args[0], default_value=args[1] if len(args) > 1 else ""
    ),
    "eval": _make_eval,
    "find-pkg-share": _arity("find-pkg-share", FindPackageShare, 1),
    "find-pkg-prefix": _arity("find-pkg-prefix", FindPackagePrefix, 1),
    "exec-in-pkg": _arity("exec-in-pkg", ExecutableInPackage, 2),
    "find-exec": lambda args: FindExecutable(name=args[0]),
    "dirname": _arity("dirname", _Dirname, 0),
    "filename": _arity("filename", ThisLaunchFile, 0),
    "anon": _arity("anon", AnonName, 1),
    "command": lambda args: Command(args[0], **({"on_stderr": args[1]} if len(args) > 1 else {})),
    "not": _arity("not", NotSubstitution, 1),
    "and": _arity("and", AndSubstitution, 2),
    "or": _arity("or", OrSubstitution, 2),
    "all": lambda args: AllSubstitution(*args),
    "any": lambda args: AnySubstitution(*args),
    "equals": _arity("equals", EqualsSubstitution, 2),
    "not-equals": _arity("not-equals", NotEqualsSubstitution, 2),
    "if": _arity("if", IfElseSubstitution, 2, 3),
    "file-content": _arity("file-content", FileContent, 1),
    "param": _arity("param", Parameter, 1),
}


def _parse(text: str, pos: int, stop: str) -> tuple[list[Substitution], int]:
    """Substitutions from ``text[pos:]`` up to a character of ``stop`` (outside quotes
    and ``$(...)``); the list and where it stopped."""
    parts: list[Substitution] = []
    literal: list[str] = []

    def flush() -> None:
        if literal:
            parts.append(TextSubstitution(text="".join(literal)))
            literal.clear()

    while pos < len(text) and text[pos] not in stop:
        if text.startswith("$(", pos):
            flush()
            substitution, pos = _parse_call(text, pos + 2)
            parts.append(substitution)
        elif text[pos] in "'\"" and stop:
            quote = text[pos]
            end = text.find(quote, pos + 1)
            if end < 0:
                raise _SubstitutionSyntaxError(f"unclosed quote {quote} in {text!r}")
            inner, _ = _parse(text[pos + 1 : end], 0, "")
            flush()
            parts.extend(inner)
            pos = end + 1
        else:
            literal.append(text[pos])
            pos += 1
    flush()
    return parts, pos


def _parse_call(text: str, pos: int) -> tuple[Substitution, int]:
    """The ``name args...)`` of a ``$(`` at ``pos``; the substitution and the end."""
    end = pos
    while end < len(text) and not text[end].isspace() and text[end] != ")":
        end += 1
    name = text[pos:end]
    if name not in FRONTEND_SUBSTITUTIONS:
        raise _SubstitutionSyntaxError(
            f"unknown substitution '$({name} ...)' in {text!r} "
            f"(known: {', '.join(sorted(FRONTEND_SUBSTITUTIONS))})"
        )
    args: list[list[Substitution]] = []
    pos = end
    while True:
        while pos < len(text) and text[pos].isspace():
            pos += 1
        if pos >= len(text):
            raise _SubstitutionSyntaxError(f"'$({name}' is not closed with ')' in {text!r}")
        if text[pos] == ")":
            break
        arg, pos = _parse(text, pos, " \t\n)")
        args.append(arg)
    return FRONTEND_SUBSTITUTIONS[name](args), pos + 1


def parse_substitution(text: str) -> list[Substitution]:
    """The substitutions of launch-file text: ``'$(find-pkg-share $(var pkg))/urdf'``."""
    parts, _ = _parse(text, 0, "")
    return parts or [TextSubstitution(text="")]
