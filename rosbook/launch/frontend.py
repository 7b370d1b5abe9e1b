"""XML and YAML launch files (``*.launch.xml``, ``*.launch.yaml``): read into the same
actions a Python launch file builds, with the tags, attributes and ``$(...)``
substitutions of upstream's ``launch_xml`` / ``launch_yaml`` front ends::

    <launch>
      <arg name="rate" default="2.0"/>
      <group>
        <push-ros-namespace namespace="robot1"/>
        <node pkg="robot_talk" exec="talker" name="talker" if="$(var with_talker)">
          <param name="rate" value="$(var rate)"/>
          <remap from="chatter" to="news"/>
        </node>
      </group>
    </launch>

A mistake in the file is one ``LaunchError`` line naming the file, the line (XML) or the
place (YAML), the element and the problem. Both formats are read with the standard
library's expat and PyYAML.
"""

from __future__ import annotations

import shlex
from collections.abc import Callable
from pathlib import Path
from typing import Any
from xml.parsers import expat

import yaml

from rosbook.launch import launcher
from rosbook.launch.descriptions import Parameter, ParameterFile
from rosbook.launch.substitutions import (
    IfCondition,
    LaunchError,
    Substitution,
    TextSubstitution,
    UnlessCondition,
    parse_substitution,
)

#: Extensions of front-end launch files, by format.
FORMATS = {".xml": "xml", ".yaml": "yaml", ".yml": "yaml"}


class Entity:
    """One element of a launch file: its tag, its attributes and its child elements."""

    def __init__(
        self, type_name: str, attrs: dict[str, Any], children: list[Entity], where: str
    ) -> None:
        self.type_name = type_name
        self.attrs = attrs
        self.children = children
        self.where = where
        self._read: set[str] = set()

    def error(self, problem: str) -> LaunchError:
        return LaunchError(f"{self.where}: <{self.type_name}> {problem}")

    def get(self, name: str, *, optional: bool = True) -> Any:
        """An attribute's raw value (text, or a YAML scalar or list); None if absent."""
        self._read.add(name)
        value = self.attrs.get(name)
        if value is None and not optional:
            raise self.error(f"needs the attribute '{name}'")
        return value

    def subs(self, name: str, *, optional: bool = True) -> list[Substitution] | None:
        """An attribute as substitutions (``$(var x)``...)."""
        value = self.get(name, optional=optional)
        if value is None:
            return None
        if isinstance(value, bool):
            value = "true" if value else "false"
        if isinstance(value, (list, dict)):
            raise self.error(f"attribute '{name}' must be text, not {type(value).__name__}")
        try:
            return parse_substitution(str(value))
        except LaunchError as error:
            raise self.error(f"attribute '{name}': {error}") from None

    def flag(self, name: str, default: bool) -> bool | list[Substitution]:
        """A true/false attribute; substitutions stay substitutions."""
        value = self.get(name)
        if value is None:
            return default
        if isinstance(value, bool):
            return value
        text = str(value).strip().lower()
        if text in ("true", "false"):
            return text == "true"
        if "$(" in text:
            return self.subs(name) or []
        raise self.error(f"attribute '{name}' must be true or false, not {value!r}")

    def number(self, name: str) -> float | list[Substitution] | None:
        value = self.get(name)
        if value is None:
            return None
        try:
            return float(value)
        except (TypeError, ValueError):
            if "$(" in str(value):
                return self.subs(name)
            raise self.error(f"attribute '{name}' must be a number, not {value!r}") from None

    def children_named(self, tag: str) -> list[Entity]:
        """Child elements ``<tag>`` (in YAML: the list under the key ``tag``)."""
        found = [c for c in self.children if c.type_name == tag]
        self._read.add(tag)
        return found

    def check_attributes(self) -> None:
        """Refuse an attribute or child element no reader asked for (``pakage=``)."""
        unknown = sorted(set(self.attrs) - self._read)
        if unknown:
            known = ", ".join(sorted(self._read)) or "none"
            raise self.error(f"has no attribute '{unknown[0]}' (known: {known})")
        for child in self.children:
            if child.type_name not in self._read:
                raise child.error(f"is not an element <{self.type_name}> can hold")


# -- reading the files into entities ---------------------------------------------------------


def _read_xml(path: Path, text: str) -> Entity:
    stack: list[Entity] = []
    root: list[Entity] = []
    parser = expat.ParserCreate()

    def start(tag: str, attrs: dict[str, str]) -> None:
        entity = Entity(tag, dict(attrs), [], f"{path}:{parser.CurrentLineNumber}")
        (stack[-1].children if stack else root).append(entity)
        stack.append(entity)

    def end(tag: str) -> None:
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(text.lstrip(), True)
    except expat.ExpatError as error:
        raise LaunchError(f"{path}: not well-formed XML: {error}") from None
    return root[0]


