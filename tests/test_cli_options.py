"""Every option upstream's ``ros2`` offers for the verbs this project ships is accepted here,
with the same flags, and every command exists (upstream's table: ``tests/ros2_upstream.py``,
read from ros2/ros2cli's jazzy branch)."""

from __future__ import annotations

import argparse

import pytest

from rosbook.cli import build_parser
from tests.ros2_upstream import UPSTREAM, VERB_OPTIONS


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _options(parser: argparse.ArgumentParser) -> set[frozenset[str]]:
    return {
        frozenset(a.option_strings)
        for a in parser._actions
        if a.option_strings and not isinstance(a, argparse._HelpAction)
    }


def _positionals(parser: argparse.ArgumentParser) -> list[str]:
    return [
        a.dest
        for a in parser._actions
        if not a.option_strings and not isinstance(a, argparse._SubParsersAction)
    ]


VERBS = _subparsers(build_parser())


@pytest.mark.parametrize("verb", sorted(VERB_OPTIONS))
def test_each_upstream_command_of_a_shipped_verb_exists(verb: str) -> None:
    upstream = {command for v, command in UPSTREAM if v == verb}
    assert upstream <= set(_subparsers(VERBS[verb])), upstream - set(_subparsers(VERBS[verb]))


@pytest.mark.parametrize("verb", sorted(VERB_OPTIONS))
def test_verb_level_options_are_upstreams(verb: str) -> None:
    ours = _options(VERBS[verb])
    missing = [o for o in VERB_OPTIONS[verb] if frozenset(o.split()) not in ours]
    assert not missing, f"ros2 {verb}: missing {missing}"


@pytest.mark.parametrize("verb_command", sorted(UPSTREAM), ids=" ".join)
def test_every_upstream_option_is_accepted_with_the_same_flags(
    verb_command: tuple[str, str],
) -> None:
    verb, command = verb_command
    parser = _subparsers(VERBS[verb])[command]
    positionals, options = UPSTREAM[verb_command]
    ours = _options(parser)
    missing = [o for o in options if frozenset(o.split()) not in ours]
    assert not missing, f"ros2 {verb} {command}: missing or spelled otherwise: {missing}"
    assert _positionals(parser) == list(positionals), f"ros2 {verb} {command}: positionals"
