"""Every lab's test cells are run by the judge as the instructor wrote them, never
scored by the student's kernel.

``make labs`` refuses a lab with a test cell the judge cannot run outside the kernel,
naming the lab, the cell and why; the kernel never gets a hidden test's source. The lab
added here is a small one from ``tests/fixtures`` (a ``Greeter`` node with a ``name``
parameter: a notebook and nothing else), released and graded with the real commands,
nbgrader and a sandboxed kernel: it is judged with no file of the grader's touched, and
an edit to its hidden test changes the grade.
"""

from __future__ import annotations

import html
import json
import os
import subprocess
import sys
from dataclasses import asdict
from pathlib import Path

import nbformat
import pytest

from autograder.config import LABS, ROOT, SOLUTIONS, lab_ids
from autograder.course import generate
from autograder.feedback import is_test_cell
from autograder.judge import unjudged_cells
from autograder.verdicts import sent_to_kernel
from autograder.worker import Job
from tests.labtools import (
    HISTORY_PRINTER,
    SOURCE_PRINTER,
    extra_cell,
    grade_id,
    hidden_only_lines,
    output_text,
    strip_markers,
)

FIXTURES = Path(__file__).parent / "fixtures"
LAB = "lab07_params"
FORGE = "get_ipython().input_transformers_post.append(lambda lines: ['pass\\n'])"


@pytest.mark.parametrize("lab", lab_ids())
def test_every_test_cell_of_every_lab_in_solutions_has_a_judge_check(lab: str) -> None:
    notebook = nbformat.read(SOLUTIONS / lab / f"{lab}.ipynb", as_version=4)
    assert unjudged_cells(lab, notebook) == []


@pytest.mark.parametrize("lab", lab_ids())
def test_a_student_has_each_test_cell_as_grading_sends_it_to_the_kernel(lab: str) -> None:
    """The released lab (what ``make check`` runs) holds each test cell without its
    hidden tests, exactly as grading sends it to the student's kernel: neither ever
    has a hidden test."""
    source = nbformat.read(SOLUTIONS / lab / f"{lab}.ipynb", as_version=4)
    released = nbformat.read(LABS / lab / f"{lab}.ipynb", as_version=4)
    sent = {grade_id(c): sent_to_kernel(c).source for c in source.cells if is_test_cell(c)}
    shown = {grade_id(c): c.source for c in released.cells if is_test_cell(c)}
    assert sent == shown
    assert all("HIDDEN TESTS" not in text for text in sent.values())


def test_a_test_cell_reading_a_name_no_cell_defines_is_named_with_the_name() -> None:
    lab = "lab01_nodes_topics"
    notebook = nbformat.read(SOLUTIONS / lab / f"{lab}.ipynb", as_version=4)
    for cell in notebook.cells:
        if grade_id(cell) == "test_doubler":
            cell.source = cell.source.replace("make_node(Doubler", "make_node(Tripler")
    assert unjudged_cells(lab, notebook) == [
        f"{lab}: test cell test_doubler: uses Tripler, which no cell of the notebook defines "
        "(the judge runs the test cell outside the kernel, with the setup cells' names and "
        "the student's)"
    ]


def test_a_test_cell_in_ipython_syntax_is_named_with_its_line() -> None:
    lab = "lab01_nodes_topics"
    notebook = nbformat.read(SOLUTIONS / lab / f"{lab}.ipynb", as_version=4)
    for cell in notebook.cells:
        if grade_id(cell) == "test_doubler":
            cell.source = "%time x = 1\n" + cell.source
    assert unjudged_cells(lab, notebook) == [
        f"{lab}: test cell test_doubler: line 1 is IPython syntax (%time), which the judge "
        "cannot run outside the kernel: write it as Python"
    ]


def test_make_labs_refuses_a_lab_whose_test_cell_the_judge_cannot_run(tmp_path: Path) -> None:
    source = nbformat.read(FIXTURES / LAB / f"{LAB}.ipynb", as_version=4)
    for cell in source.cells:
        if is_test_cell(cell):
            cell.source = cell.source.replace("node = Greeter()", "node = Welcomer()")
    (tmp_path / LAB).mkdir()
    nbformat.write(source, tmp_path / LAB / f"{LAB}.ipynb")
    done = subprocess.run(
        [sys.executable, "-m", "autograder", "labs", LAB, "--solutions", str(tmp_path)],
        capture_output=True, text=True, cwd=ROOT, timeout=600, check=False,
    )  # fmt: skip
    assert done.returncode == 1, done.stdout + done.stderr
    assert done.stderr.splitlines()[0] == (
        f"error: {LAB}: test cell test_greeter: uses Welcomer, which no cell of the notebook "
        "defines (the judge runs the test cell outside the kernel, with the setup cells' "
        "names and the student's)"
    ), done.stderr
    assert "Nothing was generated" in done.stderr
    assert not (ROOT / "labs" / LAB).exists()