def _yaml_entity(tag: str, value: Any, where: str) -> Entity:
    """An element from YAML: ``{tag: {attr: value, ...}}``; a list under an element's key
    is its children (``group: [...]``, ``param: [{name: ..}]``)."""
    if isinstance(value, list):
        children = [_yaml_item(item, f"{where}[{i}]") for i, item in enumerate(value)]
        return Entity(tag, {}, children, where)
    if value is None:
        value = {}
    if not isinstance(value, dict):
        raise LaunchError(f"{where}: <{tag}> must hold attributes (a mapping), not {value!r}")
    attrs: dict[str, Any] = {}
    children: list[Entity] = []
    for key, item in value.items():
        key = str(key)
        if key == "children" and isinstance(item, list):
            children += [_yaml_item(c, f"{where}.children[{i}]") for i, c in enumerate(item)]
        elif isinstance(item, list) and item and all(isinstance(i, dict) for i in item):
            children += [_yaml_entity(key, i, f"{where}.{key}[{n}]") for n, i in enumerate(item)]
        else:
            attrs[key] = item
    return Entity(tag, attrs, children, where)


def _yaml_item(item: Any, where: str) -> Entity:
    if not isinstance(item, dict) or len(item) != 1:
        raise LaunchError(f"{where}: expected one element such as 'node: {{...}}', got {item!r}")
    ((tag, value),) = item.items()
    return _yaml_entity(str(tag), value, f"{where}.{tag}")


def _read_yaml(path: Path, text: str) -> Entity:
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise LaunchError(f"{path}: not valid YAML: {error}".replace("\n", " ")) from None
    if not isinstance(data, dict) or "launch" not in data:
        raise LaunchError(f"{path}: a YAML launch file is a mapping with the key 'launch'")
    return _yaml_entity("launch", data["launch"], f"{path}: launch")


# -- entities into actions ---------------------------------------------------------------------


def _command_line(entity: Entity, name: str, *, optional: bool = True) -> list[Any] | None:
    """A command-line attribute (``cmd``, ``args``) as a list of arguments."""
    subs = entity.subs(name, optional=optional)
    if subs is None:
        return None
    try:
        return _words(subs)
    except ValueError as error:  # shlex: "No closing quotation"
        raise entity.error(f"attribute '{name}': {error} (quotes cannot span a $(...))") from None


def _words(subs: list[Substitution]) -> list[list[Substitution]]:
    """A command line's substitutions split into arguments at the spaces of its text
    (``$(...)`` stay inside the argument they touch), as upstream splits ``cmd``/``args``."""
    words: list[list[Substitution]] = [[]]
    for sub in subs:
        if isinstance(sub, TextSubstitution):
            parts = shlex.split(sub.text) if sub.text.strip() else []
            if sub.text[:1].isspace() and words[-1]:
                words.append([])
            for i, part in enumerate(parts):
                if i > 0:
                    words.append([])
                words[-1].append(TextSubstitution(text=part))
            if sub.text[-1:].isspace() and words[-1]:
                words.append([])
        else:
            words[-1].append(sub)
    return [w for w in words if w]


def _condition(entity: Entity) -> dict[str, Any]:
    when, unless = entity.subs("if"), entity.subs("unless")
    if when is not None and unless is not None:
        raise entity.error("cannot have both 'if' and 'unless'")
    if when is not None:
        return {"condition": IfCondition(when)}
    if unless is not None:
        return {"condition": UnlessCondition(unless)}
    return {}


def _env(entity: Entity) -> dict[str, Any]:
    env = {}
    for element in entity.children_named("env"):
        env[str(element.get("name", optional=False))] = element.subs("value", optional=False)
        element.check_attributes()
    return {"additional_env": env} if env else {}


def _process_options(entity: Entity) -> dict[str, Any]:
    """What ``<executable>`` and ``<node>`` share: output, respawn, launch-prefix, env."""
    kwargs: dict[str, Any] = {**_condition(entity), **_env(entity)}
    output = entity.get("output")
    if output is not None:
        kwargs["output"] = str(output)
    kwargs["respawn"] = entity.flag("respawn", False)
    delay = entity.number("respawn_delay")
    if delay is not None:
        kwargs["respawn_delay"] = delay
    prefix = entity.subs("launch-prefix")
    if prefix is not None:
        kwargs["prefix"] = prefix
    for name in ("sigterm_timeout", "sigkill_timeout"):
        value = entity.number(name)
        if value is not None:
            kwargs[name] = value
    return kwargs


