"""Descriptions a launch file builds actions from: ``launch_ros.descriptions``
(``Parameter``, ``ParameterValue``, ``ParameterFile``, ``ComposableNode``) and
``launch.descriptions.Executable``, under upstream's names and arguments.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from rosbook.launch.substitutions import (
    Condition,
    LaunchContext,
    LaunchError,
    SomeSubstitutionsType,
    Substitution,
    is_substitution,
    normalize_to_list_of_substitutions,
    parse_substitution,
    perform_substitutions,
)

#: The types a typed parameter value may be coerced to (``value_type=``).
_SCALARS = (bool, int, float, str)


def _coerce(text: str, value_type: Any) -> Any:
    """``text`` read as ``value_type`` (None: as YAML), as launch_ros types a value."""
    if value_type is str:
        return text
    value = yaml.safe_load(text) if text.strip() else ""
    if value_type is None:
        return "" if value is None else value
    origin = getattr(value_type, "__origin__", None)
    if origin is list:
        (item,) = value_type.__args__
        if not isinstance(value, list):
            raise LaunchError(f"parameter value {text!r} is not a list of {item.__name__}")
        return [_coerce(str(v), item) for v in value]
    if value_type is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if value_type in _SCALARS and isinstance(value, value_type):
        return value
    raise LaunchError(
        f"parameter value {text!r} is not a {getattr(value_type, '__name__', value_type)}"
    )


class ParameterValue:
    """A parameter's value: a literal, or substitutions read as YAML (or as
    ``value_type``: ``int``, ``float``, ``bool``, ``str``, ``List[...]``)."""

    def __init__(self, value: Any, *, value_type: Any = None) -> None:
        self.value = value
        self.value_type = value_type

    def evaluate(self, context: LaunchContext) -> Any:
        return evaluate_parameter_value(context, self.value, self.value_type)

    def __str__(self) -> str:
        return f"ParameterValue({self.value!r})"


def evaluate_parameter_value(context: LaunchContext, value: Any, value_type: Any = None) -> Any:
    """A literal as is; substitutions performed and read as YAML, as launch_ros does."""
    if isinstance(value, ParameterValue):
        return value.evaluate(context)
    if is_substitution(value):
        return _coerce(perform_substitutions(context, value), value_type)
    if isinstance(value, (list, tuple)):
        return [evaluate_parameter_value(context, v) for v in value]
    return value


class Parameter:
    """One parameter: its name and value (``launch_ros.descriptions.Parameter``)."""

    def __init__(self, name: SomeSubstitutionsType, value: Any, *, value_type: Any = None) -> None:
        self.name = normalize_to_list_of_substitutions(name)
        self.parameter_value = ParameterValue(value, value_type=value_type)

    @property
    def value(self) -> Any:
        return self.parameter_value.value

    def evaluate(self, context: LaunchContext) -> tuple[str, Any]:
        return perform_substitutions(context, self.name), self.parameter_value.evaluate(context)


class ParameterFile:
    """A YAML parameter file; with ``allow_substs``, its ``$(var ...)`` are substituted
    first (into a temporary file, removed when the launch's interpreter exits)."""

    def __init__(
        self,
        param_file: str | os.PathLike[str] | SomeSubstitutionsType,
        *,
        allow_substs: bool | SomeSubstitutionsType = False,
    ) -> None:
        self.param_file = param_file
        self.allow_substs = allow_substs

    def evaluate(self, context: LaunchContext) -> Path:
        if isinstance(self.param_file, os.PathLike):
            path = Path(self.param_file)
        else:
            path = Path(perform_substitutions(context, self.param_file))
        allow = self.allow_substs
        if not isinstance(allow, bool):
            allow = perform_substitutions(context, allow).strip().lower() in ("true", "1")
        if not allow:
            return path
        try:
            text = path.read_text()
        except OSError as error:
            raise LaunchError(f"parameter file '{path}': {error.strerror}") from None
        substituted = perform_substitutions(context, parse_substitution(text))
        with tempfile.NamedTemporaryFile(
            "w", prefix="launch_params_", suffix=".yaml", delete=False
        ) as out:
            out.write(substituted)
        _temporary_files.append(Path(out.name))
        return Path(out.name)

    def __str__(self) -> str:
        return f"ParameterFile({self.param_file!r})"


#: Substituted parameter files written by ``ParameterFile(allow_substs=True)``.
_temporary_files: list[Path] = []


class ComposableNode:
    """A node built as a C++ component (``rclcpp_components``), loaded into a container."""

    def __init__(
        self,
        *,
        package: SomeSubstitutionsType,
        plugin: SomeSubstitutionsType,
        name: SomeSubstitutionsType | None = None,
        namespace: SomeSubstitutionsType | None = None,
        parameters: Sequence[Any] | None = None,
        remappings: Iterable[tuple[SomeSubstitutionsType, SomeSubstitutionsType]] | None = None,
        extra_arguments: Sequence[Mapping[str, Any]] | None = None,
        condition: Condition | None = None,
    ) -> None:
        self.package = normalize_to_list_of_substitutions(package)
        self.node_plugin = normalize_to_list_of_substitutions(plugin)
        self.node_name = None if name is None else normalize_to_list_of_substitutions(name)
        self.node_namespace = (
            None if namespace is None else normalize_to_list_of_substitutions(namespace)
        )
        self.parameters = list(parameters or [])
        self.remappings = list(remappings or [])
        self.extra_arguments = list(extra_arguments or [])
        self.condition = condition

    def describe(self) -> str:
        """``package/plugin (name)`` as the walk of a description shows it."""
        text = " + ".join(s.describe() for s in self.package + self.node_plugin)
        if self.node_name is not None:
            text += " name " + " + ".join(s.describe() for s in self.node_name)
        return f"ComposableNode({text})"


class Executable:
    """A process to run (``launch.descriptions.Executable``): its command line, name,
    working folder and environment."""

    def __init__(
        self,
        *,
        cmd: Iterable[SomeSubstitutionsType],
        prefix: SomeSubstitutionsType | None = None,
        name: SomeSubstitutionsType | None = None,
        cwd: SomeSubstitutionsType | None = None,
        env: Mapping[SomeSubstitutionsType, SomeSubstitutionsType] | None = None,
        additional_env: Mapping[SomeSubstitutionsType, SomeSubstitutionsType] | None = None,
        arguments: Iterable[SomeSubstitutionsType] | None = None,
    ) -> None:
        self.cmd = list(cmd)
        self.prefix = prefix
        self.name = name
        self.cwd = cwd
        self.env = env
        self.additional_env = additional_env
        self.arguments = list(arguments or [])


__all__ = [
    "ComposableNode",
    "Executable",
    "Parameter",
    "ParameterFile",
    "ParameterValue",
    "Substitution",
    "evaluate_parameter_value",
]
