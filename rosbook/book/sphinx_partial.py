"""Sphinx extension: a build of some chapters only accepts links to the chapters it left out.

``rosbook.book.pages.build(out, chapters)`` builds a few chapters with a table of
contents of their own (a benchmark, a test of one page), as ``make book`` builds them
(``-W -n``: a warning fails it). A link from a built chapter to a chapter of the book's
own table of contents (``_toc.yml``) that this build did not read is not broken: its
warning (``myst.xref_missing``, "Unknown source document", and the ``{doc}`` role's
"unknown document") is dropped. Nothing changes
for the whole book, which reads every chapter of ``_toc.yml``; a link to a document the
book does not have still fails every build.

Enable it in ``_config.yml``: ``sphinx: extra_extensions: [rosbook.book.sphinx_partial]``.
"""

from __future__ import annotations

import logging
import re
from pathlib import Path
from typing import Any

import yaml
from sphinx.addnodes import pending_xref
from sphinx.application import Sphinx
from sphinx.domains import Domain
from sphinx.util import docname_join

#: The logger of myst-parser's cross-reference resolver (Sphinx names it "sphinx.<module>").
RESOLVER_LOGGER = "sphinx.myst_parser.sphinx_ext.myst_refs"
UNKNOWN_DOCUMENT = re.compile(r"Unknown source document '([^']+)'")


def toc_documents(toc: Path) -> set[str]:
    """Every document a ``jb-book`` table of contents lists (its root, chapters, sections)."""
    found: set[str] = set()

    def walk(entry: Any) -> None:
        if isinstance(entry, dict):
            for key, value in entry.items():
                if key in ("root", "file") and isinstance(value, str):
                    found.add(value.removesuffix(".md").removesuffix(".ipynb"))
                else:
                    walk(value)
        elif isinstance(entry, list):
            for item in entry:
                walk(item)

    walk(yaml.safe_load(toc.read_text()))
    return found


class LeftOutChapters(logging.Filter):
    """Drops "Unknown source document" for the book's chapters this build did not read."""

    def __init__(self, app: Sphinx) -> None:
        super().__init__()
        self.app = app

    def filter(self, record: logging.LogRecord) -> bool:
        if getattr(record, "subtype", None) != "xref_missing":
            return True
        missing = UNKNOWN_DOCUMENT.search(record.getMessage())
        if missing is None:
            return True
        return not left_out(self.app, missing.group(1))


def left_out(app: Sphinx, document: str) -> bool:
    """Whether ``document`` is a chapter of the book's table of contents that this build
    did not read."""
    book = toc_documents(Path(app.srcdir) / "_toc.yml")
    return document in book and document not in app.env.all_docs


def doc_role_to_left_out(app: Sphinx, domain: Domain | None, node: pending_xref) -> bool | None:
    """``warn-missing-reference``: True (no warning) for a ``{doc}`` link to a chapter
    this build left out."""
    if node.get("reftype") != "doc":
        return None
    document = docname_join(node.get("refdoc", ""), node.get("reftarget", ""))
    return True if left_out(app, document) else None


def setup(app: Sphinx) -> dict[str, Any]:
    if (Path(app.srcdir) / "_toc.yml").exists():
        logging.getLogger(RESOLVER_LOGGER).addFilter(LeftOutChapters(app))
        app.connect("warn-missing-reference", doc_role_to_left_out)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
