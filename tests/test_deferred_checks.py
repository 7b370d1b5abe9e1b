"""When grading, a judged test cell's checks do not run in the student's kernel.

The grader decides the cell outside the kernel (the judge) and runs
``verdicts.defer_next_cell`` silently in the kernel just before the cell: the cell's checks
then raise ``CheckDeferred`` at once, so their heavy work (processes, nodes, spinning)
happens once per submission, in the judge. Only that cell is deferred.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from autograder.verdicts import defer_next_cell
from rosbook.runtime.kernels import UnixSocketKernelManager

#: The notebook's set-up cell, as lab 1's.
SETUP = "from pathlib import Path\nfrom rosbook.labs import lab01 as checks"
#: A "script" whose only effect is a file: proof that a check started it.
MARKER = "from pathlib import Path\nPath('ran').write_text('yes')\n"


@pytest.fixture
def kernel(tmp_path: Path) -> Any:
    (tmp_path / "marker.py").write_text(MARKER)
    km = UnixSocketKernelManager()
    km.start_kernel(cwd=str(tmp_path))
    client = km.client()
    client.start_channels()
    try:
        client.wait_for_ready(timeout=60)
        assert run(client, SETUP)["status"] == "ok"
        yield client
    finally:
        client.stop_channels()
        km.shutdown_kernel(now=True)


def run(client: Any, source: str) -> dict[str, Any]:
    """Run ``source`` as a cell; its reply's content (status, ename, evalue)."""
    reply = client.execute_interactive(source, timeout=120, output_hook=lambda msg: None)
    return reply["content"]  # type: ignore[no-any-return]


STARTS_MARKER = (
    "with checks.run_script('marker.py') as run:\n"
    "    run.proc.wait(timeout=60)\n"
    "print(Path('ran').read_text())"
)


def test_a_deferred_cells_checks_raise_at_once_and_start_nothing(
    kernel: Any, tmp_path: Path
) -> None:
    defer_next_cell(kernel)
    built = run(kernel, "made = checks.make_node(dict, a=1)\n" + STARTS_MARKER)
    assert (built["status"], built["ename"]) == ("error", "CheckDeferred"), built
    assert "the grader checks this cell outside your notebook" in built["evalue"]
    assert not (tmp_path / "ran").exists()  # the script never started
    # make_node (the student's own constructor) still ran
    assert run(kernel, "assert made == {'a': 1}")["status"] == "ok"


def test_only_the_next_cell_is_deferred(kernel: Any, tmp_path: Path) -> None:
    """Cells after it, and any cell without the grader's call, run the checks for real
    (a student's own run and ``make check``)."""
    defer_next_cell(kernel)
    assert run(kernel, "checks.assert_sequence('s', [1], [1])")["ename"] == "CheckDeferred"
    failed = run(kernel, "checks.assert_sequence('s', [1], [2])")
    assert (failed["status"], failed["ename"]) == ("error", "CheckFailed"), failed
    # a traceback through a check (here a TypeError in it) never shows the deferral
    broken = run(kernel, "checks.assert_sequence('s', None, [1])")
    assert broken["ename"] == "TypeError" and "Deferred" not in "".join(broken["traceback"])
    assert run(kernel, STARTS_MARKER)["status"] == "ok"
    assert (tmp_path / "ran").read_text() == "yes"
