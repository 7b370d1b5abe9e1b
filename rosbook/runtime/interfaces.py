"""Message, service and action definitions: what ``ros2 interface show`` prints.

The ROS 2 wheels install each interface package's definitions next to the venv, in
``<prefix>/share/<package>/msg/*.msg`` (and ``srv``, ``action``), listed by the ament
resource index in ``<prefix>/share/ament_index/resource_index/rosidl_interfaces/``.
This module reads those files, imports the generated Python classes, turns a message
into the YAML text ``ros2 topic echo`` prints, and fills a request from the YAML-ish
text ``ros2 service call`` takes (``"{data: true}"``).
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import yaml

#: IDL primitive types a ``.msg`` field may have (everything else is a message type).
PRIMITIVES = frozenset(
    "bool byte char float32 float64 int8 uint8 int16 uint16 int32 uint32 int64 uint64 "
    "string wstring".split()
)

_KINDS = ("msg", "srv", "action")


class InterfaceError(LookupError, ValueError):
    """A malformed or not installed interface name, or a bad field value (one line)."""


def split_type(type_name: str) -> tuple[str, str, str]:
    """``('geometry_msgs', 'msg', 'Pose')`` for ``geometry_msgs/msg/Pose``."""
    parts = type_name.strip("/").split("/")
    if len(parts) != 3 or parts[1] not in _KINDS or not all(parts):
        raise InterfaceError(
            f"'{type_name}' is not an interface name: expected PACKAGE/msg|srv|action/NAME, "
            "e.g. std_msgs/msg/String"
        )
    return parts[0], parts[1], parts[2]


def prefixes() -> list[Path]:
    """Install prefixes that may hold interface packages (AMENT_PREFIX_PATH, then the venv)."""
    found = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    found.append(Path(sys.prefix))
    return list(dict.fromkeys(found))


def _index(package: str) -> tuple[Path, list[str]] | None:
    """The prefix of ``package`` and its resource-index entries (``msg/Pose.msg`` ...)."""
    for prefix in prefixes():
        entry = prefix / "share/ament_index/resource_index/rosidl_interfaces" / package
        if entry.is_file():
            return prefix, entry.read_text().split()
    return None


def package_prefix(package: str) -> Path | None:
    """The install prefix that holds interface package ``package``, or None."""
    found = _index(package)
    return None if found is None else found[0]


def packages() -> list[str]:
    """Every installed interface package, sorted."""
    names: set[str] = set()
    for prefix in prefixes():
        index = prefix / "share/ament_index/resource_index/rosidl_interfaces"
        if index.is_dir():
            names.update(p.name for p in index.iterdir())
    return sorted(names)


def interfaces(package: str) -> list[str]:
    """The interfaces of ``package``, as ``package/msg/Name`` strings, sorted."""
    found = _index(package)
    if found is None:
        raise InterfaceError(f"unknown interface package '{package}'")
    _, entries = found
    return sorted(
        f"{package}/{entry.rsplit('.', 1)[0]}"
        for entry in entries
        if entry.rsplit(".", 1)[-1] in _KINDS
    )


def definition_path(type_name: str) -> Path:
    """The installed ``.msg``/``.srv``/``.action`` file that defines ``type_name``."""
    package, kind, name = split_type(type_name)
    found = _index(package)
    if found is None:
        raise InterfaceError(f"unknown interface package '{package}' (in '{type_name}')")
    prefix, entries = found
    if f"{kind}/{name}.{kind}" not in entries:
        raise InterfaceError(
            f"unknown interface '{type_name}': package {package} has no {kind} {name}"
        )
    return prefix / "share" / package / kind / f"{name}.{kind}"


def definition(type_name: str) -> str:
    """The text of the definition file of ``type_name``, as its authors wrote it."""
    return definition_path(type_name).read_text()


def show(type_name: str, *, comments: bool = True, nested_comments: bool = False) -> str:
    """What ``ros2 interface show TYPE`` prints: the definition, nested types expanded.

    Each field whose type is itself a message is followed by that message's fields,
    indented by a tab. As upstream, the definition keeps its comments and blank lines
    unless ``comments`` is false (``--no-comments``); nested ones lose theirs unless
    ``nested_comments`` (``--all-comments``).
    """
    package, _, _ = split_type(type_name)
    lines = list(_expand(definition(type_name), package, 0, comments, nested_comments))
    return "\n".join(lines).rstrip("\n")


_FIELD = re.compile(r"^\s*([A-Za-z][\w/]*)(?:<=\d+)?(\[[^\]]*\])?\s+([A-Za-z]\w*)(\s|=|$)")


def _expand(
    text: str, package: str, depth: int, comments: bool, nested_comments: bool
) -> Iterator[str]:
    indent = "\t" * depth
    for raw in text.splitlines():
        line = raw.rstrip()
        if not comments:
            line = _strip_comment(line)
            if not line.strip():
                continue
        yield indent + line if line else ""
        match = _FIELD.match(line)
        if not match or line.lstrip().startswith("#"):
            continue
        field_type = match.group(1)
        if field_type in PRIMITIVES:  # constants are always primitive
            continue
        nested = _nested_type(field_type, package)
        if nested is None:
            continue
        nested_package = nested.split("/", 1)[0]
        yield from _expand(
            definition(nested), nested_package, depth + 1, nested_comments, nested_comments
        )


def _strip_comment(line: str) -> str:
    if line.lstrip().startswith("#"):
        return ""
    if "#" not in line or "'" in line or '"' in line:
        return line
    return line.split("#", 1)[0].rstrip()


def _nested_type(field_type: str, package: str) -> str | None:
    """``geometry_msgs/msg/Point`` for the field type ``Point`` in geometry_msgs."""
    if "/" in field_type:
        pkg, name = field_type.split("/", 1)
        name = name.removeprefix("msg/")
    elif field_type == "Header":
        pkg, name = "std_msgs", "Header"
    else:
        pkg, name = package, field_type
    full = f"{pkg}/msg/{name}"
    try:
        definition_path(full)
    except InterfaceError:
        return None
    return full


def message_class(type_name: str) -> type:
    """The generated Python class of ``type_name`` (a msg, srv or action type)."""
    package, kind, name = split_type(type_name)
    try:
        module = importlib.import_module(f"{package}.{kind}")
    except ImportError:
        raise InterfaceError(
            f"unknown interface '{type_name}': no package '{package}' with {kind} types"
        ) from None
    try:
        return getattr(module, name)  # type: ignore[no-any-return]
    except AttributeError:
        raise InterfaceError(
            f"unknown interface '{type_name}': '{package}' has no {kind} '{name}'"
        ) from None


def interface_name(interface: type) -> str:
    """``std_srvs/srv/Trigger`` for ``std_srvs.srv.Trigger`` (any msg, srv or action)."""
    parts = interface.__module__.split(".")
    return f"{parts[0]}/{parts[1]}/{interface.__name__}"


def fields(type_name: str) -> dict[str, str]:
    """Field names and their types, from the generated class (rosidl runtime)."""
    return dict(message_class(type_name).get_fields_and_field_types())


def to_plain(
    msg: Any,
    *,
    truncate_length: int | None = None,
    no_arr: bool = False,
    no_str: bool = False,
    _slot: Any = None,
) -> Any:
    """``msg`` as nested dicts, lists and scalars, in field order.

    A ``byte`` (``bytes`` in Python) becomes the text of its characters, as upstream's
    ``rosidl_runtime_py.message_to_yaml`` writes it: ``byte_value: '2'``, not binary.
    As there, ``truncate_length`` cuts longer strings and sequences (``...`` marks the
    cut), ``no_arr`` shows an array field as its type and length, ``no_str`` a string
    field as its length.
    """
    options = {"truncate_length": truncate_length, "no_arr": no_arr, "no_str": no_str}
    cut = truncate_length
    if isinstance(msg, bytes):
        text = "".join(chr(c) for c in msg[:cut])
        return text + "..." if cut is not None and len(msg) > cut else text
    if isinstance(msg, str):
        if no_str:
            return f"<string length: <{len(msg)}>>"
        return msg[:cut] + "..." if cut is not None and len(msg) > cut else msg
    if hasattr(msg, "get_fields_and_field_types"):
        return {
            name: to_plain(getattr(msg, name), _slot=slot, **options)
            for name, slot in zip(msg.get_fields_and_field_types(), msg.SLOT_TYPES)
        }
    if isinstance(msg, (list, tuple)) or type(msg).__name__ in ("ndarray", "array"):
        if no_arr and _slot is not None:
            return _array_summary(msg, _slot)
        items = [to_plain(item, **options) for item in msg[:cut]]
        return items + ["..."] if cut is not None and len(msg) > cut else items
    if hasattr(msg, "item"):  # numpy scalar
        return msg.item()
    return msg


def _type_label(value_type: Any) -> str:
    """An element type's name as ``--no-arr`` shows it (``int32``, ``string``, ``pkg/msg/T``)."""
    from rosidl_parser import definition as d

    if isinstance(value_type, d.BasicType):
        return str(value_type.typename)
    if isinstance(value_type, d.AbstractWString):
        return "wstring"
    if isinstance(value_type, d.AbstractString):
        return "string"
    if isinstance(value_type, d.NamespacedType):
        return "/".join(value_type.namespaced_name())
    if isinstance(value_type, d.NamedType):
        return str(value_type.name)
    return "unknown"


