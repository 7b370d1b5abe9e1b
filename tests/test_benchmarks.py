"""`make bench` always reports: a failing figure is recorded, the others still run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import benchmarks
from benchmarks.__main__ import main

FINE = """
from benchmarks import Figure


def run():
    return [Figure("fine figure", 1.5, "s")]
"""

BROKEN = """
from benchmarks import Figure


def run():
    yield Figure("measured before the failure", 2.0, "ms")
    raise RuntimeError("the publisher never appeared")
"""


@pytest.fixture
def extra_benchmarks(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Two benchmark topics beside the real ones: one that works, one that fails."""
    folder = tmp_path / "more_benchmarks"
    folder.mkdir()
    (folder / "bench_zz_fine.py").write_text(FINE)
    (folder / "bench_zz_broken.py").write_text(BROKEN)
    monkeypatch.setattr(benchmarks, "__path__", [*benchmarks.__path__, str(folder)])
    return tmp_path / "bench.json"


def test_bench_writes_json_and_fails_when_one_figure_fails(
    extra_benchmarks: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["zz_broken", "zz_fine"], output=extra_benchmarks)
    assert code == 1
    records = {r["name"]: r for r in json.loads(extra_benchmarks.read_text())}
    assert records["fine figure"]["value"] == 1.5
    assert records["measured before the failure"]["value"] == 2.0
    failed = records["zz_broken: failed"]
    assert failed["value"] is None
    assert failed["error"] == "RuntimeError: the publisher never appeared"
    out = capsys.readouterr()
    assert "FAILED" in out.out and "the publisher never appeared" in out.out
    assert "zz_broken" in out.err


def test_bench_rerun_replaces_a_topics_failure(extra_benchmarks: Path) -> None:
    main(["zz_broken"], output=extra_benchmarks)
    assert main(["zz_fine"], output=extra_benchmarks) == 0
    names = {r["name"] for r in json.loads(extra_benchmarks.read_text())}
    assert names == {"fine figure", "measured before the failure", "zz_broken: failed"}
    # the broken topic run again keeps one failure record, not two
    main(["zz_broken"], output=extra_benchmarks)
    records = json.loads(extra_benchmarks.read_text())
    assert [r["name"] for r in records].count("zz_broken: failed") == 1
