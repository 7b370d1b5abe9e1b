"""Grading works wherever an instructor runs it, or says why before grading anyone: the
preflight, staging the sandbox can enter, and the grader's own failures never the
student's."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from jupyter_core.utils import run_sync

from autograder import preflight, sandbox
from autograder.config import ROOT
from autograder.feedback import GRADER_ERROR, GRADER_ERROR_FEEDBACK
from autograder.kernels import IpcKernelManager
from autograder.worker import grader_failure
from tests.labtools import HANG, answered, grade_cmd, grade_rows, submit

ACCUSING = "A cell must never end the interpreter"

as_root = pytest.mark.skipif(os.geteuid() != 0, reason="the sandbox is another user only as root")

LAB = "lab01_nodes_topics"


def grade_from(
    checkout: Path, submissions: Path, out: Path, *extra: str, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """``python -m autograder grade`` run from ``checkout``."""
    command = [*grade_cmd(submissions, out, LAB), *extra]
    return subprocess.run(
        command, capture_output=True, text=True, cwd=checkout, timeout=HANG, env=env
    )


@pytest.fixture
def private_tmp() -> Iterator[Path]:
    """A temporary folder as ``pam_tmpdir`` makes it: mode 0700, owned by root."""
    folder = Path(tempfile.mkdtemp(prefix="private-tmp-", dir="/tmp"))
    os.chmod(folder, 0o700)
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


@as_root
def test_a_private_tmpdir_grades_correctly(private_tmp: Path, tmp_path: Path) -> None:
    submissions = tmp_path / "submitted"
    submit(submissions, "alice", LAB, answered(LAB))
    out = tmp_path / "out"
    done = grade_from(ROOT, submissions, out, env={**os.environ, "TMPDIR": str(private_tmp)})
    assert done.returncode == 0, done.stderr
    row = grade_rows(out)[("alice", LAB)]
    assert row["status"] == "ok" and float(row["score"]) == float(row["max_score"]) == 10, row


@as_root
def test_a_folder_the_sandbox_cannot_enter_is_refused_naming_it(
    private_tmp: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(tempfile, "tempdir", str(private_tmp))
    monkeypatch.setattr(sandbox, "STAGING_CANDIDATES", ())
    with pytest.raises(preflight.NotReady) as refused:
        preflight.check()
    said = str(refused.value)
    assert f"cannot enter {private_tmp}" in said and f"chmod o+x {private_tmp}" in said, said


@as_root
def test_bwraps_own_refusal_of_a_folder_is_explained_with_its_fix(
    private_tmp: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # staging under the private folder, as the grader did before: bwrap itself refuses
    monkeypatch.setattr(sandbox, "staging_base", lambda: str(private_tmp))
    with pytest.raises(preflight.NotReady) as refused:
        preflight.check()
    said = str(refused.value)
    assert f"cannot enter {private_tmp}, on the way to {private_tmp}/" in said, said
    assert "Permission denied" in said and "TMPDIR=/tmp" in said, said


@pytest.fixture
def other_checkout(tmp_path: Path) -> Path:
    """A copy of the grader whose venv's editable install points at this checkout."""
    copy = tmp_path / "other-checkout"
    for name in ("autograder", "rosbook", *sandbox.FRONT_ENDS, "solutions", "labs"):
        ignore = shutil.ignore_patterns("__pycache__")
        shutil.copytree(ROOT / name, copy / name, ignore=ignore, symlinks=True)
    return copy


def test_an_unimportable_project_stops_grading_before_the_first_row(
    other_checkout: Path, tmp_path: Path
) -> None:
    submissions = tmp_path / "submitted"
    submit(submissions, "alice", LAB, answered(LAB))
    out = tmp_path / "out"
    done = grade_from(other_checkout, submissions, out)
    assert done.returncode == 2, done
    said = done.stderr.strip()
    assert len(said.splitlines()) == 1, said
    assert f"cannot import autograder from this checkout ({other_checkout})" in said, said
    assert f"imports it from {ROOT}" in said and "make .venv/.installed" in said, said
    assert not out.exists()  # nothing graded, no row written


def test_the_preflight_passes_here_and_is_cheap() -> None:
    seconds = preflight.check()
    assert seconds < 60, f"timeout: the preflight took {seconds:.1f} s"  # a hang guard only
    assert preflight.check(sandboxed=False) < 60
    first = preflight.once()  # a spawner's: the probe's seconds of its first (only) run
    assert preflight.once() == first and preflight._ready == [first]


class Unenterable(IpcKernelManager):
    """A kernel staged where its sandbox cannot enter: its start fails, no cell runs."""

    where = ""

    def private_parent(self) -> str:
        return self.where


@as_root
def test_a_kernel_that_never_started_is_the_graders_failure_not_the_students(
    private_tmp: Path, tmp_path: Path
) -> None:
    km = Unenterable(kernel_name="python3")
    km.where = str(private_tmp)
    (tmp_path / "notebook").mkdir()
    run_sync(km.start_kernel)(cwd=str(tmp_path / "notebook"))
    client = km.client()
    try:
        with pytest.raises(RuntimeError) as failed:
            run_sync(client.wait_for_ready)(timeout=HANG)
    finally:
        run_sync(km.shutdown_kernel)(now=True)
    said = f"{type(failed.value).__name__}: {failed.value}"
    assert "Kernel died before replying to kernel_info" in said
    line = grader_failure(f"[AutogradeApp | ERROR] ...\n{said}\n")
    assert line == said
    assert grader_failure("DeadKernelError: Kernel died\n") is None  # a cell ended it


def test_the_student_reads_a_neutral_message_and_resume_grades_it_again(
    tmp_path: Path,
) -> None:
    submissions = tmp_path / "submitted"
    submit(submissions, "carol", LAB, '{"cells": [ not JSON')  # graded without a kernel
    out = tmp_path / "out"
    first = grade_from(ROOT, submissions, out)
    assert first.returncode == 0, first.stderr
    # that row as the grader's own failure (its sandbox did not start) left it
    journal = out / "results.jsonl"
    entry = json.loads(journal.read_text().splitlines()[-1])
    entry.update(status=GRADER_ERROR, message="The grader failed before any cell ran: bwrap: x")
    journal.write_text(json.dumps(entry) + "\n")
    again = grade_from(ROOT, submissions, out, "--resume")
    assert again.returncode == 0, again.stderr
    assert grade_rows(out)[("carol", LAB)]["status"] == "error"  # graded again
    assert len(journal.read_text().splitlines()) == 2


def test_a_grader_error_page_tells_the_student_it_was_not_their_notebook(
    tmp_path: Path,
) -> None:
    from autograder.grade import Assignment, not_graded

    lab = Assignment(LAB, tmp_path, f"{LAB}.ipynb", 10.0, "digest")
    graded = not_graded(lab, "dave", "The grader failed: OSError: no space left on device")
    assert graded.row.status == GRADER_ERROR and "no space left" in graded.row.message
    page = graded.feedback.decode()
    assert GRADER_ERROR_FEEDBACK.split(":")[0] in page
    assert "no space left" not in page and ACCUSING not in page
