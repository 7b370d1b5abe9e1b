"""The README is a front page: short, with the two commands, every command it names a
real Makefile target, and every link one a reader can open."""

from __future__ import annotations

import re
from urllib.parse import urlsplit

from autograder.config import ROOT

README = ROOT / "README.md"
#: About 6 KB: what a newcomer reads in two minutes.
BUDGET_BYTES = 6_500
#: The commands the README must name: build the book, run the tests.
TWO_COMMANDS = ("make book", "make test")


def test_the_readme_stays_under_its_budget() -> None:
    size = len(README.read_bytes())
    assert size <= BUDGET_BYTES, (
        f"README.md is {size} bytes, over its budget of {BUDGET_BYTES}: move guides to the "
        "book, contributor notes to CONTRIBUTING.md"
    )


def test_the_readme_names_the_two_commands_in_a_code_block() -> None:
    blocks = "\n".join(re.findall(r"```console\n(.*?)```", README.read_text(), re.S))
    for command in TWO_COMMANDS:
        assert re.search(rf"^{command}(\s|$)", blocks, re.M), f"README.md lost `{command}`"


def test_every_make_command_in_the_readme_is_a_makefile_target() -> None:
    targets = set(re.findall(r"^([\w.-]+):", (ROOT / "Makefile").read_text(), re.M))
    named = set(re.findall(r"\bmake ([a-z][\w-]*)", README.read_text()))
    assert {"book", "test"} <= named
    assert named <= targets, f"the README names make targets that do not exist: {named - targets}"


def test_every_link_in_the_readme_opens_a_file_of_the_repository() -> None:
    links = re.findall(r"\]\(([^)]+)\)", README.read_text())
    assert links, "the README links to nothing: a newcomer finds no guide"
    local = [link for link in links if not urlsplit(link).scheme]
    missing = [link for link in local if not (ROOT / urlsplit(link).path).exists()]
    assert not missing, f"README.md links to files that do not exist: {missing}"
