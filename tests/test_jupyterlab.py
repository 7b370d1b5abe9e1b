"""A student's session in JupyterLab, in a real browser, against ``make lab``'s server.

The server is started by ``make lab`` itself (isolated, on 127.0.0.1 with a token) on a
copy of lab 1 with the tasks answered. Chromium (driven by Playwright) runs the cells
through JupyterLab's own commands, reads what the page shows, opens a terminal and runs
``ros2 node list`` in it, and opens a live 3D view, which must reach MeshCat's server
through the Jupyter server (its ``proxy/PORT/`` route) and no other port.
"""

from __future__ import annotations

import json
import os
import secrets
import signal
import subprocess
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import nbformat
import pytest

from autograder.config import ROOT
from rosbook.runtime.isolation import child_env
from tests.jupyterlab_ui import CELL_S, START_S, cell_index, run_cell, terminal, wait_for_notebook
from tests.labtools import answered, assert_counted_from_zero
from tests.servers import server_url

LAB = "lab01_nodes_topics"

LIVE_VIEW = "from rosbook import viz\nvis = viz.live_visualizer()\nvis.jupyter_cell()"
DRAW_BOX = "import meshcat.geometry as g\nvis['box'].set_object(g.Box([0.2, 0.2, 0.2]))"


def _api(url: str, token: str, path: str, method: str = "GET") -> Any:
    request = urllib.request.Request(
        f"{url}/api/{path}", method=method, headers={"Authorization": f"token {token}"}
    )
    with urllib.request.urlopen(request, timeout=10) as response:
        body = response.read()
    return json.loads(body) if body else None


@pytest.fixture(scope="module")
def lab_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, str, Path]]:
    """``make lab`` serving a copy of lab 1 (answered, plus a live-3D cell); yields the
    server's URL, its token and the folder."""
    folder = tmp_path_factory.mktemp("labs")
    notebook = answered(LAB)
    notebook.cells += [nbformat.v4.new_code_cell(LIVE_VIEW), nbformat.v4.new_code_cell(DRAW_BOX)]
    notebook.cells.append(nbformat.v4.new_code_cell("viz.close_live(vis)"))
    nbformat.write(notebook, folder / f"{LAB}.ipynb")
    token, runtime = secrets.token_hex(16), folder.parent / "runtime"
    flags = (
        "--no-browser --ip=127.0.0.1 --port=0 "
        f"--IdentityProvider.token={token} --LabApp.expose_app_in_browser=True"
    )
    log = (folder.parent / "server.log").open("w")
    env = child_env()
    env.pop("ROS_DOMAIN_ID", None)  # `make lab` picks a domain of its own
    env["JUPYTER_RUNTIME_DIR"] = str(runtime)  # where it says which port it was given
    server = subprocess.Popen(
        ["make", "--no-print-directory", "-C", str(ROOT), "lab", f"LAB_DIR={folder}",
         f"LAB_ARGS={flags}"],
        stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True,
    )  # fmt: skip
    url = ""
    try:
        deadline = time.monotonic() + START_S
        try:
            url = server_url(runtime, server, START_S)
        except (RuntimeError, TimeoutError) as exc:
            pytest.fail(f"make lab did not serve: {exc}\n" + Path(log.name).read_text())
        while True:
            try:
                _api(url, token, "status")
                break
            except OSError:
                if server.poll() is not None or time.monotonic() > deadline:
                    pytest.fail("make lab did not serve:\n" + Path(log.name).read_text())
                time.sleep(0.2)  # polling for the server to answer, not a wait for time
        yield url, token, folder
    finally:
        try:
            if url:  # it serves: asked to shut down, as from its File menu
                _api(url, token, "shutdown", method="POST")
                server.wait(timeout=60)
        except (OSError, subprocess.TimeoutExpired):
            pass
        if server.poll() is None:
            os.killpg(server.pid, signal.SIGINT)
            server.wait(timeout=60)
        log.close()


def test_a_student_session_in_jupyterlab(browser, lab_server) -> None:
    url, token, folder = lab_server
    page = browser.new_page()
    sockets: list[Any] = []
    page.on("websocket", lambda ws: sockets.append(ws))
    try:
        page.goto(f"{url}/lab/tree/{LAB}.ipynb?token={token}", timeout=START_S * 1000)
        wait_for_notebook(page)
        setup = cell_index(page, "from rosbook.labs import lab01 as checks")
        run_cell(page, setup)
        run_cell(page, cell_index(page, "class CounterPublisher(Node)"))
        try_it = cell_index(page, "ros.spin_for(1.6)")
        first = run_cell(page, try_it)
        assert_counted_from_zero(first)
        check = run_cell(page, cell_index(page, "ros.sim_clock()"))
        assert "Error" not in check, check
        again = run_cell(page, try_it)
        assert_counted_from_zero(again)

        # a terminal of `make lab` has the venv's ros2, in the kernel's ROS domain
        listing = folder / "nodes.txt"
        terminal(page, f"ros2 node list > {listing} 2>&1; echo end-of-list >> {listing}")
        deadline = time.monotonic() + CELL_S
        while "end-of-list" not in (listing.read_text() if listing.exists() else ""):
            assert time.monotonic() < deadline, "the terminal never ran ros2 node list"
            time.sleep(0.2)  # polling for the file the terminal writes
        nodes = listing.read_text().split()
        assert "/counter_publisher" in nodes, nodes
        assert not [n for n in nodes if "probe" in n or "sim_clock" in n], nodes

        # a live 3D view: page and web socket through the Jupyter server's proxy
        run_cell(page, cell_index(page, "vis = viz.live_visualizer()"))
        frame = page.frame_locator(".jp-OutputArea iframe")
        frame.locator("canvas").first.wait_for(timeout=CELL_S * 1000)
        live = [ws for ws in sockets if "/proxy/" in ws.url]
        assert live and live[0].url.startswith(f"ws://127.0.0.1:{url.rsplit(':', 1)[1]}/proxy/")
        drawn: list[Any] = []
        live[0].on("framereceived", lambda frame: drawn.append(frame))
        run_cell(page, cell_index(page, "vis['box'].set_object"))
        deadline = time.monotonic() + CELL_S
        while not drawn:
            assert time.monotonic() < deadline, "the view never received the box"
            page.wait_for_timeout(100)  # lets Playwright deliver socket events
        run_cell(page, cell_index(page, "viz.close_live(vis)"))
    finally:
        page.close()
