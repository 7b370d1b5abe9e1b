"""The book and the labs show only ``ros2`` commands and options a full Jazzy install has,
unless the page marks them as this book's addition.

A student copies what a page shows to a terminal of a full install: an option only this
book's ``ros2`` has would end in an argparse error there. Every ``ros2`` command a page
shows is read (``!ros2 ...`` lines and ``ros2('verb', ...)`` calls in code cells,
```ros2 ...``` spans in text) and checked against upstream's options
(``tests/ros2_upstream.py``). A paragraph, a table row or a code cell that says
"this book's addition" (or "an addition of this book") marks the additions it shows.
"""

from __future__ import annotations

import ast
import json
import re
import shlex
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.ros2_upstream import OTHER_VERBS, UPSTREAM, upstream_flags

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted(
    [*ROOT.glob("book/*.md"), *ROOT.glob("labs/*/*.ipynb"), *ROOT.glob("solutions/*/*.ipynb")]
)
#: What marks an addition on a page (in the same paragraph, table row or code cell); in a
#: shell line's comment, the second spelling (an apostrophe there upsets Pygments).
MARK = re.compile(r"this book's addition|an addition of this book")
#: Shell tokens that end a command.
ENDS = {";", "|", "||", "&&", ">", "2>", "&"}


def blocks(path: Path) -> Iterator[tuple[str, str]]:
    """The page's paragraphs and table rows (``"text"``) and code cells (``"code"``)."""
    if path.suffix == ".ipynb":
        cells = [
            ("code" if c["cell_type"] == "code" else "text", "".join(c["source"]))
            for c in json.loads(path.read_text())["cells"]
        ]
    else:
        parts = re.split(r"(```\{code-cell\}[^\n]*\n.*?\n```)", path.read_text(), flags=re.S)
        cells = [
            ("code", _cell_source(p)) if p.startswith("```{code-cell}") else ("text", p)
            for p in parts
        ]
    for kind, source in cells:
        if kind == "code":
            yield kind, source
            continue
        for paragraph in re.split(r"\n\s*\n", source):
            if paragraph.lstrip().startswith("|"):
                yield from (("text", row) for row in paragraph.splitlines())
            else:
                yield "text", paragraph


def _cell_source(fenced: str) -> str:
    """A MyST code cell's code: without its fences and its options (``:tags:``, ``---``)."""
    lines = fenced.splitlines()[1:-1]
    if lines and lines[0] == "---":
        lines = lines[lines.index("---", 1) + 1 :]
    while lines and lines[0].startswith(":"):
        lines = lines[1:]
    return "\n".join(lines)


def commands(kind: str, text: str) -> Iterator[list[str]]:
    """The ``ros2`` command lines a block shows, as argument lists (after ``ros2``)."""
    lines = [text] if kind == "text" else []
    if kind == "code":
        shell = [line for line in text.splitlines() if line.lstrip()[:1] in ("!", "%")]
        lines = [line.split("!", 1)[1] for line in shell if "!ros2 " in line]
        python = "\n".join(
            line[: len(line) - len(line.lstrip())] + "pass" if line in shell else line
            for line in text.splitlines()
        )
        try:
            tree = ast.parse(python)
        except SyntaxError:  # cell magics: only the shell lines are read
            tree = ast.parse("")
        for call in ast.walk(tree):
            name = getattr(call, "func", None)
            if (
                isinstance(call, ast.Call)
                and getattr(name, "id", getattr(name, "attr", "")) == "ros2"
            ):
                yield [a.value for a in call.args if isinstance(a, ast.Constant)]
    for line in lines:
        spans = re.findall(r"`(ros2 [^`]+)`", line) if kind == "text" else [line]
        for span in spans:
            try:
                tokens = shlex.split(span.replace("\n", " "))
            except ValueError:  # an unfinished quote in prose
                tokens = span.split()
            args = []
            for token in tokens[1:]:
                if token in ENDS:
                    break
                args.append(token.rstrip(";"))
                if token.endswith(";"):
                    break
            yield args


def problems(args: list[str]) -> Iterator[str]:
    """What upstream's jazzy ``ros2`` would refuse in ``ros2 ARGS``."""
    if not args or args[0].startswith("-"):
        return
    verb, rest = args[0], args[1:]
    known = {v for v, _ in (*UPSTREAM, *OTHER_VERBS)}
    if verb not in known:
        yield f"`ros2 {verb}` is not a command of upstream's ros2"
        return
    named = rest and (verb, rest[0].split("/")[0]) in {**UPSTREAM, **OTHER_VERBS}
    if (verb, "") in OTHER_VERBS and not named:
        commands_, rest = [""], rest
    elif rest and not rest[0].startswith("-"):
        commands_, rest = rest[0].split("/"), rest[1:]  # "list/get/set" in prose: each
    else:
        return  # the verb alone (prose: "`ros2 topic`")
    positionals = 0
    for token in rest:
        if token == "--ros-args" or (verb == "run" and positionals == 2):
            break  # the rest goes to the node: its ROS arguments, its own
        if not token.startswith("-") or token == "-" or re.match(r"-\d", token):
            positionals += not token.startswith("-")
            continue
        flag = token.split("=", 1)[0]
        for command in commands_:
            flags = upstream_flags(verb, command)
            if flags is None:
                yield f"`ros2 {verb} {command}` is not a command of upstream's ros2"
            elif flag not in flags:
                yield f"`ros2 {verb} {command}` has no option {flag} in upstream's ros2"
    for command in commands_:
        if upstream_flags(verb, command) is None and not any(t.startswith("-") for t in rest):
            yield f"`ros2 {verb} {command}` is not a command of upstream's ros2"


def unmarked(path: Path) -> list[str]:
    """Each command or option of ``path`` that upstream lacks, in a block not marked."""
    found = []
    for kind, text in blocks(path):
        if MARK.search(text):
            continue
        for args in commands(kind, text):
            found += [f"{' '.join(args)}: {problem}" for problem in problems(args)]
    return found


def test_the_pages_show_ros2_commands_at_all() -> None:
    """The reader below finds the commands the pages show (a guard on the reader)."""
    shown = [args for path in PAGES for kind, text in blocks(path) for args in commands(kind, text)]
    assert ["topic", "info", "-v", "/status"] in shown and len(shown) > 40, shown[:5]
    assert ["param", "set", "/rate_publisher", "rate_hz", "-3.0"] in shown


def test_an_unmarked_addition_is_found_and_a_marked_one_is_not(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text(
        "Run `ros2 topic echo -n 3 /chatter`.\n\n"
        "```{code-cell} ipython3\n!ros2 topic hz --duration 3 /chatter\n```\n\n"
        "`ros2 topic echo --once /chatter`, `ros2 graph`.\n\n"
        "`ros2 topic hz --duration 3 /x` (`--duration` is this book's addition).\n"
    )
    assert unmarked(page) == [
        "topic echo -n 3 /chatter: `ros2 topic echo` has no option -n in upstream's ros2",
        "topic hz --duration 3 /chatter: `ros2 topic hz` has no option --duration"
        " in upstream's ros2",
        "graph: `ros2 graph` is not a command of upstream's ros2",
    ]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_a_page_shows_only_upstreams_ros2_options_or_marks_them(page: Path) -> None:
    found = unmarked(page)
    assert not found, (
        f"{page.relative_to(ROOT)} shows what Jazzy's ros2 does not have; use upstream's "
        "spelling or say it is this book's addition:\n" + "\n".join(found)
    )
