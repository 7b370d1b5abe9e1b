"""`make test` runs the suite in parallel workers (pytest-xdist, tests/conftest.py): a
file's tests in one worker, files with slow tests first, the book built once."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rosbook.book.pages import ROOT
from tests.conftest import LONGEST, once_per_run

#: The Makefile's pytest-xdist options (``PARALLEL``), read from the Makefile itself.
PARALLEL = re.search(r"^PARALLEL := (.+)$", (ROOT / "Makefile").read_text(), re.M)

#: Two test files that need one thing made once per run; each waits until the other
#: runs, so they pass only when the two workers run them at the same time.
CONFTEST = """
import os, time
from pathlib import Path

import pytest
import pytest
from tests.conftest import once_per_run

@pytest.fixture(scope="session")
def met(tmp_path_factory):
    shared = tmp_path_factory.getbasetemp().parent
    me = os.environ["PYTEST_XDIST_WORKER"]
    (shared / f"running-{me}").touch()
    give_up = time.monotonic() + 120
    while len(list(shared.glob("running-*"))) < 2:
        assert time.monotonic() < give_up, "timeout: the other worker never ran"
        time.sleep(0.05)

@pytest.fixture(scope="session")
def made(tmp_path_factory):
    def make(folder):
        with open(os.environ["MADE_LOG"], "a") as log:
            log.write(os.environ["PYTEST_XDIST_WORKER"] + "\\n")
        time.sleep(0.5)  # the other worker asks meanwhile: it must wait, not make it again
        (folder / "thing").write_text("made")
    return once_per_run(tmp_path_factory, "thing", make)
"""
TEST = """
def test_{name}(met, made):
    assert (made / "thing").read_text() == "made"
"""


def test_two_workers_make_a_shared_thing_once(tmp_path: Path) -> None:
    assert PARALLEL is not None, "the Makefile's PARALLEL options"
    suite = tmp_path / "suite"
    suite.mkdir()
    (suite / "conftest.py").write_text(CONFTEST)
    for name in ("a", "b"):
        (suite / f"test_{name}.py").write_text(TEST.format(name=name))
    log = tmp_path / "made.log"
    options = PARALLEL.group(1).replace("$(TEST_WORKERS)", "2").split()
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", *options, str(suite)],
        cwd=suite,
        env={**os.environ, "PYTHONPATH": str(ROOT), "MADE_LOG": str(log)},
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "2 passed" in done.stdout
    assert len(log.read_text().split()) == 1, f"made by more than one worker: {log.read_text()}"


def collected_files(*options: str) -> list[str]:
    """The suite's test files in the order pytest collects them (and xdist hands them out)."""
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "--collect-only", "-q",
         *options],
        cwd=ROOT, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-3000:]
    return list(dict.fromkeys(ln.split("::")[0] for ln in done.stdout.splitlines() if "::" in ln))


def test_files_with_slow_tests_are_handed_out_first_the_longest_first() -> None:
    files = collected_files()
    with_slow = set(collected_files("-m", "slow"))
    assert with_slow and set(files[: len(with_slow)]) == with_slow, files
    longest = [f"tests/{name}" for name in LONGEST]
    assert [f for f in files if f in longest] == [f for f in longest if f in files], files
    assert files[0] == longest[0], files


def test_a_make_that_raised_is_tried_again_and_its_files_are_kept(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    name = f"failing-{os.getpid()}-{time.monotonic_ns()}"

    def fails(folder: Path) -> None:
        (folder / "build.log").write_text("the first attempt's log")
        raise RuntimeError("the first attempt failed")

    with pytest.raises(RuntimeError, match=f"making {name} failed; its files are in ") as raised:
        once_per_run(tmp_path_factory, name, fails)
    assert str(raised.value.__cause__) == "the first attempt failed"
    kept = Path(str(raised.value).rpartition(" ")[2]) / "build.log"
    assert kept.read_text() == "the first attempt's log"
    folder = once_per_run(tmp_path_factory, name, lambda f: (f / "build.log").write_text("done"))
    assert (folder / "build.log").read_text() == "done"
    assert kept == folder.parent / f"{name}.failed-0" / "build.log"
    assert kept.read_text() == "the first attempt's log"


def test_a_hung_test_fails_as_a_timeout_and_the_run_goes_on(tmp_path: Path) -> None:
    # A test waiting forever for a lost answer must not stall the suite until CI's limit.
    # The suite's own settings (pyproject.toml), with its limit cut to 2 s here.
    assert PARALLEL is not None, "the Makefile's PARALLEL options"
    (tmp_path / "test_hang.py").write_text(
        "import time\n\ndef test_waits_forever():\n    time.sleep(60)\n\n"
        "def test_after_it():\n    pass\n"
    )
    options = PARALLEL.group(1).replace("$(TEST_WORKERS)", "2").split()
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-o", "timeout=2",
         "-c", str(ROOT / "pyproject.toml"), "--rootdir", str(tmp_path), *options, str(tmp_path)],
        cwd=tmp_path, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert "1 failed, 1 passed" in done.stdout, done.stdout[-3000:] + done.stderr[-2000:]
    assert "Timeout (>2.0s)" in done.stdout, done.stdout[-3000:]
