"""Performance figures of the project (``make bench``).

Each ``benchmarks/bench_<topic>.py`` defines ``run() -> list[Figure]``. ``python -m
benchmarks`` runs them all (or those named on the command line), prints a table and
writes every figure to ``_build/bench.json`` as a list of ``{"name", "value", "unit",
"topic"}``. A topic that raises is recorded as ``{"name": "<topic>: failed", "value":
null, "error": ...}``, the other topics still run, and the command exits 1. ``run()`` may
be a generator: the figures it yielded before an error are kept.
Targets are stated in each figure's name or docstring, never asserted by tests.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Figure:
    name: str
    value: float
    unit: str
