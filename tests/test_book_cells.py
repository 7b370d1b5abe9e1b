"""The book's hidden cells only assert: a reader who runs the visible cells alone gets
the same session (nodes, time source, files) as the build that executed them all."""

from __future__ import annotations

import re
from pathlib import Path

BOOK = Path(__file__).resolve().parent.parent / "book"

#: A cell with one of these tags is not shown in the HTML book.
HIDDEN_TAGS = ("remove-cell", "remove-input", "hide-cell", "hide-input")
#: Statements that change the session or the disk rather than check something.
STATE_CHANGES = re.compile(
    r"^(ros\.(reset|remove|shutdown|init|sim_clock)\(|rclpy\.(init|shutdown|try_shutdown)\("
    r"|\w+\.destroy(_node)?\(\)|shutil\.rmtree\()"
)


def hidden_cells(text: str) -> list[tuple[int, str]]:
    """(line, source) of every code cell whose tags hide it."""
    cells = []
    for match in re.finditer(r"```\{code-cell\}[^\n]*\n(.*?)```", text, re.S):
        body = match.group(1)
        tags = re.match(r":tags: \[([^\]]*)\]\n", body)
        if tags and any(tag in tags.group(1) for tag in HIDDEN_TAGS):
            cells.append((text[: match.start()].count("\n") + 1, body))
    return cells


def state_changes(source: str) -> list[str]:
    return [line for line in source.splitlines() if STATE_CHANGES.match(line)]


def test_hidden_cells_of_the_book_change_no_state() -> None:
    found = [
        f"{chapter.name}:{line}: {change}"
        for chapter in sorted(BOOK.glob("*.md"))
        for line, source in hidden_cells(chapter.read_text())
        for change in state_changes(source)
    ]
    assert found == [], "hidden cells that change state (make them visible):\n" + "\n".join(found)


def test_the_scan_finds_a_state_change_in_a_hidden_cell() -> None:
    chapter = (
        "```{code-cell} ipython3\n:tags: [remove-cell]\nassert x == 1\nros.reset()\n```\n"
        "```{code-cell} ipython3\nros.shutdown()\n```\n"
    )
    assert [state_changes(source) for _, source in hidden_cells(chapter)] == [["ros.reset()"]]
