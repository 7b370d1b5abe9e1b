"""Lab 8's checks (testing): a student's pytest file must pass on a correct wall stopper
and fail on each seeded bug.

The student's tests import the node under test as ``from wall_stopper import
WallStopper, forward_speed``. Each check runs the test file with pytest in a process of
its own, ``python -I -m rosbook.labs.lab08 TEST_FILE``, which puts
``rosbook.labs.wall_stopper`` on that name, seeded with the bug it reads on its stdin
(none: the correct node). When graded, the judge starts that process as the student,
in the student's sandbox and folder (``Judgement.wrap``), and reads its exit code
itself: pytest's own verdict on the student's tests. A bug the tests miss is named by
its description (``wall_stopper.BUGS``), never by a test's source.
"""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from rosbook.labs import wall_stopper
from rosbook.labs.deferral import deferrable
from rosbook.labs.probes import CheckFailed, TimedOut, run_program
from rosbook.labs.remote import judging

#: The file the student writes, and the module name their tests import.
TEST_FILE = "test_wall_stopper.py"
MODULE = "wall_stopper"
#: Wall-clock seconds one pytest run may take: a hang guard, never a verdict.
RUN_GUARD_S = 300.0

#: pytest's exit codes (``pytest.ExitCode``) that the checks tell apart.
PASSED, FAILED, NO_TESTS = 0, 1, 5


@dataclass
class TestRun:
    """One pytest run of the student's file against the node seeded with ``bug``."""

    __test__ = False  # not a test class, for pytest

    bug: str | None
    code: int
    output: str

    @property
    def failed(self) -> list[str]:
        """The tests pytest reported failed or in error (``FAILED``/``ERROR`` lines)."""
        found = re.findall(r"^(?:FAILED|ERROR) \S*?::(\S+)", self.output, re.MULTILINE)
        return list(dict.fromkeys(found))

    @property
    def passed(self) -> int:
        """How many tests pytest's summary line says passed."""
        summary = self.output.strip().splitlines()[-1:]
        found = re.findall(r"(\d+) passed", summary[0]) if summary else []
        return int(found[-1]) if found else 0

    def tail(self, lines: int = 15) -> str:
        return "\n".join(self.output.strip().splitlines()[-lines:])


def run_tests(path: str = TEST_FILE, bug: str | None = None) -> TestRun:
    """Run pytest on ``path`` against the wall stopper seeded with ``bug`` (None: the
    correct one); when graded, as the student in their sandbox. A hang is ``TimedOut``."""
    if bug is not None and bug not in wall_stopper.BUGS:
        raise ValueError(f"no seeded bug {bug!r}; the bugs: {', '.join(wall_stopper.BUGS)}")
    j = judging()
    folder = Path.cwd() if j is None else j.folder
    if not (folder / path).is_file():
        raise CheckFailed(f"{path} does not exist: did you run its %%writefile cell?")
    guard = RUN_GUARD_S if j is None else j.guard(RUN_GUARD_S)
    argv = [sys.executable, "-I", "-m", "rosbook.labs.lab08", path]
    wrap = list if j is None else j.wrap
    with run_program(argv, cwd=folder, wrap=wrap, stdin=True) as run:
        try:
            output, _ = run.proc.communicate(f"{bug or ''}\n", timeout=guard)
        except subprocess.TimeoutExpired:
            against = "a correct node" if bug is None else wall_stopper.BUGS[bug]
            raise TimedOut(
                f"timeout: pytest on {path} against {against} had not finished after "
                f"{guard:.0f} s. Does a test wait for something without a guard?"
            ) from None
    return TestRun(bug, run.proc.returncode, output)


def assert_passes_on_correct(path: str = TEST_FILE) -> TestRun:
    """Every test of ``path`` passes on the correct wall stopper (and there is one)."""
    run = run_tests(path)
    if run.code == NO_TESTS or (run.code == PASSED and not run.passed):
        raise CheckFailed(
            f"pytest found no tests in {path}: name each test function test_..., at the "
            "top level of the file"
        )
    if run.code == FAILED:
        raise CheckFailed(
            f"your tests must all pass on a correct wall stopper, and these failed: "
            f"{', '.join(run.failed) or 'see below'}. A test that fails on right code "
            f"expects something the contract does not say.\n{run.tail()}"
        )
    if run.code != PASSED:
        raise CheckFailed(
            f"pytest could not run {path} (exit code {run.code}): does it import "
            f"`from {MODULE} import WallStopper, forward_speed` and nothing else of "
            f"yours?\n{run.tail()}"
        )
    return run


def assert_catches(path: str, bugs: Sequence[str]) -> None:
    """``path`` passes on the correct wall stopper and fails on each of ``bugs``."""
    assert_passes_on_correct(path)
    missed = []
    for bug in bugs:
        run = run_tests(path, bug)
        if run.code not in (PASSED, FAILED):
            raise CheckFailed(
                f"pytest did not finish its run of {path} on {wall_stopper.BUGS[bug]}: "
                f"exit code {run.code}, where a failed test gives 1: {run.tail(1)}"
            )
        if run.code == PASSED:
            missed.append(bug)
    if missed:
        described = "; ".join(wall_stopper.BUGS[bug] for bug in missed)
        raise CheckFailed(
            f"your tests passed on {described}. Add a test that fails on "
            f"{'it' if len(missed) == 1 else 'each'}."
        )


def main(argv: list[str] | None = None) -> int:
    """``python -I -m rosbook.labs.lab08 TEST_FILE``, given the bug's name (or an empty
    line) on stdin: pytest on ``TEST_FILE`` with the seeded wall stopper as ``MODULE``;
    exits with pytest's exit code."""
    import pytest

    (path,) = sys.argv[1:] if argv is None else argv
    wall_stopper.seed(sys.stdin.readline().strip() or None)
    sys.modules[MODULE] = wall_stopper
    options = ["-p", "no:cacheprovider", "-c", "/dev/null", "--rootdir", "."]
    return int(pytest.main([*options, "-q", "-rfE", "--color=no", "--no-header", path]))


deferrable(globals())

if __name__ == "__main__":
    raise SystemExit(main())
