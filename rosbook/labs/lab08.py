"""Lab 8's checks (testing): a student's pytest file must pass on a correct wall stopper
and fail on each seeded bug.

The student's tests import the node under test as ``from wall_stopper import
WallStopper, forward_speed``. Each check runs the test file with pytest in a process of
its own, ``python -I -m rosbook.labs.lab08 TEST_FILE``, which reads the source of the
module under test on its stdin (``wall_stopper.variant``: one variant's code, nothing
that names it), makes it that module, closes its stdin, and says the digest of what it
got before pytest starts; a run whose digest is not the sent one is no verdict. When
graded, the judge starts that process as the student, in the student's sandbox and
folder (``Judgement.wrap``). The verdict is what ``pytest.main`` returned, said on the
process's last line (``FINISHED``), not the exit code the judge is told (a loaded
machine once gave it 0 for a failed run). A bug is named by what it does (``wall_stopper.BUGS``), never by
anything the tests can read, and the hidden tests also try them on a correct node
written differently (``rewrite``), which a test that recognises the code fails on.
"""

from __future__ import annotations

import hashlib
import os
import re
import subprocess
import sys
import types
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

#: The first line the process prints: the digest of the module it got (``received``).
RECEIVED = f"{MODULE} under test: sha256 "

#: The last line the process prints: what ``pytest.main`` returned (``finished``). The
#: verdict is read from it, not from the exit code: on a loaded machine the judge was
#: told 0 for a run whose pytest had returned 1 (the exit status lost on its way).
FINISHED = "pytest returned "

#: pytest's exit codes (``pytest.ExitCode``) that the checks tell apart.
PASSED, FAILED, NO_TESTS = 0, 1, 5


@dataclass
class TestRun:
    """One pytest run of the student's file against the node seeded with ``bug``."""

    __test__ = False  # not a test class, for pytest

    bug: str | None
    #: What pytest returned, or None when the process ended before it returned.
    code: int | None
    output: str
    #: The process's exit code, as the judge was told it.
    exit: int | None = None

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


def received(source: str) -> str:
    """The line that says the process got ``source`` as the module under test."""
    return RECEIVED + hashlib.sha256(source.encode()).hexdigest()


def finished(output: str) -> tuple[int | None, str]:
    """What pytest returned, as the last line of ``output`` says (None: no such line,
    the process ended before), and the output without that line."""
    head, _, last = output.rstrip("\n").rpartition("\n")
    said = last.removeprefix(FINISHED)
    if last.startswith(FINISHED) and said.isdigit():
        return int(said), head
    return None, output


def run_tests(
    path: str = TEST_FILE, bug: str | None = None, rewrite: int | None = None
) -> TestRun:
    """Run pytest on ``path`` against the wall stopper seeded with ``bug`` (None: the
    correct one; ``rewrite``: written differently, ``wall_stopper.variant``); when graded,
    as the student in their sandbox. A hang is ``TimedOut``; a process that did not get
    the module under test is a ``RuntimeError`` (the grader's, never a verdict)."""
    source = wall_stopper.variant(bug, rewrite)
    j = judging()
    folder = Path.cwd() if j is None else j.folder
    if not (folder / path).is_file():
        raise CheckFailed(f"{path} does not exist: did you run its %%writefile cell?")
    guard = RUN_GUARD_S if j is None else j.guard(RUN_GUARD_S)
    argv = [sys.executable, "-I", "-m", "rosbook.labs.lab08", path]
    wrap = list if j is None else j.wrap
    with run_program(argv, cwd=folder, wrap=wrap, stdin=True) as run:
        try:
            output, _ = run.proc.communicate(source, timeout=guard)
        except subprocess.TimeoutExpired:
            against = "a correct node" if bug is None else wall_stopper.BUGS[bug]
            raise TimedOut(
                f"timeout: pytest on {path} against {against} had not finished after "
                f"{guard:.0f} s. Does a test wait for something without a guard?"
            ) from None
    first, _, rest = output.partition("\n")
    if first != received(source):
        raise RuntimeError(
            f"the run of {path} did not get its module under test (exit code "
            f"{run.proc.returncode}): {output.strip()[-300:]!r}"
        )
    code, rest = finished(rest)
    if code is not None and code != run.proc.returncode:  # for the grading log
        print(
            f"[lab08] pytest on {path} returned {code}; its process's exit code read "
            f"{run.proc.returncode}",
            file=sys.stderr,
            flush=True,
        )
    return TestRun(bug, code, rest, run.proc.returncode)


def assert_passes_on_correct(path: str = TEST_FILE, rewrite: int | None = None) -> TestRun:
    """Every test of ``path`` passes on the correct wall stopper (and there is one);
    ``rewrite``: on the correct one written differently by that seed."""
    run = run_tests(path, rewrite=rewrite)
    if run.code is None:
        raise unfinished(path, run, "a correct wall stopper")
    if run.code == NO_TESTS or (run.code == PASSED and not run.passed):
        raise CheckFailed(
            f"pytest found no tests in {path}: name each test function test_..., at the "
            "top level of the file"
        )
    if run.code == FAILED:
        correct = "a correct wall stopper" + (" written differently" if rewrite else "")
        raise CheckFailed(
            f"your tests must all pass on {correct}, and these failed: "
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


def assert_catches(path: str, bugs: Sequence[str], rewrite: int | None = None) -> None:
    """``path`` passes on the correct wall stopper and fails on each of ``bugs``; with
    ``rewrite``, each of them written differently by that seed."""
    assert_passes_on_correct(path, rewrite)
    missed = []
    for bug in bugs:
        run = run_tests(path, bug, rewrite)
        if run.code is None:
            raise unfinished(path, run, wall_stopper.BUGS[bug])
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


def unfinished(path: str, run: TestRun, against: str) -> CheckFailed:
    """What a run whose process ended before pytest returned says (no pass, no catch)."""
    return CheckFailed(
        f"pytest did not finish its run of {path} on {against}: the process ended (exit "
        f"code {run.exit}) before pytest reported. Does a test end the process?\n{run.tail()}"
    )


def module_under_test(source: str) -> types.ModuleType:
    """``source`` made the module ``MODULE``, as an import would (with no file)."""
    module = types.ModuleType(MODULE)
    exec(compile(source, f"<{MODULE}>", "exec"), module.__dict__)  # noqa: S102 (variant())
    return module


def main(argv: list[str] | None = None) -> int:
    """``python -I -m rosbook.labs.lab08 TEST_FILE``, given the module under test's
    source on stdin: pytest on ``TEST_FILE`` with that module as ``MODULE``; exits with
    pytest's exit code. Nothing the tests can read names the variant: stdin is read to
    its end and closed, and the source is not kept."""
    import pytest

    (path,) = sys.argv[1:] if argv is None else argv
    source = sys.stdin.read()
    sys.modules[MODULE] = module_under_test(source)
    os.dup2(os.open(os.devnull, os.O_RDONLY), 0)
    sys.stdin = open(os.devnull)  # noqa: SIM115 - the process's stdin, to its end
    print(received(source), flush=True)
    del source
    options = ["-p", "no:cacheprovider", "-c", "/dev/null", "--rootdir", "."]
    code = int(pytest.main([*options, "-q", "-rfE", "--color=no", "--no-header", path]))
    print(f"\n{FINISHED}{code}", flush=True)
    return code


deferrable(globals())

if __name__ == "__main__":
    raise SystemExit(main())