def _array_summary(value: Any, slot: Any) -> str:
    """What ``--no-arr`` prints for an array or sequence field (upstream's wording)."""
    from rosidl_parser import definition as d

    label = _type_label(slot.value_type)
    if isinstance(slot, d.Array):
        return f"<array type: {label}[{slot.size}]>"
    if isinstance(slot, d.BoundedSequence):
        return f"<sequence type: {label}[{slot.maximum_size}], length: {len(value)}>"
    if isinstance(slot, d.UnboundedSequence):
        return f"<sequence type: {label}, length: {len(value)}>"
    return "unknown"


def to_yaml(msg: Any, *, flow_style: bool = False, **options: Any) -> str:
    """``msg`` as the YAML block ``ros2 topic echo`` prints (without the ``---``);
    ``options``: ``to_plain``'s."""
    text: str = yaml.safe_dump(
        to_plain(msg, **options),
        default_flow_style=flow_style,
        sort_keys=False,
        allow_unicode=True,
        width=sys.maxsize,
    )
    return text.rstrip("\n")


def to_csv(
    msg: Any, *, truncate_length: int | None = None, no_arr: bool = False, no_str: bool = False
) -> str:
    """``msg`` as the one line ``ros2 topic echo --csv`` prints: every leaf value in
    field order, comma-separated (upstream's ``message_to_csv``)."""
    options = {"truncate_length": truncate_length, "no_arr": no_arr, "no_str": no_str}
    cut = truncate_length

    def text(value: Any, slot: Any = None) -> str:
        if isinstance(value, (list, tuple)) or type(value).__name__ in ("ndarray", "array"):
            if no_arr and slot is not None:
                return _array_summary(value, slot)
            items = [text(item) for item in value[:cut]]
            return ",".join(items + (["..."] if cut is not None and len(value) > cut else []))
        if isinstance(value, str) and no_str:
            return f"<string length: <{len(value)}>>"
        if isinstance(value, (str, bytes)) and cut is not None and len(value) > cut:
            value = value[:cut] + ("..." if isinstance(value, str) else b"...")
        if hasattr(value, "get_fields_and_field_types"):
            return to_csv(value, **options)
        return str(value)

    return ",".join(
        text(getattr(msg, name), slot)
        for name, slot in zip(msg.get_fields_and_field_types(), msg.SLOT_TYPES)
    )


