"""Every test run is isolated in a ROS domain of its own, even when pytest is run by hand."""

from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from rosbook.book import pages as bookpages
from rosbook.book.pages import ROOT
from rosbook.book.site import serve
from rosbook.runtime.isolation import isolated_environ
from rosbook.runtime.session import Session, ros

#: Fixtures that take minutes or load the machine: the whole book built, a browser, a
#: lab class graded (also a small one, ``quick_class``), a colcon workspace built, the
#: CLI run on a slow machine.
SLOW_FIXTURES = {
    "built_book",
    "browser",
    "graded",
    "quick_class",
    "round_trip",
    "scaffolded",
    "loaded_runs",
}


#: The files that take longest, longest first (worker seconds in a fresh clone's `make
#: test` with four workers, CI32): handed out first, so that the last minutes are not one
#: worker finishing a long file while the others have nothing left. The other files with
#: slow tests follow, then the quick ones.
LONGEST = (
    "test_trusted_grading.py",  # lab 1's class of attacks, about 300 s
    "test_benchmarks.py",  # every benchmark topic in its quick mode, about 400 s
    "test_lab05.py",  # a class with a submission whose drive hangs, and the round trip
    "test_judge_process.py",  # mostly waits out the judge's guards: fills others' gaps
    "test_book_scenes.py",  # builds the book unless another file did; 3D rendering
    "test_book_browser.py",  # every page in the browser
    "test_grading_runs.py",
    "test_hub.py",
    "test_hub_attacks.py",
    "test_trusted_grading_labs.py",
    "test_labs.py",
    "test_lab06.py",
    "test_lab08.py",  # a class whose tests run pytest ten times each, about 200 s
    "test_sandbox_attacks.py",
    "test_lab01.py",
    "test_book.py",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """A test that uses a slow fixture is marked slow: `make test-fast` leaves it out
    without each such test having to say so.

    `make test` runs the test files in parallel workers (pytest-xdist, ``--dist
    loadfile``: a file's tests in one worker, so its module fixtures, such as a graded
    class, are made once). Files with slow tests come first, the ``LONGEST`` in its
    order, so that the last minutes are not one worker grading a class while the others
    have nothing left: the quick files fill the gaps."""
    for item in items:
        if SLOW_FIXTURES & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)
    slow = {item.path for item in items if item.get_closest_marker("slow")}
    rank = {name: i for i, name in enumerate(LONGEST)}
    items.sort(key=lambda item: (item.path not in slow, rank.get(item.path.name, len(rank))))


@pytest.fixture(scope="session", autouse=True)
def ros_domain() -> Iterator[int]:
    """A domain of this run's own, set before rclpy is first initialised."""
    with isolated_environ() as domain_id:
        yield domain_id
    ros.shutdown()


@pytest.fixture
def session() -> Iterator[Session]:
    """The notebook session, initialised on wall time; its nodes are destroyed after."""
    ros.init()
    yield ros
    ros.reset()


@pytest.fixture
def private() -> Iterator[Path]:
    """A folder of the grader's for a sandbox (in /tmp: nobody can reach it when root)."""
    folder = Path(tempfile.mkdtemp(prefix="rosbook-test-sandbox-"))
    yield folder
    shutil.rmtree(folder, ignore_errors=True)


#: Executed chapters kept between test runs: ``<BOOK_CACHE>/<key>/`` is jupyter-cache's
#: folder, which executes a chapter again only when its code changed; the key changes
#: with the library, the dependencies and the book's settings, which outputs depend on.
BOOK_CACHE = ROOT / "_build" / "test-book-cache"
#: What executed chapters depend on besides their own code.
# The guides execute grading (autograder/) on the labs (labs/, solutions/).
BOOK_INPUTS = [
    "rosbook", "autograder", "labs", "solutions",
    "requirements.txt", "pyproject.toml", "_config.yml",
]  # fmt: skip


