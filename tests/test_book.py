"""The book builds with every cell executed, and its pages show real outputs."""

from __future__ import annotations

import html
import re
from pathlib import Path

import nbformat
import pytest
import yaml

from autograder.config import LABS, ROOT, SOLUTIONS, lab_ids
from rosbook.book.sphinx_labs import NEVER_SHOWN, PAGES, lab_page


def page_text(built_book: Path, name: str) -> str:
    raw = (built_book / "book" / f"{name}.html").read_text(encoding="utf-8")
    raw = re.sub(r"<iframe\b.*?</iframe>", "", raw, flags=re.S)
    raw = re.sub(r"<(script|style)\b.*?</\1>", "", raw, flags=re.S)
    return html.unescape(re.sub(r"<[^>]+>", "", raw))


def toc_files() -> list[str]:
    toc = yaml.safe_load((ROOT / "_toc.yml").read_text())
    files = [toc["root"]]
    for part in toc.get("parts", []):
        files += [chapter["file"] for chapter in part["chapters"]]
    return files


def test_every_chapter_in_the_toc_is_built(built_book: Path) -> None:
    for file in toc_files():
        assert (built_book / f"{file}.html").exists(), f"{file} was not built"


def test_every_book_page_is_in_the_toc() -> None:
    pages = {p.relative_to(ROOT).with_suffix("").as_posix() for p in (ROOT / "book").rglob("*.md")}
    assert pages == set(toc_files()), "a chapter in book/ is missing from _toc.yml"


def test_nodes_chapter_shows_real_log_lines_and_messages(built_book: Path) -> None:
    text = page_text(built_book, "nodes_topics_live")
    assert re.search(r"\[INFO\] \[\d{10}\.\d+\] \[talker\]: Publishing: \"Hello World: 0\"", text)
    assert re.search(r"\[listener\]: I heard: \"Hello World: \d+\"", text)
    assert "[2, 4, 6, 42]" in text
    assert "/chatter             std_msgs/msg/String" in text


def test_nodes_chapter_shows_the_jazzy_ctrl_c_failure_and_its_fix(built_book: Path) -> None:
    text = page_text(built_book, "nodes_topics_live")
    assert "exit code: 1" in text and "rcl_shutdown already called" in text
    assert "exit code: 0" in text


def test_hidden_assertion_cells_are_not_shown(built_book: Path) -> None:
    text = page_text(built_book, "nodes_topics_live")
    assert "The claims above, checked at every build" not in text


# --- the part for the people who use the course ----------------------------------------


def graded_cells(lab: str) -> dict[str, float]:
    """The released lab's graded cells: points by grade_id."""
    notebook = nbformat.read(LABS / lab / f"{lab}.ipynb", as_version=4)
    found = {}
    for cell in notebook.cells:
        meta = cell.metadata.get("nbgrader", {})
        if meta.get("grade") and not meta.get("solution"):
            found[meta["grade_id"]] = float(meta["points"])
    return found


def solution_lines(lab: str) -> list[str]:
    """Lines of the lab's answers (between the solution markers) that its release does
    not hold: what a lab's page must never show."""
    released = nbformat.read(LABS / lab / f"{lab}.ipynb", as_version=4)
    seen = "\n".join(c.source for c in released.cells)
    source = nbformat.read(SOLUTIONS / lab / f"{lab}.ipynb", as_version=4)
    secret = []
    for cell in source.cells:
        inside = False
        for line in cell.source.splitlines():
            inside = (inside or "### BEGIN SOLUTION" in line) and "### END SOLUTION" not in line
            if inside and len(line.strip()) > 25 and line.strip() not in seen:
                secret.append(line.strip())
    return secret


def test_every_lab_has_its_page_in_the_toc() -> None:
    assert lab_ids(), "no lab found: the test would prove nothing"
    missing = [lab for lab in lab_ids() if f"{PAGES}/{lab}" not in toc_files()]
    assert not missing, f"labs without a page in _toc.yml (add {PAGES}/<lab>.md): {missing}"


def test_every_lab_has_its_page_in_the_built_book(built_book: Path) -> None:
    """Each lab's page shows its title, its tasks and every graded check with its
    points, made from the released notebook; never an answer or a hidden test."""
    index = page_text(built_book, "labs")
    for lab in lab_ids():
        text = page_text(built_book, f"labs/{lab}")
        released = nbformat.read(LABS / lab / f"{lab}.ipynb", as_version=4)
        title = released.cells[0].source.splitlines()[0].lstrip("# ").strip()
        assert title in text and title in index, f"{lab}: its title {title!r}"
        for grade_id, points in graded_cells(lab).items():
            assert re.search(rf"{grade_id}\s*\({points:g} points\)", text), f"{lab}: {grade_id}"
        assert f"total\n{sum(graded_cells(lab).values()):g}" in re.sub(r"\n\s*", "\n", text)
        shown = [line for line in solution_lines(lab) if line in text]
        assert not shown and not any(marker in text for marker in NEVER_SHOWN), (lab, shown)


def test_a_lab_page_refuses_a_notebook_with_an_answer_or_a_hidden_test() -> None:
    lab = lab_ids()[0]
    notebook = nbformat.read(LABS / lab / f"{lab}.ipynb", as_version=4)
    assert "Graded check" in lab_page(notebook, lab, "")
    for marker in NEVER_SHOWN:
        leaked = nbformat.read(LABS / lab / f"{lab}.ipynb", as_version=4)
        leaked.cells[-1].source += f"\n{marker}\nanswer = 42"
        with pytest.raises(ValueError, match=re.escape(marker)):
            lab_page(leaked, lab, "")


def test_the_grading_page_shows_a_class_graded_at_build_time(built_book: Path) -> None:
    """The solution's row at full marks, the untouched release's at zero, and the
    untouched student's real feedback page embedded."""
    lab = "lab01_nodes_topics"
    total = sum(graded_cells(lab).values())
    text = page_text(built_book, "grading")
    assert f"ada,{lab},{total:g},{total:g},ok" in text, text
    assert f"ben,{lab},0,{total:g},ok" in text, text
    raw = (built_book / "book" / "grading.html").read_text(encoding="utf-8")
    frame = re.search(r'<iframe title="([^"]+)" srcdoc="([^"]+)"', raw)
    assert frame is not None and "ben" in frame.group(1)
    feedback = html.unescape(frame.group(2))
    assert f"{lab} (Score: 0.0 / {total:.1f})" in feedback, feedback[:2000]
    assert "this task is not done yet" in feedback
