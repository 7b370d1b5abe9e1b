"""Another node's parameters, from outside: list, get and set over its parameter services.

Every rclpy node serves ``<node>/list_parameters``, ``get_parameters`` and
``set_parameters`` (``rcl_interfaces/srv/...``). These functions call them with the
bounded calls of ``rosbook.runtime.services``, as ``ros2 param`` does.
"""

from __future__ import annotations

from typing import Any

from rcl_interfaces.msg import ParameterType, SetParametersResult
from rcl_interfaces.srv import DescribeParameters, GetParameters, ListParameters, SetParameters
from rclpy.node import Node
from rclpy.parameter import Parameter, get_parameter_value, parameter_value_to_python

from rosbook.runtime.services import ServiceCallError, call


class ParameterError(RuntimeError):
    """A parameter that is not declared, or a value the node refused."""


def _service(target: str, name: str) -> str:
    return "/" + target.strip("/") + "/" + name


def list_parameters(
    node: Node, target: str, timeout: float = 2.0, prefixes: list[str] | None = None
) -> list[str]:
    """The names of ``target``'s parameters, sorted (only those under ``prefixes``, when
    given, as the node's ``list_parameters`` service reads them)."""
    request = ListParameters.Request(prefixes=list(prefixes or []))
    response = call(
        node, ListParameters, _service(target, "list_parameters"), request, timeout=timeout
    )
    return sorted(response.result.names)


def parameter_value(node: Node, target: str, name: str, timeout: float = 2.0) -> Any:
    """``target``'s answer for parameter ``name``: an ``rcl_interfaces/msg/ParameterValue``
    (of type ``PARAMETER_NOT_SET`` for a declared parameter without a value), or None
    when the node has no such parameter."""
    request = GetParameters.Request(names=[name])
    response = call(
        node, GetParameters, _service(target, "get_parameters"), request, timeout=timeout
    )
    return response.values[0] if response.values else None


def get_parameter(node: Node, target: str, name: str, timeout: float = 2.0) -> Any:
    """The value of ``target``'s parameter ``name`` as a Python value.

    Raises ``ParameterError`` when the node has no such parameter.
    """
    value = parameter_value(node, target, name, timeout)
    if value is None or value.type == ParameterType.PARAMETER_NOT_SET:
        raise ParameterError(f"node '{target}' has no parameter '{name}' (is it declared?)")
    return parameter_value_to_python(value)


def describe_parameters(
    node: Node, target: str, names: list[str], timeout: float = 2.0
) -> list[Any]:
    """``target``'s ``rcl_interfaces/msg/ParameterDescriptor`` of each of ``names``."""
    request = DescribeParameters.Request(names=names)
    service = _service(target, "describe_parameters")
    return list(call(node, DescribeParameters, service, request, timeout=timeout).descriptors)


def set_parameter(
    node: Node, target: str, name: str, value: Any, timeout: float = 2.0
) -> SetParametersResult:
    """Ask ``target`` to set ``name`` to ``value``; its answer (``successful``, ``reason``).

    A string ``value`` is read as YAML like ``ros2 param set`` does (``'5.0'`` is a double).
    """
    if isinstance(value, str):
        msg = Parameter(name).to_parameter_msg()
        msg.value = get_parameter_value(value)
    else:
        msg = Parameter(name, value=value).to_parameter_msg()
    request = SetParameters.Request(parameters=[msg])
    response = call(
        node, SetParameters, _service(target, "set_parameters"), request, timeout=timeout
    )
    if not response.results:
        raise ServiceCallError(f"node '{target}' answered set_parameters with no result")
    return response.results[0]