def _parameters(entity: Entity, prefix: list[Substitution]) -> list[Any]:
    found: list[Any] = []
    for param in entity.children_named("param"):
        source = param.subs("from")
        name = param.subs("name")
        if source is not None:
            if name is not None:
                raise param.error("cannot have both 'name' and 'from'")
            found.append(ParameterFile(source, allow_substs=param.flag("allow_substs", False)))
        elif name is None:
            raise param.error("needs the attribute 'name' (or 'from', a parameter file)")
        else:
            full = [*prefix, TextSubstitution(text="."), *name] if prefix else name
            nested = param.children_named("param")
            value = param.get("value")
            if nested and value is not None:
                raise param.error("cannot have both 'value' and nested <param> elements")
            if nested:
                found += _parameters(param, full)
            elif value is None:
                raise param.error("needs the attribute 'value' (or nested <param> elements)")
            elif isinstance(value, (list, bool, int, float)):  # a YAML literal
                found.append(Parameter(full, value))
            else:
                sep = param.get("value-sep")
                if sep is not None:
                    found.append(Parameter(full, str(value).split(str(sep))))
                else:
                    found.append(Parameter(full, param.subs("value")))
            param.get("type")
        param.check_attributes()
    return found


def _node(entity: Entity, reader: Reader) -> Any:
    kwargs = _process_options(entity)
    kwargs["executable"] = entity.subs("exec", optional=False)
    for attr, key in (
        ("pkg", "package"),
        ("name", "name"),
        ("namespace", "namespace"),
        ("exec_name", "exec_name"),
    ):
        value = entity.subs(attr)
        if value is not None:
            kwargs[key] = value
    for attr, key in (("args", "arguments"), ("ros_args", "ros_arguments")):
        value = _command_line(entity, attr)
        if value is not None:
            kwargs[key] = value
    remaps = []
    for remap in entity.children_named("remap"):
        remaps.append((remap.subs("from", optional=False), remap.subs("to", optional=False)))
        remap.check_attributes()
    if remaps:
        kwargs["remappings"] = remaps
    parameters = _parameters(entity, [])
    if parameters:
        kwargs["parameters"] = parameters
    return launcher.Node(**kwargs)


def _executable(entity: Entity, reader: Reader) -> Any:
    kwargs = _process_options(entity)
    kwargs["cmd"] = [
        *(_command_line(entity, "cmd", optional=False) or []),
        *(_command_line(entity, "args") or []),
    ]
    for attr in ("cwd", "name"):
        value = entity.subs(attr)
        if value is not None:
            kwargs[attr] = value
    kwargs["shell"] = bool(entity.flag("shell", False))
    return launcher.ExecuteProcess(**kwargs)


def _include(entity: Entity, reader: Reader) -> Any:
    arguments = []
    for arg in entity.children_named("arg"):
        arguments.append((arg.subs("name", optional=False), arg.subs("value", optional=False)))
        arg.check_attributes()
    return launcher.IncludeLaunchDescription(
        launcher.AnyLaunchDescriptionSource(entity.subs("file", optional=False)),
        launch_arguments=arguments,
        **_condition(entity),
    )


def _arg(entity: Entity, reader: Reader) -> Any:
    choices = [c.get("value", optional=False) for c in entity.children_named("choice")]
    for choice in entity.children_named("choice"):
        choice.check_attributes()
    description = entity.get("description")
    return launcher.DeclareLaunchArgument(
        str(entity.get("name", optional=False)),
        default_value=entity.subs("default"),
        description=None if description is None else str(description),
        choices=[str(c) for c in choices] or None,
        **_condition(entity),
    )


def _group(entity: Entity, reader: Reader) -> Any:
    scoped = entity.flag("scoped", True)
    forwarding = entity.flag("forwarding", True)
    if not isinstance(scoped, bool) or not isinstance(forwarding, bool):
        raise entity.error("'scoped' and 'forwarding' must be true or false")
    kept = {}  # <keep name=.. value=..>: configurations a non-forwarding group starts with
    for keep in entity.children_named("keep"):
        kept[str(keep.get("name", optional=False))] = keep.subs("value", optional=False)
        keep.check_attributes()
    actions = reader.actions([c for c in entity.children if c.type_name != "keep"])
    entity._read.update(c.type_name for c in entity.children)
    return launcher.GroupAction(
        actions,
        scoped=scoped,
        forwarding=forwarding,
        launch_configurations=kept or None,
        **_condition(entity),
    )


