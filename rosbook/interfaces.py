"""Interface types by name, requests from YAML-ish text, and ``.srv``/``.action`` sources.

The ``ros2`` CLI names types as ``package/kind/Name`` (``std_srvs/srv/Trigger``) and
fills requests from YAML (``"{data: true}"``); the book, the checks and this project's
CLI share these conversions.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path
from typing import Any

import yaml

KINDS = ("msg", "srv", "action")


class InterfaceError(ValueError):
    """An interface name that does not name an installed type, or a bad field value."""


def interface_name(interface: type) -> str:
    """``std_srvs/srv/Trigger`` for ``std_srvs.srv.Trigger`` (any msg, srv or action)."""
    parts = interface.__module__.split(".")
    return f"{parts[0]}/{parts[1]}/{interface.__name__}"


def import_interface(name: str) -> type:
    """The Python class of ``package/kind/Name``; ``InterfaceError`` saying why if none."""
    parts = name.strip("/").split("/")
    if len(parts) != 3 or parts[1] not in KINDS:
        raise InterfaceError(f"'{name}' is not an interface name like 'std_srvs/srv/Trigger'")
    package, kind, type_name = parts
    try:
        module = importlib.import_module(f"{package}.{kind}")
    except ImportError:
        raise InterfaceError(
            f"unknown interface '{name}': no package '{package}' with {kind} types"
        ) from None
    try:
        return getattr(module, type_name)
    except AttributeError:
        raise InterfaceError(
            f"unknown interface '{name}': '{package}' has no {kind} '{type_name}'"
        ) from None


def definition(name: str) -> str:
    """The ``.msg``/``.srv``/``.action`` source of ``name``, as shipped in the package."""
    import_interface(name)  # a clear error for unknown names
    package, kind, type_name = name.strip("/").split("/")
    path = Path(sys.prefix) / "share" / package / kind / f"{type_name}.{kind}"
    if path.is_file():
        return path.read_text()
    raise InterfaceError(f"the package '{package}' ships no {kind}/{type_name}.{kind} file")


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
