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
from tests.labtools import answered, assert_counted_from_zero
from tests.servers import server_url

LAB = "lab01_nodes_topics"
#: Bounds against hangs only (a loaded machine is slow; none of them decides a verdict).
START_S = 180
CELL_S = 180

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


# JupyterLab's own objects (page config `exposeAppInBrowser`): the notebook panel and
# a cell's state, read and driven as its menus and keys would.
_PANEL = "window.labNotebook"


def _run_cell(page: Any, index: int) -> str:
    """Run cell ``index`` with JupyterLab's run command; return its text and errors."""
    before = page.evaluate(f"{_PANEL}.content.widgets[{index}].model.executionCount")
    page.evaluate(
        f"""async () => {{
            const panel = {_PANEL};
            window.jupyterapp.shell.activateById(panel.id);
            panel.content.activeCellIndex = {index};
            await window.jupyterapp.commands.execute('notebook:run-cell');
        }}"""
    )
    page.wait_for_function(
        f"""() => {{
            const panel = {_PANEL};
            const cell = panel.content.widgets[{index}];
            const count = cell.model.executionCount;
            return count !== null && count !== {json.dumps(before)} &&
                panel.sessionContext.session.kernel.status === 'idle';
        }}""",
        timeout=CELL_S * 1000,
    )
    outputs = page.evaluate(f"{_PANEL}.content.widgets[{index}].model.outputs.toJSON()")
    return "".join(
        "".join(o.get("text", "")) + (f"{o['ename']}: {o['evalue']}" if "ename" in o else "")
        for o in outputs
    )


def _terminal(page: Any, command: str) -> None:
    """Open a new terminal as a student does (File > New > Terminal), wait until it has the
    keyboard and type ``command`` into it. JupyterLab gives a new terminal the focus once its
    xterm is ready, and it restores the terminals a student left open (a later login shows
    them again): keys typed before then go to another terminal, or split between two."""
    widget = page.evaluate(
        """async () => {
            const widget = await window.jupyterapp.commands.execute('terminal:create-new');
            return widget.id;
        }"""
    )
    keys = page.locator(f"[id='{widget}'] .xterm-helper-textarea")
    # attached first: Playwright's wait_for_function fails at once when its predicate
    # throws, and the one below throws (getElementById is null) until the widget is attached
    keys.wait_for(state="attached", timeout=START_S * 1000)
    page.wait_for_function(
        "id => document.getElementById(id).contains(document.activeElement)",
        arg=widget,
        timeout=START_S * 1000,
    )
    page.keyboard.type(command + "\n")


def _wait_for_notebook(page: Any) -> None:
    """Until the open notebook's kernel is idle; it is then ``window.labNotebook``."""
    page.wait_for_function(
        "() => { const p = window.jupyterapp && window.jupyterapp.shell.currentWidget;"
        " const k = p && p.sessionContext && p.sessionContext.session &&"
        " p.sessionContext.session.kernel;"
        " if (k && k.status === 'idle') { window.labNotebook = p; return true; } }",
        timeout=START_S * 1000,
    )


def _index(page: Any, text: str) -> int:
    """The first code cell whose source holds ``text``."""
    sources = page.evaluate(
        f"{_PANEL}.content.widgets.map(c => c.model.type === 'code' ? c.model.sharedModel.source"
        " : '')"
    )
    return next(i for i, source in enumerate(sources) if text in source)


def test_a_student_session_in_jupyterlab(browser, lab_server) -> None:
    url, token, folder = lab_server
    page = browser.new_page()
    sockets: list[Any] = []
    page.on("websocket", lambda ws: sockets.append(ws))
    try:
        page.goto(f"{url}/lab/tree/{LAB}.ipynb?token={token}", timeout=START_S * 1000)
        _wait_for_notebook(page)
        setup = _index(page, "from rosbook.labs import lab01 as checks")
        _run_cell(page, setup)
        _run_cell(page, _index(page, "class CounterPublisher(Node)"))
        try_it = _index(page, "ros.spin_for(1.6)")
        first = _run_cell(page, try_it)
        assert_counted_from_zero(first)
        check = _run_cell(page, _index(page, "ros.sim_clock()"))
        assert "Error" not in check, check
        again = _run_cell(page, try_it)
        assert_counted_from_zero(again)

        # a terminal of `make lab` has the venv's ros2, in the kernel's ROS domain
        listing = folder / "nodes.txt"
        _terminal(page, f"ros2 node list > {listing} 2>&1; echo end-of-list >> {listing}")
        deadline = time.monotonic() + CELL_S
        while "end-of-list" not in (listing.read_text() if listing.exists() else ""):
            assert time.monotonic() < deadline, "the terminal never ran ros2 node list"
            time.sleep(0.2)  # polling for the file the terminal writes
        nodes = listing.read_text().split()
        assert "/counter_publisher" in nodes, nodes
        assert not [n for n in nodes if "probe" in n or "sim_clock" in n], nodes

        # a live 3D view: page and web socket through the Jupyter server's proxy
        _run_cell(page, _index(page, "vis = viz.live_visualizer()"))
        frame = page.frame_locator(".jp-OutputArea iframe")
        frame.locator("canvas").first.wait_for(timeout=CELL_S * 1000)
        live = [ws for ws in sockets if "/proxy/" in ws.url]
        assert live and live[0].url.startswith(f"ws://127.0.0.1:{url.rsplit(':', 1)[1]}/proxy/")
        drawn: list[Any] = []
        live[0].on("framereceived", lambda frame: drawn.append(frame))
        _run_cell(page, _index(page, "vis['box'].set_object"))
        deadline = time.monotonic() + CELL_S
        while not drawn:
            assert time.monotonic() < deadline, "the view never received the box"
            page.wait_for_timeout(100)  # lets Playwright deliver socket events
        _run_cell(page, _index(page, "viz.close_live(vis)"))
    finally:
        page.close()