def _timer(entity: Entity, reader: Reader) -> Any:
    period = entity.number("period")
    if period is None:
        raise entity.error("needs the attribute 'period'")
    entity._read.update(c.type_name for c in entity.children)
    return launcher.TimerAction(
        period=period, actions=reader.actions(entity.children), **_condition(entity)
    )


def _simple(
    build: Callable[..., Any], *attrs: str, optional: tuple[str, ...] = ()
) -> Callable[[Entity, Reader], Any]:
    """An element whose attributes are the action's arguments, in order."""

    def make(entity: Entity, reader: Reader) -> Any:
        args = [entity.subs(a, optional=False) for a in attrs]
        extra = {k: entity.subs(k) for k in optional if entity.get(k) is not None}
        return build(*args, **extra, **_condition(entity))

    return make


def _log(entity: Entity, reader: Reader) -> Any:
    return launcher.LogInfo(msg=entity.subs("message", optional=False), **_condition(entity))


def _shutdown(entity: Entity, reader: Reader) -> Any:
    reason = entity.subs("reason")
    return launcher.Shutdown(
        **({"reason": reason} if reason is not None else {}), **_condition(entity)
    )


#: The elements of a launch file and how each becomes an action, as upstream spells them
#: (both the dashed and the underscored spellings upstream accepts).
ELEMENTS: dict[str, Callable[[Entity, Reader], Any]] = {
    "arg": _arg,
    "let": _simple(launcher.SetLaunchConfiguration, "name", "value"),
    "node": _node,
    "executable": _executable,
    "include": _include,
    "group": _group,
    "timer": _timer,
    "log": _log,
    "shutdown": _shutdown,
    "push-ros-namespace": _simple(launcher.PushROSNamespace, "namespace"),
    "set-env": _simple(launcher.SetEnvironmentVariable, "name", "value"),
    "unset-env": _simple(launcher.UnsetEnvironmentVariable, "name"),
    "append-env": _simple(
        launcher.AppendEnvironmentVariable, "name", "value", optional=("prepend", "separator")
    ),
    "set-parameter": _simple(launcher.SetParameter, "name", "value"),
    "set-parameters-from-file": _simple(launcher.SetParametersFromFile, "filename"),
    "set-remap": _simple(launcher.SetRemap, "from", "to"),
    "set-use-sim-time": _simple(launcher.SetUseSimTime, "value"),
}
ELEMENTS.update({tag.replace("-", "_"): make for tag, make in list(ELEMENTS.items())})


class Reader:
    """Turns a launch file's entities into actions."""

    def actions(self, entities: list[Entity]) -> list[Any]:
        found = []
        for entity in entities:
            make = ELEMENTS.get(entity.type_name)
            if make is None:
                known = ", ".join(sorted(t for t in ELEMENTS if "_" not in t))
                raise entity.error(f"is not a launch element (known: {known})")
            action = make(entity, self)
            entity.check_attributes()
            found.append(action)
        return found


def load_frontend_launch_file(path: Path, kind: str | None = None) -> Any:
    """The ``LaunchDescription`` of an XML or YAML launch file (``kind`` 'xml' or 'yaml';
    None: told by its extension)."""
    kind = kind or FORMATS.get(path.suffix)
    if kind is None:
        raise LaunchError(f"{path}: not an XML or YAML launch file (.xml, .yaml)")
    try:
        text = path.read_text()
    except OSError as error:
        raise LaunchError(f"no launch file '{path}' ({error.strerror})") from None
    root = (_read_xml if kind == "xml" else _read_yaml)(path, text)
    if root.type_name != "launch":
        raise root.error("is not <launch>: a launch file's root element is <launch>")
    root.get("version")
    actions = Reader().actions(root.children)
    root._read.update(c.type_name for c in root.children)
    root.check_attributes()
    return launcher.LaunchDescription(actions)


class Parser:
    """Reads XML and YAML launch files (``launch.frontend.Parser``)."""

    @staticmethod
    def parse_substitution(value: str) -> list[Substitution]:
        return parse_substitution(value)

    @classmethod
    def get_file_extensions_from_parsers(cls) -> set[str]:
        return {suffix.lstrip(".") for suffix in FORMATS}

    @classmethod
    def load(cls, file: str | Path) -> Entity:
        """The root element of a launch file."""
        path = Path(file)
        kind = FORMATS.get(path.suffix)
        if kind is None:
            raise LaunchError(f"{path}: not an XML or YAML launch file (.xml, .yaml)")
        return (_read_xml if kind == "xml" else _read_yaml)(path, path.read_text())

    def parse_description(self, entity: Entity) -> Any:
        """The ``LaunchDescription`` of a root element."""
        actions = Reader().actions(entity.children)
        return launcher.LaunchDescription(actions)
