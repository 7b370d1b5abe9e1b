"""The earlier flat module names still import for this term, as the modules they became."""

from __future__ import annotations

import importlib
import sys

import pytest

import rosbook
from rosbook.labs import lab01, probes


@pytest.mark.parametrize("old", sorted(rosbook.OLD_NAMES))
def test_an_earlier_module_name_imports_the_module_it_became(old: str) -> None:
    sys.modules.pop(f"rosbook.{old}", None)
    with pytest.warns(DeprecationWarning, match=f"rosbook.{old} is now"):
        module = importlib.import_module(f"rosbook.{old}")
    assert module is importlib.import_module(rosbook.OLD_NAMES[old])


def test_lab_one_checks_reach_the_shared_probes_too() -> None:
    assert lab01.Probe is probes.Probe and lab01.assert_sequence is probes.assert_sequence
    assert lab01.assert_hello_world.__module__ == "rosbook.labs.lab01"


def test_packages_named_like_an_earlier_module_still_give_its_names() -> None:
    from rosbook.launch import LaunchDescription, Node
    from rosbook.sim import World
    from rosbook.viz import SCENE_CLASS

    assert LaunchDescription.__module__ == "rosbook.launch.launcher" and Node
    assert World.__module__ == "rosbook.sim.physics" and SCENE_CLASS
