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
import os
import shutil
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from rosbook.launch.workspace import package_prefix


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

    def scoped(self) -> LaunchContext:
        """A copy whose configurations and environment changes stay in it (a group's)."""
        child = copy.copy(self)
        child.launch_configurations = {
            k: copy.copy(v) for k, v in self.launch_configurations.items()
        }
        child.environment = dict(self.environment)
        return child

    def reading(self, path: Path) -> LaunchContext:
        """The same configurations, while the launch file ``path`` is read."""
        child = copy.copy(self)
        child.launch_file = path
        return child

    def perform_substitution(self, substitution: Substitution) -> str:
        return substitution.perform(self)


class Substitution:
    """Text worked out when the launch runs."""

    def perform(self, context: LaunchContext) -> str:
        raise NotImplementedError

    def describe(self) -> str:
        return repr(self)


SomeSubstitutionsType = str | Substitution | Iterable[str | Substitution]


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


class FindPackageShare(Substitution):
    """``<prefix>/share/<package>`` of an installed package (``launch_ros``)."""

    def __init__(self, package: SomeSubstitutionsType) -> None:
        self.package = normalize_to_list_of_substitutions(package)

    def perform(self, context: LaunchContext) -> str:
        package = perform_substitutions(context, self.package)
        try:
            return str(package_prefix(package, context.environment) / "share" / package)
        except LookupError as error:
            raise SubstitutionFailure(str(error)) from None

    def describe(self) -> str:
        return f"Pkg('{_describe(self.package)}')"


# -- conditions --------------------------------------------------------------------------


class Condition:
    """Whether an action runs (its ``condition=``)."""

    def evaluate(self, context: LaunchContext) -> bool:
        raise NotImplementedError


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