def worker_grades(job: Job) -> dict[str, object]:
    """``job`` graded by the grader's own worker process (``python -m autograder.worker``)."""
    read, write = os.pipe()
    try:
        done = subprocess.run(
            [sys.executable, "-m", "autograder.worker", str(write)],
            input=json.dumps(asdict(job)) + "\n",
            pass_fds=(write,), capture_output=True, text=True, cwd=ROOT, timeout=900,
            check=False,
        )  # fmt: skip
        os.close(write)
        write = -1
        with os.fdopen(read, "r") as results:
            read = -1
            line = results.readline()
    finally:
        for fd in (read, write):
            if fd >= 0:
                os.close(fd)
    assert line, done.stdout + done.stderr
    return json.loads(line)  # type: ignore[no-any-return]


@pytest.fixture(scope="module")
def template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The fixture lab as grading prepares it: its gradebook (hidden tests) and release."""
    root = tmp_path_factory.mktemp("template") / LAB
    generate(root, LAB, solutions=FIXTURES)
    return root


def submission(template: Path, *cells: str) -> nbformat.NotebookNode:
    """The release, answered as in the solution, with ``cells`` added after the set-up."""
    notebook = nbformat.read(template / "release" / LAB / f"{LAB}.ipynb", as_version=4)
    source = nbformat.read(FIXTURES / LAB / f"{LAB}.ipynb", as_version=4)
    answers = {grade_id(c): strip_markers(c.source) for c in source.cells}
    for cell in notebook.cells:
        if cell.metadata.get("nbgrader", {}).get("solution"):
            cell.source = answers[grade_id(cell)]
    for source_text in reversed(cells):
        extra_cell(notebook, source_text)
    notebook.cells.append(nbformat.v4.new_code_cell(HISTORY_PRINTER))
    return notebook


def graded(template: Path, tmp: Path, notebook: nbformat.NotebookNode) -> tuple[dict, str]:
    folder = tmp / "submitted" / LAB
    folder.mkdir(parents=True)
    nbformat.write(notebook, folder / f"{LAB}.ipynb")
    job = Job(
        str(template), LAB, "student", str(folder), f"{LAB}.ipynb", str(tmp / "course"),
        str(tmp / "feedback.html"), 30,
    )  # fmt: skip
    result = worker_grades(job)
    autograded = tmp / "course" / "autograded" / "student" / LAB / f"{LAB}.ipynb"
    notebook = nbformat.read(autograded, as_version=4)
    # the graded notebook (the instructor's view) keeps the instructor's test cell
    source = nbformat.read(FIXTURES / LAB / f"{LAB}.ipynb", as_version=4)
    tests = {grade_id(c): c.source for c in source.cells if is_test_cell(c)}
    assert {grade_id(c): c.source for c in notebook.cells if is_test_cell(c)} == tests
    return result, output_text(notebook) + html.unescape((tmp / "feedback.html").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("forged", [False, True], ids=["honest", "input_transformer"])
def test_an_added_lab_is_judged_outside_the_kernel_which_never_sees_its_hidden_tests(
    template: Path, tmp_path: Path, forged: bool
) -> None:
    """A lab added as a notebook alone is judged: the right answer scores full marks,
    and one whose kernel forges a pass (every later cell run as ``pass``, the solution's
    too) scores nothing. A student's hooks printing each cell's source, and its input
    history, show no hidden test."""
    cells = [SOURCE_PRINTER, FORGE] if forged else [SOURCE_PRINTER]
    result, seen = graded(template, tmp_path, submission(template, *cells))
    if forged:
        assert result["score"] == 0, result
        assert "passed: the grader checked" not in seen
    else:
        assert (result["score"], result["status"]) == (3, "ok"), result
        assert "HISTORY:" in seen, seen[:3000]
        assert "Greeter declares 'name'" in seen  # the visible part of the test ran
        assert "passed: the grader checked this cell on your code" in seen
    assert "PRE-RUN:" in seen, seen[:3000]  # the hooks ran
    hidden = hidden_only_lines(LAB, FIXTURES, template / "release")
    assert hidden and all(line not in seen for line in hidden), hidden


@pytest.mark.slow
def test_an_instructors_edit_to_a_hidden_test_changes_the_grade(tmp_path: Path) -> None:
    """The hidden test's expected greeting edited in the source notebook (and nothing
    else): the same right answer now fails that cell, with the edited test's message."""
    source = nbformat.read(FIXTURES / LAB / f"{LAB}.ipynb", as_version=4)
    for cell in source.cells:
        if is_test_cell(cell):
            assert '"Hello, hidden ROS!"' in cell.source
            cell.source = cell.source.replace('"Hello, hidden ROS!"', '"Hi, hidden ROS!"')
    edited = tmp_path / "solutions"
    (edited / LAB).mkdir(parents=True)
    nbformat.write(source, edited / LAB / f"{LAB}.ipynb")
    template = tmp_path / "template" / LAB
    generate(template, LAB, solutions=edited)
    folder = tmp_path / "submitted" / LAB
    folder.mkdir(parents=True)
    nbformat.write(submission(template), folder / f"{LAB}.ipynb")
    job = Job(
        str(template), LAB, "student", str(folder), f"{LAB}.ipynb", str(tmp_path / "course"),
        str(tmp_path / "feedback.html"), 30,
    )  # fmt: skip
    result = worker_grades(job)
    assert result["score"] == 0, result
    feedback = html.unescape((tmp_path / "feedback.html").read_text())
    assert "Hello, hidden ROS!" in feedback  # the assertion's message: what the node said
