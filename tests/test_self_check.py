"""``make check`` (``python -m autograder check``) tells a student what grading will say."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from autograder.check import big_outputs
from tests.labtools import answered, grade_id

#: Each test runs the self-check's notebook in a kernel: out of `make test-fast`.
pytestmark = pytest.mark.slow

LAB = "lab01_nodes_topics"


def test_self_check_reports_a_timed_out_cell_and_a_raising_cell_and_keeps_logs_out(
    tmp_path: Path,
) -> None:
    """A scratch ``rclpy.spin`` runs into the cell limit: grading says ``timeout``, and so
    must the self-check, even though every check passes; the node's log lines go to the
    log file the report names, not to the terminal."""
    notebook = answered(LAB)
    forever = "import rclpy\ncounter = CounterPublisher()\nrclpy.spin(counter)"
    scratch = [nbformat.v4.new_code_cell(forever), nbformat.v4.new_code_cell("1 / 0")]
    at = next(i for i, c in enumerate(notebook.cells) if "ros.spin_for(1.6)" in c.source) + 1
    notebook.cells[at:at] = scratch
    path = tmp_path / f"{LAB}.ipynb"
    nbformat.write(notebook, path)
    log = tmp_path / "check.log"
    done = subprocess.run(
        [sys.executable, "-m", "autograder", "check", str(path), "--timeout", "15",
         "--log", str(log)],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    out = done.stdout
    assert done.returncode == 1, out + done.stderr  # every check passes, yet it is not done
    assert f"{LAB}.ipynb: 4 of 4 visible checks pass" in out, out
    assert "TIMEOUT" in out and f"cell {at + 1}" in out and "'timeout'" in out, out
    assert f"cell {at + 2}: ZeroDivisionError: division by zero" in out, out
    assert "[INFO]" not in out and "Publishing" not in out and done.stderr == "", out
    assert f"(the nodes' log lines: {log})" in out, out
    assert "Publishing: " in log.read_text()


def test_self_check_names_the_cells_a_kernel_kept_busy_did_not_run(tmp_path: Path) -> None:
    """A spin that the interrupt cannot stop (a node with only a subscription): the
    cells after it are not run, and the report says so rather than showing each of them
    interrupted after waiting out the limit."""
    notebook = answered(LAB)
    at = next(i for i, c in enumerate(notebook.cells) if grade_id(c) == "doubler") + 1
    notebook.cells.insert(at, nbformat.v4.new_code_cell("import rclpy\nrclpy.spin(Doubler())"))
    path = tmp_path / f"{LAB}.ipynb"
    nbformat.write(notebook, path)
    done = subprocess.run(
        [sys.executable, "-m", "autograder", "check", str(path), "--timeout", "10",
         "--log", str(tmp_path / "check.log")],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    out = done.stdout
    assert done.returncode == 1, out + done.stderr
    interrupted = "TIMEOUT  these cells ran longer than 10 s and were interrupted"
    assert f"{interrupted}; grading will mark the submission 'timeout': cell {at + 1}." in out, out
    not_run = "NOT RUN  a cell was still running 10 s after it was interrupted"
    assert f"{not_run}, so these later cells did not run: test_doubler, talker_script" in out, out
    assert "not run: the kernel was still busy with cell" in out, out


def test_big_saved_outputs_are_named_so_they_can_be_cleared() -> None:
    notebook = answered(LAB)
    cell = next(c for c in notebook.cells if "ros.spin_for(1.6)" in c.source)
    cell.outputs = [
        nbformat.v4.new_output("display_data", {"text/html": "<iframe>" + "x" * 900_000})
    ]
    index = notebook.cells.index(cell)
    assert big_outputs(notebook) == [f"cell {index + 1} (0.9 MB)"]
    cell.outputs = [nbformat.v4.new_output("stream", text="Publishing: 0\n")]
    assert big_outputs(notebook) == []


def test_self_check_says_when_the_kernel_died_and_names_the_line(tmp_path: Path) -> None:
    """Grading says 'error' when a cell ends the interpreter; the self-check says so
    too, with the line, instead of a traceback of its own."""
    notebook = answered(LAB)
    notebook.cells.insert(2, nbformat.v4.new_code_cell("import os\nos._exit(3)"))
    path = tmp_path / f"{LAB}.ipynb"
    nbformat.write(notebook, path)
    done = subprocess.run(
        [sys.executable, "-m", "autograder", "check", str(path), "--timeout", "15",
         "--log", str(tmp_path / "check.log")],
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert done.returncode == 1 and done.stderr == "", done.stdout + done.stderr
    assert "the Python kernel running it died" in done.stdout and "'error'" in done.stdout
    assert "cell 3: os._exit(3)" in done.stdout, done.stdout
