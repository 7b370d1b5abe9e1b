"""The package's layout: the layered modules, and the names packages still give."""

from __future__ import annotations

import importlib

import pytest

from rosbook.labs import lab01, probes


@pytest.mark.parametrize("old", ["checks", "session", "sim_node", "qos_checks"])
def test_the_flat_module_names_of_an_earlier_term_are_gone(old: str) -> None:
    """``rosbook.checks`` & co. were the names of an earlier term; only the layered
    modules import now (``rosbook.labs.lab01``, ``rosbook.runtime.session``, ...)."""
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(f"rosbook.{old}")


def test_lab_one_checks_reach_the_shared_probes_too() -> None:
    assert lab01.Probe is probes.Probe and lab01.assert_sequence is probes.assert_sequence
    assert lab01.assert_hello_world.__module__ == "rosbook.labs.lab01"


def test_packages_named_like_an_earlier_module_still_give_its_names() -> None:
    from rosbook.launch import LaunchDescription, Node
    from rosbook.sim import World
    from rosbook.viz import SCENE_CLASS

    assert LaunchDescription.__module__ == "rosbook.launch.launcher" and Node
    assert World.__module__ == "rosbook.sim.physics" and SCENE_CLASS