def fill(message: Any, values: dict[str, Any] | None) -> Any:
    """Set ``message``'s fields from a dict (nested dicts for nested messages); returns it."""
    for field, value in (values or {}).items():
        if not hasattr(message, field) or field.startswith("_"):
            fields = ", ".join(message.get_fields_and_field_types()) or "none"
            raise InterfaceError(
                f"{type(message).__name__} has no field '{field}' (its fields: {fields})"
            )
        current = getattr(message, field)
        if isinstance(value, dict) and hasattr(current, "get_fields_and_field_types"):
            fill(current, value)
            continue
        value = _checked(field, current, value)
        try:
            setattr(message, field, value)
        except (TypeError, ValueError, AssertionError) as exc:
            raise InterfaceError(f"field '{field}' cannot be {value!r}: {exc}") from None
    return message


def _checked(field: str, current: Any, value: Any) -> Any:
    """``value`` fit for a field now holding ``current`` (an int is a fine float)."""
    kinds = {bool: "a bool", int: "an integer", float: "a number", str: "a string"}
    kind = type(current)
    if kind not in kinds:
        return value
    fits = (
        isinstance(value, bool)
        if kind is bool
        else not isinstance(value, bool)
        and isinstance(value, (int, float) if kind is float else kind)
    )
    if not fits:
        raise InterfaceError(f"field '{field}' cannot be {value!r}: it takes {kinds[kind]}")
    return float(value) if kind is float else value


def from_yaml(interface: type, text: str | None) -> Any:
    """An instance of ``interface`` (a message class) filled from YAML-ish ``text``."""
    try:
        values = yaml.safe_load(text) if text else {}
    except yaml.YAMLError as exc:
        raise InterfaceError(f"cannot read {text!r} as YAML: {exc}") from None
    if values is not None and not isinstance(values, dict):
        raise InterfaceError(f"{text!r} is not a mapping like '{{field: value}}'")
    return fill(interface(), values)
