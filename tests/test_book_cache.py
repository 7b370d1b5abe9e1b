"""The executed-book cache kept between test runs is keyed by what outputs depend on."""

from __future__ import annotations

from pathlib import Path

from tests.conftest import BOOK_INPUTS, book_cache_key


def tree(root: Path) -> Path:
    (root / "rosbook").mkdir(parents=True)
    (root / "rosbook" / "graph.py").write_text("PERIOD = 0.25\n")
    (root / "book").mkdir()
    (root / "book" / "chapter.md").write_text("# A chapter\n")
    for name in BOOK_INPUTS[1:]:
        (root / name).write_text(f"{name}\n")
    return root


def test_book_cache_key_changes_with_the_library_and_settings(tmp_path: Path) -> None:
    root = tree(tmp_path)
    first = book_cache_key(root)
    assert book_cache_key(root) == first, "the key must be stable"
    (root / "rosbook" / "graph.py").write_text("PERIOD = 3.0\n")
    second = book_cache_key(root)
    assert second != first, "a library change must execute every chapter again"
    (root / "_config.yml").write_text("execute: {timeout: 60}\n")
    assert book_cache_key(root) != second, "a settings change must execute every chapter again"


def test_book_cache_key_ignores_chapters_and_bytecode(tmp_path: Path) -> None:
    root = tree(tmp_path)
    first = book_cache_key(root)
    # jupyter-cache itself re-executes a chapter whose code changed
    (root / "book" / "chapter.md").write_text("# A chapter, edited\n")
    (root / "rosbook" / "__pycache__").mkdir()
    (root / "rosbook" / "__pycache__" / "graph.cpython-311.pyc").write_bytes(b"\0")
    assert book_cache_key(root) == first
