"""The code is ruff-clean: lint over packages, tests and lab notebooks; format over code."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from autograder.config import ROOT

RUFF = str(Path(sys.executable).parent / "ruff")
CODE = ["rosbook", "autograder", "launch", "launch_ros", "tests", "benchmarks"]


def test_ruff_lint_passes() -> None:
    result = subprocess.run(
        [RUFF, "check", *CODE, "solutions"], cwd=ROOT, capture_output=True, text=True
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_ruff_format_is_applied() -> None:
    result = subprocess.run(
        [RUFF, "format", "--check", *CODE], cwd=ROOT, capture_output=True, text=True
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_rosbook_layers_import_one_way() -> None:
    """import-linter's contracts (pyproject.toml): no layer of rosbook imports a higher one,
    and rosbook never imports the grader."""
    lint_imports = str(Path(sys.executable).parent / "lint-imports")
    result = subprocess.run([lint_imports], cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
