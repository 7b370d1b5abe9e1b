"""Run the benchmarks: ``python -m benchmarks [topic ...]``."""

from __future__ import annotations

import importlib
import json
import pkgutil
import sys
from dataclasses import asdict
from pathlib import Path

import benchmarks
from benchmarks import Figure

OUTPUT = Path(__file__).resolve().parent.parent / "_build" / "bench.json"


def topics() -> list[str]:
    return sorted(
        m.name.removeprefix("bench_")
        for m in pkgutil.iter_modules(benchmarks.__path__)
        if m.name.startswith("bench_")
    )


def main(argv: list[str]) -> int:
    chosen = argv or topics()
    unknown = sorted(set(chosen) - set(topics()))
    if unknown:
        print(f"unknown benchmark(s) {unknown}; there are: {topics()}", file=sys.stderr)
        return 2
    figures: list[Figure] = []
    for topic in chosen:
        module = importlib.import_module(f"benchmarks.bench_{topic}")
        print(f"-- {topic}", flush=True)
        for figure in module.run():
            print(f"   {figure.name:<48} {figure.value:>12.4g} {figure.unit}", flush=True)
            figures.append(figure)
    OUTPUT.parent.mkdir(parents=True, exist_ok=True)
    previous = json.loads(OUTPUT.read_text()) if OUTPUT.exists() and argv else []
    names = {f.name for f in figures}
    merged = [f for f in previous if f["name"] not in names] + [asdict(f) for f in figures]
    OUTPUT.write_text(json.dumps(merged, indent=1) + "\n")
    print(f"\n{'figure':<51} {'value':>12} unit")
    for f in merged:
        print(f"{f['name']:<51} {f['value']:>12.4g} {f['unit']}")
    print(f"written to {OUTPUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
