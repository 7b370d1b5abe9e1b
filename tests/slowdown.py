"""A slow machine for one test: what it runs gets a quarter of one core.

The tests that prove "correctness never depends on machine speed" run their command on a
slow machine: a cgroup whose CPU quota is ``SLOW_CPUS`` of one core, shared by the command
and everything it starts (a grader's sandboxes are made inside it, and held to it too).
That is slower than beside busy processes (two per core leave a lone command about 0.4
of a core on 2 cores), and it costs the machine nothing: the quota makes the command wait,
where busy loops burned both cores for the test's whole length and slowed every other test
of the run. Where no cgroup can be made (not root, no delegation: ``autograder.cgroups``),
the machine is loaded with two busy processes per core instead, as ``make stress`` does.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

from autograder import cgroups
from rosbook.runtime.stress import busy_processes, cores

#: The CPU a slow machine gives the test's command and all it starts (of one core).
SLOW_CPUS = 0.25


@contextmanager
def slow_machine() -> Iterator[Callable[[], None] | None]:
    """A slow machine for the block: yields the ``preexec_fn`` that puts a child process in
    it (None where busy processes load the whole machine instead)."""
    group = cgroups.create("slow-machine", cpus=SLOW_CPUS, ram=1 << 40, processes=1 << 20)
    if group is None:
        with busy_processes(2 * cores()):
            yield None
        return
    inside = [str(d) for d in group.directories()]
    try:
        yield lambda: cgroups.join(inside)
    finally:
        group.remove()  # with what a grader made inside it
