"""The book builds with every cell executed, and its pages show real outputs."""

from __future__ import annotations

import html
import re
from pathlib import Path

import yaml

from autograder.config import ROOT


def page_text(built_book: Path, name: str) -> str:
    raw = (built_book / "book" / f"{name}.html").read_text(encoding="utf-8")
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
    pages = {f"book/{p.stem}" for p in (ROOT / "book").glob("*.md")}
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
