"""Before grading (or a self-check, or a lab server) starts: can a kernel run here?

A grading run whose sandbox cannot start, or whose kernel cannot import the project,
would grade a whole class as errors. ``check`` finds that out once, before the first
submission: it starts a process in a sandbox exactly as a kernel's starts
(``sandbox.prepare`` with a private folder where kernels get theirs, a seed folder and a
shared folder where grading makes them), has it import what a kernel imports
(``sandbox.probe``), and raises ``NotReady`` with one message naming the cause and the
fix: the folder the sandbox's user cannot enter, the module it cannot import (a venv
installed from another checkout), or missing user namespaces.

``check(sandboxed=False)`` checks only the import, in an unsandboxed process as
``make lab``'s kernels are. A course server's spawner calls ``once()`` before each start
(the probe runs the first time only).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path

from autograder import sandbox

#: A hang guard for the probe (it takes about a second): hitting it says "timeout".
PROBE_TIMEOUT = 120.0
#: The probe's command: what a kernel imports, where it comes from.
PROBE = [sys.executable, "-I", "-m", "autograder.sandbox", "probe"]
#: bwrap's words for a folder it cannot reach.
_NO_SOURCE = re.compile(r"Can't find source path (\S+): (.+)")


class NotReady(RuntimeError):
    """Kernels cannot run here; the message names the cause and the fix."""


def check(env: Mapping[str, str] | None = None, sandboxed: bool = True) -> float:
    """Raise ``NotReady`` unless a kernel can start here and import the project; the
    seconds it took. ``env``: the run's environment besides this process's."""
    started = time.monotonic()
    full = {**os.environ, **(env or {})}
    if sandboxed:
        found = _probe_sandboxed(full)
    else:
        found = _probe_plain(full)
    _check_imports(found, "the sandboxed kernel" if sandboxed else "the kernel")
    return time.monotonic() - started


def _probe_plain(env: Mapping[str, str]) -> dict[str, str]:
    done = subprocess.run(
        PROBE, cwd="/", env=dict(env), capture_output=True, timeout=PROBE_TIMEOUT, check=False
    )
    return _parse(done.returncode, done.stdout, done.stderr, "the kernel's Python")


def _probe_sandboxed(env: Mapping[str, str]) -> dict[str, str]:
    try:
        base = sandbox.staging_base()
        sandbox.bwrap()
    except sandbox.SandboxUnavailable as exc:
        raise NotReady(f"Cannot grade here: {exc}") from None
    private = Path(tempfile.mkdtemp(prefix="rosbook-preflight-", dir=base))
    # the seed and the shared folder are where grading makes them: the temporary folder
    outside = Path(tempfile.mkdtemp(prefix="rosbook-preflight-"))
    try:
        seed = outside / "seed"
        seed.mkdir()
        (seed / "data.txt").write_text("seed\n")
        shared = outside / "shared"
        shared.mkdir()
        env = {**env, sandbox.SHARED_ENV: str(shared)}
        with sandbox.Network() as network:
            launch = sandbox.prepare(
                PROBE, network=network, private=private, env=env, seed=seed, label="preflight"
            )
            try:
                proc, _ = sandbox.start(launch, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
            except sandbox.SandboxUnavailable as exc:
                raise NotReady(_explain_bwrap(str(exc))) from None
            try:
                out, err = proc.communicate(timeout=PROBE_TIMEOUT)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.communicate()
                raise NotReady(
                    f"Cannot grade here: timeout: the sandboxed probe did not end within "
                    f"{PROBE_TIMEOUT:g} s"
                ) from None
    except sandbox.SandboxUnavailable as exc:
        raise NotReady(f"Cannot grade here: {exc}") from None
    finally:
        shutil.rmtree(private, ignore_errors=True)
        shutil.rmtree(outside, ignore_errors=True)
    return _parse(proc.returncode, out, err, "the sandboxed kernel")


def _explain_bwrap(said: str) -> str:
    """One message for a sandbox that did not start: the folder, or user namespaces."""
    missing = _NO_SOURCE.search(said)
    if missing is None:
        return f"Cannot grade here: {said}"
    path = Path(missing.group(1))
    blocked = sandbox.blocking_folder(path) if sandbox._as_root() else None
    where = f"{blocked}, on the way to {path}" if blocked else str(path)
    fix = f"`chmod o+x {blocked}`" if blocked else "make it readable by the grader's user"
    return (
        f"Cannot grade here: the sandbox's user cannot enter {where} ({missing.group(2)}). "
        f"Fix: {fix}, or set TMPDIR to a folder every user can enter (e.g. TMPDIR=/tmp)."
    )


def _parse(code: int, out: bytes, err: bytes, who: str) -> dict[str, str]:
    lines = out.decode(errors="replace").strip().splitlines()
    try:
        found = json.loads(lines[-1]) if code == 0 and lines else None
    except ValueError:
        found = None
    if not isinstance(found, dict):
        said = err.decode(errors="replace").strip().splitlines()
        last = said[-1] if said else f"exit code {code}, no message"
        bwrap_said = next((line for line in said if line.startswith("bwrap:")), None)
        if bwrap_said:
            raise NotReady(_explain_bwrap(bwrap_said))
        module = re.search(r"No module named '([^']+)'", last)
        if module:
            found = {module.group(1).split(".")[0]: f"!{last}"}
        else:
            raise NotReady(f"Cannot grade here: {who} could not start: {last}")
    return found


def _where_installed(module: str) -> str:
    """Where this venv's Python imports ``module`` from outside any sandbox, or why not."""
    done = subprocess.run(
        PROBE, cwd="/", env=dict(os.environ), capture_output=True, timeout=PROBE_TIMEOUT
    )
    lines = done.stdout.decode(errors="replace").strip().splitlines()
    try:
        found = json.loads(lines[-1]) if lines else {}
    except ValueError:
        return "?"
    top = module.split(".")[0]
    return next((str(v) for k, v in found.items() if k.split(".")[0] == top), "?")


def _check_imports(found: Mapping[str, str], who: str) -> None:
    root = str(sandbox.ROOT)
    for module in ("autograder", *sandbox.PROBED):
        if module not in found:
            continue
        where = found[module]
        top = module.split(".")[0]
        if where.startswith("!") or not (top == "ipykernel" or where.startswith(root + os.sep)):
            installed = where if not where.startswith("!") else _where_installed(module)
            elsewhere = (
                f"this venv's Python ({sys.prefix}) imports it from {installed}"
                if not installed.startswith("!") and installed != "?"
                else f"this venv's Python ({sys.prefix}) cannot import it ({installed.lstrip('!')})"
            )
            fix = (
                f"`make .venv/.installed` in {root} (its editable install of this checkout)"
                if top != "ipykernel"
                else "`make .venv/.installed`"
            )
            raise NotReady(
                f"Cannot grade here: {who} cannot import {module} from this checkout "
                f"({root}): {elsewhere}. Fix: {fix}."
            )


_ready: list[float] = []


def once(env: Mapping[str, str] | None = None) -> float:
    """``check``, the first time in this process only (a course server's spawner calls it
    before each start): raises ``NotReady`` until a check has passed."""
    if not _ready:
        _ready.append(check(env))
    return _ready[0]
