"""The course server (``make hub``): how soon a student works, and what one costs.

Measured in one run, with the venv and the proxy already installed (a fresh clone first
spends the venv's minute or two and the proxy's ``npm install``):

- "make hub to the hub's API": ``make hub`` started until the hub answers;
- "make hub to the first student's running kernel": until a student who logged in (in
  Chromium) has a kernel that reports idle;
- "idle student server, memory": the student's processes (the sandbox, JupyterLab, its
  relay) once JupyterLab has loaded, before any kernel: resident memory summed, and the
  proportional share (PSS: a shared library counted once across the machine); target
  150 MB.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from autograder.sandbox import process_tree
from benchmarks import Figure
from coursehub.hub import add, serve, stop
from rosbook.book.chromium import chromium_path, launch
from rosbook.runtime.isolation import child_env

STUDENT = "ada"
#: A hang guard for one step in the browser (milliseconds, as Playwright takes it).
STEP_MS = 300_000


def _kib(pid: int, field: str, file: str) -> int:
    try:
        for line in Path(f"/proc/{pid}/{file}").read_text().splitlines():
            if line.startswith(field + ":"):
                return int(line.split()[1])
    except OSError:
        pass
    return 0


def run() -> Iterator[Figure]:
    path = chromium_path()
    if path is None:
        raise RuntimeError("NO BROWSER: install Debian's chromium (apt-get install chromium)")
    state = Path(tempfile.mkdtemp(prefix="bench_hub_"))
    password = add(state / "roster.json", STUDENT)
    env = {
        **child_env(),
        "ROSBOOK_HUB_DIR": str(state),
        "ROSBOOK_HUB_LAB_ARGS": "--LabApp.expose_app_in_browser=True",
    }
    with (state / "hub.log").open("w") as log:
        start = time.monotonic()
        server, url = serve(env, log)
        try:
            yield Figure("make hub to the hub's API", time.monotonic() - start, "s")
            before = set(process_tree(server.pid))
            with launch(path) as browser:
                page = browser.new_context().new_page()
                page.goto(f"{url}/hub/login", timeout=STEP_MS)
                page.fill("#username_input", STUDENT)
                page.fill("#password_input", password)
                page.click("#login_submit")
                page.wait_for_url(f"**/user/{STUDENT}/lab**", timeout=STEP_MS)
                page.wait_for_selector(".jp-Launcher, .jp-DirListing", timeout=STEP_MS)
                students = set(process_tree(server.pid)) - before
                rss = sum(_kib(pid, "VmRSS", "status") for pid in students)
                pss = sum(_kib(pid, "Pss", "smaps_rollup") for pid in students)
                page.wait_for_function("() => window.jupyterapp", timeout=STEP_MS)
                # JupyterLab's own client starts a kernel and asks it for its info: the
                # answer comes from the running kernel.
                info = page.evaluate(
                    """async () => {
                        const manager = window.jupyterapp.serviceManager.kernels;
                        const kernel = await manager.startNew({name: 'python3'});
                        const info = await kernel.info;  // once connected, its reply
                        return info.status;
                    }"""
                )
                if info != "ok":
                    raise RuntimeError(f"the student's kernel answered {info!r}")
                yield Figure(
                    "make hub to the first student's running kernel",
                    time.monotonic() - start,
                    "s",
                )
                yield Figure(
                    f"idle student server, memory RSS ({len(students)} processes; target 150)",
                    rss / 1024,
                    "MB",
                )
                yield Figure("idle student server, memory PSS (target 150)", pss / 1024, "MB")
        finally:
            stop(server)
