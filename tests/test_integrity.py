"""autograder.integrity: student cells that reach into the grading code are named."""

from __future__ import annotations

import nbformat
import pytest

from autograder.config import lab_ids
from autograder.integrity import findings, grading_code_changes
from tests.labtools import notebook_path

PROTECTED = {"checks", "ros"}


@pytest.mark.parametrize("lab", lab_ids())
def test_no_solution_and_no_release_is_flagged(lab: str) -> None:
    released = nbformat.read(notebook_path(lab), as_version=4)
    solution = nbformat.read(notebook_path(lab, released=False), as_version=4)
    assert grading_code_changes(solution, released) == []
    assert grading_code_changes(released, released) == []


@pytest.mark.parametrize(
    ("source", "what"),
    [
        ("checks.assert_sequence = lambda *a, **k: None", "changes checks.assert_sequence"),
        (
            "import rosbook.labs.probes as c\nc.expect_published = print",
            "changes c.expect_published",
        ),
        ("from rosbook import qos_checks\nqos_checks.x = 1", "changes qos_checks.x"),
        ("setattr(checks, 'make_node', print)", "calls setattr() on checks"),
        ("object.__setattr__(checks, 'a', 1)", "calls __setattr__() on checks"),
        ("vars(checks)['Probe'] = None", "changes vars(checks)['Probe']"),
        ("globals()['checks'] = None", "changes globals()['checks']"),
        ("checks.__dict__.update(Probe=None)", "uses checks.__dict__"),
        ("import sys\nsys.modules['rosbook.labs.probes'] = None", "uses sys.modules"),
        ("checks = FakeChecks()", "rebinds checks"),
        ("from my_fakes import checks", "rebinds checks by an import"),
        ("from launch_ros import actions as checks", "rebinds checks by an import"),
        ("from . import checks", "rebinds checks by an import"),
        ("def ros():\n    pass", "rebinds ros"),
        ("del checks.Probe", "changes checks.Probe"),
        ("a, checks.b = 1, 2", "changes checks.b"),
        ("import builtins\nbuiltins.AssertionError = Exception", "changes builtins.AssertionError"),
        ("exec(open('x.py').read())", "calls exec()"),
        ("def f():\n    checks.x = 1", "changes checks.x"),
    ],
)
def test_ways_into_the_grading_code_are_found(source: str, what: str) -> None:
    assert what in [w for _, w in findings(source, PROTECTED)]


@pytest.mark.parametrize(
    "source",
    [
        "node = checks.make_node(Talker)",
        "ros.spin_for(1.0)",
        "setattr(self, 'count', 0)",
        "super().__init__('talker')",
        "self.__class__.__name__",
        "import os\nprint(os.getcwd())",
        "this is not python (",
    ],
)
def test_ordinary_code_is_not_flagged(source: str) -> None:
    assert findings(source, PROTECTED) == []


def test_imports_copied_from_ros_tutorials_are_not_flagged_in_lab6() -> None:
    """lab 6's locked cells import LaunchDescription and Node from launch and launch_ros; a
    student who writes the upstream imports of a ROS tutorial again is not tampering."""
    lab = "lab06_launch_system"
    released = nbformat.read(notebook_path(lab), as_version=4)
    submitted = nbformat.read(notebook_path(lab), as_version=4)
    submitted.cells.insert(
        2,
        nbformat.v4.new_code_cell(
            "from launch import LaunchDescription\nfrom launch_ros.actions import Node\n"
            "import launch\nfrom rclpy.node import Node"
        ),
    )
    assert grading_code_changes(submitted, released) == []


def test_a_flag_names_the_cell_line_and_code() -> None:
    released = nbformat.read(notebook_path("lab01_nodes_topics"), as_version=4)
    submitted = nbformat.read(notebook_path("lab01_nodes_topics"), as_version=4)
    submitted.cells.insert(2, nbformat.v4.new_code_cell("x = 1\nchecks.Probe = None"))
    assert grading_code_changes(submitted, released) == [
        "cell 3, line 2: changes checks.Probe (checks.Probe = None)"
    ]
