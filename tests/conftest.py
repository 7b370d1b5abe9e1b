"""Every test run is isolated in a ROS domain of its own, even when pytest is run by hand."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from rosbook import bookpages
from rosbook.isolation import isolated_environ
from rosbook.session import Session, ros


@pytest.fixture(scope="session", autouse=True)
def ros_domain() -> Iterator[int]:
    """A domain of this run's own, set before rclpy is first initialised."""
    with isolated_environ() as domain_id:
        yield domain_id
    ros.shutdown()


@pytest.fixture
def session() -> Iterator[Session]:
    """The notebook session, initialised on wall time; its nodes are destroyed after."""
    ros.init()
    yield ros
    ros.reset()


@pytest.fixture(scope="session")
def built_book(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The whole book built once per test run, as `make book` builds it, from a fresh
    cache (so every cell runs) in a ROS domain of its own. Returns `_build/html`."""
    return bookpages.build(tmp_path_factory.mktemp("book"))
