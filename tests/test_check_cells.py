"""Check cells in a real IPython kernel: they leave the kernel as they found it, and a
failing check shows its message first, without the library's frames."""

from __future__ import annotations

from pathlib import Path

import nbformat
import pytest

from autograder.check import run_notebook
from tests.labtools import answered, assert_counted_from_zero, grade_id, replace_in_answer

#: A lab notebook's kernel and its check cells: out of `make test-fast` (test_lab01 keeps
#: one round trip).
pytestmark = pytest.mark.slow

LAB = "lab01_nodes_topics"

STATE = "print('sim_time', ros.sim_time, 'nodes', sorted(n.get_name() for n in ros.nodes))"


def _cell(notebook: nbformat.NotebookNode, gid: str) -> int:
    return next(i for i, c in enumerate(notebook.cells) if grade_id(c) == gid)


def _text(cell: nbformat.NotebookNode) -> str:
    return "".join(o.get("text", "") for o in cell.outputs if o.output_type == "stream")


@pytest.fixture(scope="module")
def after_a_check(tmp_path_factory: pytest.TempPathFactory) -> nbformat.NotebookNode:
    """Lab 1 answered, run as a student would: try it, check, try it again."""
    notebook = answered(LAB)
    try_it = next(c for c in notebook.cells if "ros.spin_for(1.6)" in c.source)
    at = _cell(notebook, "test_counter_publisher") + 1
    again = [nbformat.v4.new_code_cell(STATE), nbformat.v4.new_code_cell(try_it.source)]
    notebook.cells[at:at] = again
    at = _cell(notebook, "test_talker_script") + 1
    notebook.cells[at:at] = [nbformat.v4.new_code_cell(STATE)]
    path = tmp_path_factory.mktemp("lab") / f"{LAB}.ipynb"
    nbformat.write(notebook, path)
    return run_notebook(path, cell_timeout=60)


def test_a_try_it_cell_logs_again_after_a_check_cell(after_a_check) -> None:
    cells = after_a_check.cells
    runs = [c for c in cells if c.cell_type == "code" and "ros.spin_for(1.6)" in c.source]
    assert len(runs) == 2
    for run in runs:
        assert_counted_from_zero(_text(run))


def test_a_check_cell_restores_wall_time_and_removes_its_nodes(after_a_check) -> None:
    cells = after_a_check.cells
    after_clock_check = cells[_cell(after_a_check, "test_counter_publisher") + 1]
    assert _text(after_clock_check).strip() == "sim_time False nodes []"
    after_probe_check = cells[_cell(after_a_check, "test_talker_script") + 1]
    # the probe on 'chatter' (and every node the checks made) is gone; the student's
    # counter_publisher went at the ros.reset() of test_counter_subscriber
    assert _text(after_probe_check).strip() == "sim_time False nodes []"


def test_a_failing_check_shows_its_message_first_and_only_the_students_lines(
    tmp_path: Path,
) -> None:
    notebook = answered(LAB, **replace_in_answer(LAB, "counter_publisher", "'counter'", "'count'"))
    path = tmp_path / f"{LAB}.ipynb"
    nbformat.write(notebook, path)
    ran = run_notebook(path, cell_timeout=60)
    cell = ran.cells[_cell(ran, "test_counter_publisher")]
    error = next(o for o in cell.outputs if o.output_type == "error")
    assert error.ename == "CheckFailed"
    assert error.evalue.startswith("node 'counter_publisher' has no publisher on /counter")
    lines = "\n".join(error.traceback).splitlines()
    assert lines[0] == f"CheckFailed: {error.evalue.splitlines()[0]}", lines
    assert any("checks.expect_published(node, 'counter'" in line for line in lines), lines
    assert not any("rosbook" in line or "site-packages" in line for line in lines), lines
    assert len(lines) < 10, lines
