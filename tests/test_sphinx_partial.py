"""A build of some chapters (a benchmark's, a page test's) accepts links to the book's
chapters it left out, and still fails on a link to a document the book does not have."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

CONF = """
extensions = ["myst_parser", "rosbook.book.sphinx_partial"]
root_doc = "intro"
exclude_patterns = ["_build", {excluded}]
"""
TOC = "format: jb-book\nroot: intro\nchapters:\n  - file: first\n  - file: second\n"


def build(tmp_path: Path, link: str, excluded: list[str]) -> subprocess.CompletedProcess[str]:
    """``sphinx-build -W -n`` of a small book whose first chapter links to ``link``."""
    src = tmp_path / "src"
    src.mkdir()
    (src / "conf.py").write_text(CONF.format(excluded=", ".join(map(repr, excluded))))
    (src / "_toc.yml").write_text(TOC)
    (src / "intro.md").write_text("# Intro\n\n```{toctree}\n:glob:\n\n*\n```\n")
    (src / "first.md").write_text(f"# First\n\nSee {link}.\n")
    (src / "second.md").write_text("# Second\n\nText.\n")
    (src / "aside.md").write_text("# Aside\n\nText.\n")
    command = [sys.executable, "-m", "sphinx", "-W", "-n", "-q", "-b", "html"]
    return subprocess.run(
        [*command, str(src), str(tmp_path / "html")],
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.mark.parametrize("link", ["[the next one](second.md)", "{doc}`second`"])
def test_a_partial_build_accepts_a_link_to_a_chapter_it_left_out(tmp_path: Path, link: str) -> None:
    done = build(tmp_path, link, excluded=["second.md"])
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize(
    ("link", "excluded", "warning"),
    [
        ("[the third](third.md)", [], "[myst.xref_missing]"),
        ("[the third](third.md)", ["second.md"], "[myst.xref_missing]"),
        ("[an aside](aside.md)", ["aside.md"], "[myst.xref_missing]"),
        ("{doc}`third`", ["second.md"], "unknown document"),
        ("{doc}`aside`", ["aside.md"], "unknown document"),
    ],
)
def test_a_link_to_a_document_the_book_does_not_have_still_fails(
    tmp_path: Path, link: str, excluded: list[str], warning: str
) -> None:
    # third.md does not exist; aside.md exists but is no chapter of the book (_toc.yml)
    done = build(tmp_path, link, excluded=excluded)
    assert done.returncode != 0
    target = "third" if "third" in link else "aside"
    assert warning in done.stderr and target in done.stderr
