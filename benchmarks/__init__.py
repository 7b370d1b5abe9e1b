"""Performance figures of the project (``make bench``).

Each ``benchmarks/bench_<topic>.py`` defines ``run() -> list[Figure]``. ``python -m
benchmarks`` runs them all (or those named on the command line), prints a table and
writes every figure to ``_build/bench.json`` as a list of ``{"name", "value", "unit",
"topic"}``. A topic that raises is recorded as ``{"name": "<topic>: failed", "value":
null, "error": ...}``, the other topics still run, and the command exits 1. ``run()`` may
be a generator: the figures it yielded before an error are kept.
Targets are stated in each figure's name or docstring, never asserted by tests.

**Quick mode** (``python -m benchmarks --quick``, or ``ROSBOOK_BENCH_QUICK=1``): every
topic runs its whole code path at tiny sizes (``sized``), so that the test suite finds a
broken benchmark; its figures measure nothing worth keeping and go to
``_build/bench-quick.json``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TypeVar

#: Set (to 1) for quick mode.
QUICK_ENV = "ROSBOOK_BENCH_QUICK"
T = TypeVar("T")


def quick() -> bool:
    """Whether the benchmarks run in quick mode (tiny sizes)."""
    return os.environ.get(QUICK_ENV, "") not in ("", "0")


def sized(full: T, small: T) -> T:
    """``full``, or ``small`` in quick mode."""
    return small if quick() else full


@dataclass(frozen=True)
class Figure:
    name: str
    value: float
    unit: str
