"""The book's chapters execute side by side, each in a ROS domain of its own
(``rosbook.book.sphinx_execute``), on a small real Sphinx project with myst-nb."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

from rosbook.book.pages import failure_excerpt
from rosbook.book.sphinx_execute import JOBS_VARIABLE

#: A Sphinx build with kernels: out of `make test-fast`.
pytestmark = pytest.mark.slow

CHAPTERS = ["a", "b", "c", "d", "e", "f"]  # Sphinx reads more than 5 in parallel only

#: Chapter ``me`` says it runs, then waits for chapter ``other`` to say so: both end only
#: if they execute at the same time. The wait is a hang guard (it says what did not happen).
MEET = """
import os, pathlib, time
from ipykernel import get_connection_info
folder = pathlib.Path({folder!r})
(folder / "domain-{me}").write_text(os.environ.get("ROS_DOMAIN_ID", "none"))
(folder / "transport-{me}").write_text(get_connection_info(unpack=True)["transport"])
(folder / "running-{me}").touch()
give_up = time.monotonic() + 120
while not (folder / "running-{other}").exists():
    assert time.monotonic() < give_up, "timeout: chapter {other} did not run while {me} ran"
    time.sleep(0.05)
"""
NOTE = """
import os, pathlib
from ipykernel import get_connection_info
pathlib.Path({folder!r}, "domain-{me}").write_text(os.environ.get("ROS_DOMAIN_ID", "none"))
pathlib.Path({folder!r}, "transport-{me}").write_text(get_connection_info(unpack=True)["transport"])
"""


def project(tmp_path: Path) -> Path:
    source, seen = tmp_path / "src", tmp_path / "seen"
    source.mkdir()
    seen.mkdir()
    (source / "conf.py").write_text(
        'extensions = ["myst_nb", "rosbook.book.sphinx_execute"]\n'
        'nb_execution_mode = "cache"\n'
        "nb_execution_timeout = 300\n"
        "nb_execution_raise_on_error = False\n"  # as _config.yml: -W fails the build
        "nb_execution_show_tb = True\n"
    )
    toc = "\n".join(f"   {name}" for name in CHAPTERS)
    (source / "index.rst").write_text(f"Book\n====\n\n.. toctree::\n\n{toc}\n")
    pairs = {"a": "d", "d": "a"}
    for name in CHAPTERS:
        code = (MEET if name in pairs else NOTE).format(
            folder=str(seen), me=name, other=pairs.get(name)
        )
        notebook = new_notebook(cells=[new_markdown_cell(f"# Chapter {name}"), new_code_cell(code)])
        notebook.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3"}
        nbformat.write(notebook, source / f"{name}.ipynb")
    return source


def sphinx_build(source: Path, html: Path, *flags: str) -> subprocess.CompletedProcess[str]:
    """``sphinx-build -W -b html`` of ``source`` with two parallel readers."""
    return subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", *flags, "-b", "html", str(source), str(html)],
        env={**os.environ, JOBS_VARIABLE: "2"},
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )


def test_chapters_execute_side_by_side_each_in_a_domain_of_its_own(tmp_path: Path) -> None:
    source = project(tmp_path)
    done = sphinx_build(source, tmp_path / "html")  # two readers: a, b, c; d, e, f
    assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
    domains = {name: (tmp_path / "seen" / f"domain-{name}").read_text() for name in CHAPTERS}
    build_domain = os.environ["ROS_DOMAIN_ID"]  # the test run is isolated (conftest)
    assert build_domain not in domains.values(), f"a chapter ran in the build's domain: {domains}"
    assert domains["a"] != domains["d"], f"chapters running at once share a domain: {domains}"
    for first, second in zip(CHAPTERS, CHAPTERS[1:]):  # one process reads these in turn
        if {first, second} != {"c", "d"}:
            assert domains[first] != domains[second], domains
    # on Unix sockets: a TCP kernel can lose a port to another process as it starts
    transports = {name: (tmp_path / "seen" / f"transport-{name}").read_text() for name in CHAPTERS}
    assert set(transports.values()) == {"ipc"}, transports


def test_a_chapter_that_times_out_is_named_with_its_cell_in_the_failure(tmp_path: Path) -> None:
    """A timed-out cell (or a dead kernel) fails the build with myst-nb's own account of
    it, not with the end of the log only (a kernel's complaint that its socket closed)."""
    source = project(tmp_path)
    conf = (source / "conf.py").read_text().replace("timeout = 300", "timeout = 5")
    (source / "conf.py").write_text(conf)
    notebook = nbformat.read(source / "b.ipynb", 4)
    notebook.cells.append(new_code_cell("import threading\nthreading.Event().wait()  # hangs"))
    nbformat.write(notebook, source / "b.ipynb")
    pairs = "a", "d"  # they wait for each other; keep them apart from the hang's reader
    for name in pairs:
        (source / f"{name}.ipynb").unlink()
        toc = (source / "index.rst").read_text().replace(f"   {name}\n", "")
        (source / "index.rst").write_text(toc)
    done = sphinx_build(source, tmp_path / "html")
    assert done.returncode != 0
    excerpt = failure_excerpt(done.stdout + done.stderr)
    assert "Executing notebook failed: CellTimeoutError" in excerpt.splitlines()[0], excerpt
    assert "threading.Event().wait()" in excerpt, excerpt


def test_a_failing_cell_is_named_with_its_error_when_the_build_keeps_going(tmp_path) -> None:
    """As the book builds (``-W --keep-going``, chapters read in parallel): a cell that
    raises fails the build, and the log holds the cell and its error. (Raised as an
    error instead, Sphinx drops what the failing reader logged and stops the others.)"""
    source = project(tmp_path)
    notebook = nbformat.read(source / "e.ipynb", 4)
    notebook.cells.append(new_code_cell("raise ValueError('the robot is not where expected')"))
    nbformat.write(notebook, source / "e.ipynb")
    done = sphinx_build(source, tmp_path / "html", "--keep-going")
    assert done.returncode != 0
    excerpt = failure_excerpt(done.stdout + done.stderr)
    assert "ValueError: the robot is not where expected" in excerpt, excerpt
    for name in CHAPTERS:  # the other chapters ran to their end
        assert (tmp_path / "seen" / f"domain-{name}").exists(), name
