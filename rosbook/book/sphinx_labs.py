"""Sphinx extension: one page per lab, made at build time from the released notebook.

A lab's page in the book is ``book/labs/<lab>.md``: a few lines written by hand (the
chapters the lab builds on), read by Sphinx as the body of a page whose every other
line comes from ``labs/<lab>/<lab>.ipynb``, the notebook students get: its text (the
contract table, each task), its visible code cells as they are released (the code to
complete, the try-it cells) and, for each graded cell, what it checks and its points.
The page is made while Sphinx reads it, so it never drifts from the lab.

The page ``book/labs.md`` gets a link to every lab's page.

The released notebook holds neither solutions nor hidden tests (``make labs`` strips
them); a page that would show one fails the build. A lab in ``labs/`` without a page in
the table of contents is a warning, which ``-W`` makes the build's failure.

Enable it in ``_config.yml``: ``sphinx: extra_extensions: [rosbook.book.sphinx_labs]``.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path
from typing import Any

import nbformat
from sphinx.application import Sphinx
from sphinx.environment import BuildEnvironment
from sphinx.util import logging

from rosbook.book.sphinx_partial import toc_documents

logger = logging.getLogger(__name__)

#: The folder of the lab pages, relative to the book's source folder (docnames).
PAGES = "book/labs"
#: The released labs, relative to the book's source folder.
RELEASED = "labs"
#: What a released notebook must never hold: nbgrader's solution and hidden-test markers.
NEVER_SHOWN = ("### BEGIN SOLUTION", "### BEGIN HIDDEN TESTS")


def released_notebook(srcdir: Path, lab: str) -> Path:
    """The notebook students get for ``lab``."""
    return srcdir / RELEASED / lab / f"{lab}.ipynb"


def released_labs(srcdir: Path) -> list[str]:
    """Every released lab, in order."""
    folder = srcdir / RELEASED
    return sorted(p.name for p in folder.iterdir() if released_notebook(srcdir, p.name).is_file())


def _nbgrader(cell: nbformat.NotebookNode) -> dict[str, Any]:
    return dict(cell.get("metadata", {}).get("nbgrader", {}))


def _check_says(source: str) -> str:
    """What a graded cell checks: its docstring (the first line of its source)."""
    try:
        tree = ast.parse("\n".join(ln for ln in source.splitlines() if not ln.startswith("%")))
        said = ast.get_docstring(tree)
    except SyntaxError:
        said = None
    return " ".join((said or "").split())


def _fence(source: str) -> str:
    """A code cell as a MyST code block, its fence longer than any backtick run in it."""
    longest = max((len(run) for run in re.findall("`+", source)), default=0)
    ticks = "`" * max(3, longest + 1)
    return f"{ticks}ipython3\n{source.rstrip()}\n{ticks}"


def lab_page(notebook: nbformat.NotebookNode, lab: str, written: str) -> str:
    """The MyST markdown of ``lab``'s page: the notebook's first cell (its title,
    introduction and contract), the hand-written lines ``written``, then each cell.

    Raises ``ValueError`` if a cell holds a solution or a hidden test."""
    parts: list[str] = []
    graded: list[tuple[str, float]] = []
    for index, cell in enumerate(notebook.cells):
        shown = [marker for marker in NEVER_SHOWN if marker in cell.source]
        if shown:
            raise ValueError(f"{lab}: cell {index} of the released notebook holds {shown[0]!r}")
        meta = _nbgrader(cell)
        if cell.cell_type == "markdown":
            parts.append(cell.source.strip())
        elif cell.cell_type == "code" and meta.get("grade") and not meta.get("solution"):
            points = float(meta.get("points") or 0)
            graded.append((meta["grade_id"], points))
            parts.append(
                f":::{{admonition}} Graded check `{meta['grade_id']}` ({points:g} points)\n"
                f":class: note\n\n{_check_says(cell.source) or 'A check of this task.'}\n:::"
            )
        elif cell.cell_type == "code" and cell.source.strip():
            answer = "Complete this cell. " if meta.get("solution") else ""
            if answer:
                parts.append(f"{answer}(`{meta['grade_id']}`)")
            parts.append(_fence(cell.source))
        if index == 0:
            parts.append(written.strip())
    total = sum(points for _, points in graded)
    parts.append(
        "## What is graded\n\n"
        "| check | points |\n|---|---|\n"
        + "".join(f"| `{gid}` | {points:g} |\n" for gid, points in graded)
        + f"| total | {total:g} |\n\n"
        "Each check above runs in the notebook as you see it; when the lab is graded, "
        "hidden checks of the same tasks run too, with other parameters."
    )
    return "\n\n".join(part for part in parts if part) + "\n"


def make_lab_page(app: Sphinx, docname: str, source: list[str]) -> None:
    """While Sphinx reads ``book/labs/<lab>``: the page made from the lab's notebook;
    reading ``book/labs`` (the labs' own page): a link to every lab's page."""
    if docname == PAGES:
        source[0] += (
            "".join(f"\n- {{doc}}`labs/{lab}`" for lab in released_labs(Path(app.srcdir))) + "\n"
        )
        return
    folder, _, lab = docname.rpartition("/")
    if folder != PAGES:
        return
    path = released_notebook(Path(app.srcdir), lab)
    if not path.is_file():
        logger.warning(f"{docname}: no released lab at {path} (make labs generates it)")
        return
    app.env.note_dependency(str(path))
    notebook = nbformat.read(path, as_version=4)
    source[0] = lab_page(notebook, lab, source[0])


def every_lab_has_a_page(app: Sphinx, env: BuildEnvironment) -> None:
    """Once every page is read: warn about a released lab whose page is not in the book
    (the table of contents, which a build of some chapters only does not read whole)."""
    book = toc_documents(Path(app.srcdir) / "_toc.yml") | set(env.found_docs)
    pages = {name.rpartition("/")[2] for name in book if name.startswith(PAGES + "/")}
    for lab in released_labs(Path(app.srcdir)):
        if lab not in pages:
            logger.warning(f"lab {lab} has no page: add {PAGES}/{lab}.md and list it in _toc.yml")


def setup(app: Sphinx) -> dict[str, Any]:
    app.connect("source-read", make_lab_page)
    app.connect("env-updated", every_lab_has_a_page)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
