"""When grading, a test cell's checks are the grader's, not the kernel's.

The grader decides each test cell outside the student's kernel (``autograder.judge``).
Just before the cell runs in the kernel, it runs ``defer_this_cell()`` there (silently):
until that cell ends, every check it calls raises ``CheckDeferred`` at once instead of
running a second time (starting nodes, spinning, building...). Each lab's checks module
ends with ``deferrable(globals())``, which makes its public functions do so. A student's
own runs and ``make check`` never call ``defer_this_cell``: there the checks run as
written. Honest code can then never pass a test cell in the kernel while grading, so a
pass there is a forged one (the grader flags it).
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from typing import Any

#: What a check called in a test cell says when the grader decides that cell itself.
DEFERRED = "deferred: the grader checks this cell outside your notebook"

#: Functions a test cell calls before its checks run: they build the student's node or
#: set the session up, and stay real when deferred (cheap, and they are the student's).
NOT_DEFERRED = frozenset({"make_node", "restore_after_checks"})

_deferring = False


class CheckDeferred(Exception):
    """Raised by a check in a test cell the grader decides outside the kernel."""

    def _render_traceback_(self) -> list[str]:
        return [f"{type(self).__name__}: {self}"]


def defer_this_cell(shell: Any | None = None) -> None:
    """Until the next cell of ``shell`` (default: the running IPython) ends, every check
    raises ``CheckDeferred`` instead of running. The grader runs this (silently) in the
    kernel just before a test cell it decides itself."""
    global _deferring
    if shell is None:
        from IPython import get_ipython

        shell = get_ipython()
    if shell is None:
        return

    def done(result: Any) -> None:
        global _deferring
        _deferring = False
        shell.events.unregister("post_run_cell", done)

    _deferring = True
    shell.events.register("post_run_cell", done)


def deferrable(namespace: dict[str, Any]) -> None:
    """Make the public functions defined in the module ``namespace`` (its ``globals()``,
    at its end) raise ``CheckDeferred`` while a cell is deferred (``defer_this_cell``)."""

    def wrap(check: Callable[..., Any]) -> Callable[..., Any]:
        @functools.wraps(check)
        def deferrable_check(*args: Any, **kwargs: Any) -> Any:
            __tracebackhide__ = True  # noqa: F841 (IPython and pytest leave this frame out)
            if _deferring:
                raise CheckDeferred(DEFERRED)
            return check(*args, **kwargs)

        return deferrable_check

    for name, value in list(namespace.items()):
        if (
            not name.startswith("_")
            and name not in NOT_DEFERRED
            and inspect.isfunction(value)
            and value.__module__ == namespace["__name__"]
        ):
            namespace[name] = wrap(value)