def book_cache_key(root: Path = ROOT) -> str:
    """A hash of every file the chapters' outputs depend on besides their own code."""
    digest = hashlib.sha256()
    for entry in BOOK_INPUTS:
        path = root / entry
        files = sorted(path.rglob("*")) if path.is_dir() else [path]
        for file in files:
            if file.is_file() and "__pycache__" not in file.parts:
                digest.update(file.relative_to(root).as_posix().encode() + b"\0")
                digest.update(file.read_bytes())
    return digest.hexdigest()[:16]


def book_cache() -> Path | None:
    """This run's execution cache folder (stale ones removed); ``None`` when
    ``ROSBOOK_BOOK_CACHE=fresh`` asks for every cell to run (``make stress``)."""
    if os.environ.get("ROSBOOK_BOOK_CACHE") == "fresh":
        return None
    folder = BOOK_CACHE / book_cache_key()
    for stale in BOOK_CACHE.glob("*"):
        if stale != folder:
            shutil.rmtree(stale, ignore_errors=True)
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def once_per_run(factory: pytest.TempPathFactory, name: str, make: Callable[[Path], None]) -> Path:
    """The folder ``<run>/<name>`` filled by ``make(folder)`` once per test run, also when
    pytest-xdist runs the tests in several workers: the first worker that needs it makes
    it in the run's shared folder, the others wait on a lock and use it. A ``make`` that
    raised is tried again by the next worker that needs it; what it left is kept beside,
    as ``<name>.failed-<n>``, for its logs, and its error says where."""
    shared = factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        shared = shared.parent  # the run's folder, above each worker's own
    folder, made = shared / name, shared / f"{name}.made"

    def keep() -> Path:
        kept = shared / f"{name}.failed-{len(list(shared.glob(f'{name}.failed-*')))}"
        folder.rename(kept)
        return kept

    with open(shared / f"{name}.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not made.exists():
            if folder.exists():  # left by a worker killed while making it
                keep()
            folder.mkdir()
            try:
                make(folder)
            except Exception as error:
                raise RuntimeError(f"making {name} failed; its files are in {keep()}") from error
            made.touch()
    return folder


@pytest.fixture(scope="session")
def built_book(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The whole book built once per test run (``once_per_run``), as `make book` builds
    it, in a ROS domain of its own. Returns `_build/html`. Chapters whose code and inputs
    are unchanged since an earlier run take their outputs from the kept cache
    (``book_cache``)."""

    def build(out: Path) -> None:
        cache = book_cache()
        if cache is not None:
            (out / "_build").mkdir()
            (out / "_build" / ".jupyter_cache").symlink_to(cache, target_is_directory=True)
        bookpages.build(out)

    return once_per_run(tmp_path_factory, "book", build) / "_build" / "html"


@pytest.fixture(scope="session")
def round_trip(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, Path]:
    """Every lab's release answered as its solution ("right": what a student who solved
    the lab submits) and left as released ("untouched"), graded in one class once per
    test run (``once_per_run``): the instructor CI's round trip (test_labs.py), and each
    lab's right and untouched rows beside its own class (``labtools.with_round_trip``),
    so that no file grades them again. Returns the rows by (student, lab) and the out
    folder."""
    import nbformat

    from autograder.config import lab_ids
    from tests.labtools import answered, grade, grade_rows, notebook_path, submit

    def make(folder: Path) -> None:
        for lab in lab_ids():
            submit(folder / "submissions", "right", lab, answered(lab))
            submit(folder / "submissions", "untouched", lab, nbformat.read(notebook_path(lab), 4))
        # no submission here hangs: a generous cell guard, so a loaded machine never
        # times out
        grade(folder / "submissions", folder / "out", workers=2, cell_timeout=600)

    out = once_per_run(tmp_path_factory, "round_trip", make) / "out"
    return grade_rows(out), out


@pytest.fixture(scope="module")
def site(built_book: Path) -> Iterator[str]:
    """The built book served over http on loopback (the browser tests' site)."""
    with serve(built_book) as url:
        yield url


@pytest.fixture(scope="session")
def browser() -> Iterator[object]:
    """One headless Chromium for the run (see tests/browser.py)."""
    from browser import chromium

    with chromium() as instance:
        yield instance
