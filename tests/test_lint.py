"""The code is ruff-clean: lint over packages, tests and lab notebooks; format over code."""

from __future__ import annotations

import ast
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


def test_no_test_file_imports_another() -> None:
    """What test files share lives in helper modules (CONTRIBUTING's "Tests"): importing a
    test file runs its fixtures' module and hides where a helper lives."""
    imports = []
    for path in sorted((ROOT / "tests").glob("test_*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = (
                [node.module or ""]
                if isinstance(node, ast.ImportFrom)
                else [alias.name for alias in node.names]
                if isinstance(node, ast.Import)
                else []
            )
            imports += [f"{path.name}: {n}" for n in names if n.startswith("tests.test_")]
    assert imports == []
