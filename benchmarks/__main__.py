"""Run the benchmarks: ``python -m benchmarks [--quick] [--output PATH] [topic ...]``.

Every topic runs, whatever the others do: a topic whose ``run()`` raises is reported
as failed with its error (the figures it yielded before failing are kept), the table
and ``_build/bench.json`` are still written, and the command exits 1.
"""

from __future__ import annotations

import importlib
import json
import os
import pkgutil
import sys
import time
import traceback
from dataclasses import asdict
from pathlib import Path
from typing import Any

import benchmarks

OUTPUT = Path(__file__).resolve().parent.parent / "_build" / "bench.json"
#: Where quick mode's figures go (never mixed with the real ones).
QUICK_OUTPUT = OUTPUT.with_name("bench-quick.json")


def topics() -> list[str]:
    return sorted(
        m.name.removeprefix("bench_")
        for m in pkgutil.iter_modules(benchmarks.__path__)
        if m.name.startswith("bench_")
    )


def failure(topic: str, error: BaseException) -> dict[str, Any]:
    """The record of a topic that failed: its name, no value, and the error."""
    return {
        "name": f"{topic}: failed",
        "value": None,
        "unit": "",
        "topic": topic,
        "error": "".join(traceback.format_exception_only(type(error), error)).strip(),
    }


def run_topic(topic: str) -> list[dict[str, Any]]:
    """The records of one topic: its figures, and a failure record if it raised."""
    records: list[dict[str, Any]] = []
    start = time.monotonic()
    try:
        module = importlib.import_module(f"benchmarks.bench_{topic}")
        for figure in module.run():
            print(f"   {figure.name:<48} {figure.value:>12.4g} {figure.unit}", flush=True)
            records.append(dict(asdict(figure), topic=topic))
    except Exception as error:  # noqa: BLE001 - any failure is reported, the others still run
        traceback.print_exc()
        records.append(failure(topic, error))
        print(f"   FAILED after {time.monotonic() - start:.0f} s: {records[-1]['error']}")
    return records


def show(record: dict[str, Any]) -> str:
    if record.get("error"):
        return f"{record['name']:<51} {'FAILED':>12} {record['error'].splitlines()[-1]}"
    return f"{record['name']:<51} {record['value']:>12.4g} {record['unit']}"


def main(argv: list[str], output: Path | None = None) -> int:
    if "--quick" in argv:
        argv = [a for a in argv if a != "--quick"]
        os.environ[benchmarks.QUICK_ENV] = "1"
    if "--output" in argv:  # --output PATH: where the figures go
        at = argv.index("--output")
        output, argv = Path(argv[at + 1]), argv[:at] + argv[at + 2 :]
    output = output or (QUICK_OUTPUT if benchmarks.quick() else OUTPUT)
    chosen = argv or topics()
    unknown = sorted(set(chosen) - set(topics()))
    if unknown:
        print(f"unknown benchmark(s) {unknown}; there are: {topics()}", file=sys.stderr)
        return 2
    records: list[dict[str, Any]] = []
    for topic in chosen:
        print(f"-- {topic}", flush=True)
        records += run_topic(topic)
    output.parent.mkdir(parents=True, exist_ok=True)
    previous = json.loads(output.read_text()) if output.exists() and argv else []
    names = {r["name"] for r in records}
    kept = [r for r in previous if r["name"] not in names and r.get("topic") not in chosen]
    merged = kept + records
    output.write_text(json.dumps(merged, indent=1) + "\n")
    print(f"\n{'figure':<51} {'value':>12} unit")
    for record in merged:
        print(show(record))
    print(f"written to {output}")
    failed = [r["topic"] for r in records if r.get("error")]
    if failed:
        print(f"{len(failed)} benchmark topic(s) failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
