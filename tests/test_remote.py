"""What crosses from the student's kernel to the judge is plain data the judge decodes
itself: a value built to pass a comparison, or to run code when decoded, arrives as a
description that equals nothing. The agent's side (``rosbook.labs.agent``) encodes, the
judge's side (``rosbook.labs.remote``) decodes; both run here without a kernel, as the
judge would meet them (the answer goes through JSON)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
from rclpy.parameter import Parameter

from rosbook.labs.agent import argument, data, describe
from rosbook.labs.remote import Unreadable, decode, encode


class AlwaysEqual(int):
    """An int whose comparisons always say yes."""

    def __eq__(self, other: object) -> bool:
        return True

    __hash__ = int.__hash__


class Greeter:
    def greeting(self) -> str:
        return "hi"


def crossed(value: Any) -> Any:
    """``value`` as the judge gets it: the agent's data, through JSON, decoded."""
    return decode(json.loads(json.dumps(data(value))))


def test_plain_values_cross_as_they_are() -> None:
    value = {"ranges": [1.5, 2, None], "name": "scan", "ok": True, "pair": (3, "x")}
    assert crossed(value) == value
    assert type(crossed([1, 2])) is list and type(crossed((1, 2))) is tuple
    assert crossed(2**40) == 2**40 and type(crossed(2**40)) is int


def test_a_value_that_always_compares_equal_arrives_as_a_description() -> None:
    got = crossed(AlwaysEqual(3))
    assert isinstance(got, Unreadable) and got != 3 and got != AlwaysEqual(3)
    assert "AlwaysEqual" in repr(got)
    inside = crossed([1, AlwaysEqual(2)])
    assert inside[0] == 1 and isinstance(inside[1], Unreadable) and inside != [1, 2]


def test_an_object_arrives_as_a_description_never_as_itself() -> None:
    got = crossed(Greeter())
    assert isinstance(got, Unreadable) and not hasattr(got, "greeting")
    assert describe(Greeter()) == {"kind": "object"}
    assert describe(Greeter) == {"kind": "class"}
    assert describe(len) == {"kind": "function"}
    assert describe([1, 2]) == {"kind": "value", "plain": data([1, 2])}


def test_a_forged_answer_decodes_to_nothing_it_could_run() -> None:
    forged = {"type": "int", "value": {"__class__": "os.system", "args": ["true"]}}
    assert decode(forged) is None
    assert decode({"type": "list", "list": [forged]}) == [None]


def test_numpy_numbers_cross_as_numbers() -> None:
    assert crossed(np.float64(0.5)) == 0.5 and crossed(np.arange(3)) == [0, 1, 2]
    assert encode(np.float64(0.25)) == 0.25 and encode([np.int64(2)]) == [2]


def test_a_parameter_reaches_the_students_code_as_a_parameter() -> None:
    sent = json.loads(json.dumps(encode([Parameter("name", value="hidden ROS")])))
    (rebuilt,) = argument(sent)
    assert isinstance(rebuilt, Parameter)
    assert (rebuilt.name, rebuilt.value) == ("name", "hidden ROS")
