"""Feedback a student reads: nbgrader's HTML, minus hidden tests, plus plain notices."""

from __future__ import annotations

import html
import re
from pathlib import Path
from typing import Any

from nbconvert.preprocessors import Preprocessor
from nbformat import NotebookNode
from pygments.formatters import HtmlFormatter
from traitlets import Bool

_ANSI = re.compile(r"\x1b\[[0-9;]*m")


def is_test_cell(cell: NotebookNode) -> bool:
    meta = cell.get("metadata", {}).get("nbgrader", {})
    return bool(meta.get("grade")) and not meta.get("solution") and cell.cell_type == "code"


def cell_name(cell: NotebookNode, index: int) -> str:
    """A cell's ``grade_id``, else its position (``cell 3``), as grading names it."""
    return cell.get("metadata", {}).get("nbgrader", {}).get("grade_id") or f"cell {index + 1}"


class ShortenTestTracebacks(Preprocessor):  # type: ignore[misc]
    """A failing test cell shows its error message only.

    A traceback through a test cell quotes the failing line, which may be a hidden
    test; the checks' messages already say what was expected and what was seen.
    """

    enabled = Bool(True)  # nbconvert preprocessors are off unless enabled

    def preprocess_cell(
        self, cell: NotebookNode, resources: dict[str, Any], index: int
    ) -> tuple[NotebookNode, dict[str, Any]]:
        if is_test_cell(cell):
            for output in cell.get("outputs", []):
                if output.output_type == "error":
                    message = _ANSI.sub("", f"{output.ename}: {output.evalue}").rstrip(": ")
                    output.traceback = [message]
        return cell, resources


NOTICE_STYLE = (
    "margin:1em 0;padding:.8em 1em;border-left:6px solid {color};background:#fafafa;"
    "font-family:sans-serif;white-space:pre-wrap"
)
COLORS = {"ok": "#2e7d32", "timeout": "#ef6c00", "tampered": "#c62828", "grader_error": "#546e7a"}

#: The status of a submission the grader itself failed on (its sandbox or kernel did
#: not start, the grader raised): the row's message is for the instructor, the student
#: reads ``GRADER_ERROR_FEEDBACK``, and ``--resume`` grades it again.
GRADER_ERROR = "grader_error"
GRADER_ERROR_FEEDBACK = (
    "Your notebook could not be graded this time because of a problem on the grading "
    "machine, before any of your cells ran: nothing in your notebook caused it. Your "
    "instructor sees this and will grade it again."
)


def notice_html(title: str, message: str, status: str) -> str:
    style = NOTICE_STYLE.format(color=COLORS.get(status, "#c62828"))
    return (
        f'<div class="grader-notice" style="{style}"><strong>{html.escape(title)}</strong>'
        f"\n{html.escape(message)}</div>"
    )


def add_notice(feedback_html: Path, title: str, message: str, status: str) -> None:
    """Put a notice at the top of an nbgrader feedback page."""
    page = feedback_html.read_text(encoding="utf-8")
    page = re.sub(
        r"(<body[^>]*>)",
        lambda m: m.group(1) + notice_html(title, message, status),
        page,
        count=1,
    )
    feedback_html.write_text(page, encoding="utf-8")


def write_notice_page(
    path: Path, student_id: str, assignment_id: str, title: str, message: str, status: str
) -> None:
    """Feedback for a submission nbgrader could not grade (missing, broken, killed); for
    the grader's own failure the student reads ``GRADER_ERROR_FEEDBACK``, never
    ``message`` (the instructor's, in the row)."""
    message = GRADER_ERROR_FEEDBACK if status == GRADER_ERROR else message
    path.parent.mkdir(parents=True, exist_ok=True)
    heading = html.escape(f"{assignment_id}: feedback for {student_id}")
    path.write_text(
        "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
        f"<title>{heading}</title></head><body>"
        f"<h1>{heading}</h1>{notice_html(title, message, status)}</body></html>\n",
        encoding="utf-8",
    )


#: What nbgrader's feedback page lacks for readers with a screen reader, a keyboard or
#: low vision (axe-core's serious rules): links darker than its pale blue and underlined
#: (they sit in text), the list of checks' links tall enough to hit, code coloured with
#: contrast enough (Pygments' xcode style: 4.5:1 and more), the terminal colours of tracebacks
#: darkened likewise, and every scrolling block of code or output reachable by keyboard.
ACCESSIBLE_STYLE = (
    "<style>a { color: #1d4f7c; text-decoration: underline; }\n"
    "div.nbgrader_cell .panel-heading a { color: #fff; }\n"
    "#toc li { line-height: 24px; margin: 2px 0; }\n"
    "#toc a { display: inline-block; min-height: 24px; }\n"
    + HtmlFormatter(style="xcode").get_style_defs(".highlight")
    + "\n.ansi-black-fg { color: #3e424d; } .ansi-red-fg { color: #b22b31; }"
    " .ansi-green-fg { color: #007427; } .ansi-yellow-fg { color: #8a6100; }"
    " .ansi-blue-fg { color: #0065ca; } .ansi-magenta-fg { color: #a03196; }"
    " .ansi-cyan-fg { color: #0b6f83; } pre span[style*='color'] { color: inherit !important; }"
    "</style>"
)


def accessible(page: str) -> str:
    """A feedback page in a language a screen reader can say, its links, colours and
    code blocks usable (:data:`ACCESSIBLE_STYLE`; scrolling ``<pre>`` blocks focusable)."""
    page = re.sub(r"<html(?![^>]*\blang=)", '<html lang="en"', page, count=1)
    page = page.replace("</head>", ACCESSIBLE_STYLE + "</head>", 1)
    return re.sub(r"<pre(?=[\s>])(?![^>]*\btabindex=)", '<pre tabindex="0"', page)
