"""The course server (``make hub``): students in a real browser, each isolated.

``make hub`` serves on a free loopback port with a state folder of the test's own. In
Chromium (Playwright), students log in at once with their own passwords, open lab 1
(answered, in their own home), run its cells and a cell that starts a node named after
them, and list the ROS graph with ``ros2 node list`` from a JupyterLab terminal. All are
in the same ROS domain: each must see only their own nodes (their server runs on a
network of its own). Stopping the hub must leave no process of any student.
"""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar
from urllib.parse import parse_qs, quote, urlencode, urlparse

import nbformat
import psutil
import pytest

from autograder.config import ROOT
from autograder.sandbox import process_tree
from coursehub.hub import COURSE, add, serve, stop
from rosbook.runtime.isolation import child_env
from tests.jupyterlab_ui import CELL_S, START_S, cell_index, run_cell, terminal, wait_for_notebook
from tests.labtools import answered, assert_counted_from_zero
from tests.servers import leftovers, running_hub, still_running

T = TypeVar("T")

LAB = "lab01_nodes_topics"
STUDENTS = ("ada", "ben", "cyd")
INSTRUCTOR = "prof"
STOP_S = 120  # a hang guard for the hub's stop
GRADE_S = 900  # a hang guard for the instructor's commands (grading three on a busy machine)


@pytest.fixture(scope="module")
def hub(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    """``make hub`` with three students and an instructor; yields its URL, state folder,
    process and passwords."""
    state = tmp_path_factory.mktemp("hub")
    passwords = {name: add(state / "roster.json", name) for name in STUDENTS}
    passwords[INSTRUCTOR] = add(state / "roster.json", INSTRUCTOR, instructor=True)
    for name in STUDENTS:
        home = state / "home" / name
        home.mkdir(parents=True)
        notebook = answered(LAB)
        notebook.cells.append(
            nbformat.v4.new_code_cell(f"import rclpy\nmarker = rclpy.create_node('only_{name}')")
        )
        nbformat.write(notebook, home / f"{LAB}.ipynb")
        nbformat.write(answered(LAB), home / "answers.ipynb")  # what they will submit
    env = child_env()
    env.update(
        ROSBOOK_HUB_DIR=str(state),
        ROSBOOK_HUB_LAB_ARGS="--LabApp.expose_app_in_browser=True",
        ROS_DOMAIN_ID="0",  # every student in one domain: only their networks part them
    )
    with running_hub(env, state, STOP_S) as (server, url, tmp):
        yield {"url": url, "state": state, "server": server, "passwords": passwords, "tmp": tmp}


def _log_in(browser: Any, url: str, name: str, password: str, then: str = "") -> Any:
    """A new browser's page logged in as ``name``, on its way to ``then`` (a path of the
    student's server: a link to a notebook) or the server's default page."""
    page = browser.new_context().new_page()
    there = f"?next={quote(f'/user/{name}/{then}')}" if then else ""
    page.goto(f"{url}/hub/login{there}", timeout=START_S * 1000)
    page.fill("#username_input", name)
    page.fill("#password_input", password)
    page.click("#login_submit")
    return page


def _wait_until(found: Callable[[], T], what: str, timeout: float = CELL_S) -> T:
    """Polls for what the terminal or the server writes; its guard says "timeout"."""
    deadline = time.monotonic() + timeout
    while not (result := found()):
        assert time.monotonic() < deadline, f"timeout: {what}"
        time.sleep(0.2)
    return result


def _wait_for_text(path: Path, end: str, timeout: float = CELL_S) -> str:
    def ended() -> str:
        text = path.read_text() if path.exists() else ""
        return text if end in text else ""

    return _wait_until(ended, f"{path} never ended with {end}", timeout)


def _wait_for_files(folder: Path, pattern: str) -> list[Path]:
    return _wait_until(lambda: sorted(folder.glob(pattern)), f"nothing like {pattern} in {folder}")


def _wait_for_bytes(path: Path, size: int) -> bytes:
    def whole() -> bytes:
        data = path.read_bytes()
        return data if len(data) >= size else b""

    return _wait_until(whole, f"{path} stayed shorter than {size} bytes")


def _hub_command(hub: dict[str, Any], *args: str) -> str:
    """The instructor's command line on the hub's machine."""
    env = child_env()
    env["ROSBOOK_HUB_DIR"] = str(hub["state"])
    done = subprocess.run(
        [sys.executable, "-m", *args], env=env, cwd=ROOT, capture_output=True, text=True,
        timeout=GRADE_S,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def _assignments_tab(page: Any) -> Any:
    """The Assignments tab, opened from JupyterLab's Nbgrader menu as a student would."""
    page.locator(".lm-MenuBar-item", has_text="Nbgrader").click(timeout=START_S * 1000)
    page.locator(".lm-Menu-item", has_text="Assignment List").click(timeout=START_S * 1000)
    tab = page.locator("#nbgrader-assignment-list")
    tab.wait_for(timeout=START_S * 1000)
    return tab


def _click_in_tab(tab: Any, listing: str, button: str) -> None:
    """Click ``button`` on the lab's row of the tab's ``listing`` (released, fetched or
    submitted), once the server lists it there."""
    row = tab.locator(f"#{listing}_assignments_list .list_item", has_text=LAB)
    row.locator("button", has_text=button).first.click(timeout=CELL_S * 1000)


def test_release_submit_grade_and_feedback(browser, hub, tmp_path: Path) -> None:
    """nbgrader's flow through each student's own exchange, in the Assignments tab:
    each student clicks Fetch, solves and validates in a terminal, clicks Submit and,
    once graded, Fetch Feedback. The last student submits the lab as released
    (unanswered), the others answer it."""
    url, state = hub["url"], hub["state"]
    pages = {name: _log_in(browser, url, name, hub["passwords"][name]) for name in STUDENTS}
    for name, page in pages.items():
        page.wait_for_url(f"**/user/{name}/lab**", timeout=START_S * 1000, wait_until="commit")
        page.wait_for_function("() => window.jupyterapp !== undefined", timeout=START_S * 1000)
    assert _hub_command(hub, "coursehub.hub", "release", LAB).split()[2:] == list(STUDENTS)
    tabs = {name: _assignments_tab(page) for name, page in pages.items()}
    for tab in tabs.values():
        _click_in_tab(tab, "released", "Fetch")
    for name, page in pages.items():
        tabs[name].locator("#fetched_assignments_list .list_item", has_text=LAB).first.wait_for(
            timeout=CELL_S * 1000
        )  # fetched: the tab lists it as downloaded
        solve = "true" if name == STUDENTS[-1] else f"cp ~/answers.ipynb ~/{LAB}/{LAB}.ipynb"
        terminal(
            page,
            f"({solve} && nbgrader validate {LAB}/{LAB}.ipynb) > ~/flow.txt 2>&1;"
            " echo end-of-flow >> ~/flow.txt",
        )
    for name in STUDENTS:
        # validate runs the whole lab in the student's 1-CPU sandbox: a grader's guard
        flow = _wait_for_text(state / "home" / name / "flow.txt", "end-of-flow", GRADE_S)
        if name != STUDENTS[-1]:
            assert "Success! Your notebook passes all the tests." in flow, (name, flow)
    for name, page in pages.items():
        page.locator(".lm-TabBar-tab", has_text="Assignments").click(timeout=START_S * 1000)
        _click_in_tab(tabs[name], "fetched", "Submit")
    for tab in tabs.values():
        submitted = tab.locator("#submitted_assignments_list .list_item", has_text=LAB)
        submitted.first.wait_for(timeout=CELL_S * 1000)
    submissions, graded = tmp_path / "submissions", tmp_path / "graded"
    collected = _hub_command(hub, "coursehub.hub", "collect", LAB, str(submissions))
    assert collected.split()[2:] == list(STUDENTS)
    _hub_command(hub, "autograder", "grade", str(submissions), "--out", str(graded))
    returned = _hub_command(hub, "coursehub.hub", "feedback", LAB, str(graded))
    assert returned.split()[2:] == list(STUDENTS)
    for tab in tabs.values():
        _click_in_tab(tab, "submitted", "Fetch Feedback")
    scores = {}
    for name in STUDENTS:
        pages_seen = _wait_for_files(state / "home" / name / LAB / "feedback", f"*/{LAB}.html")
        assert len(pages_seen) == 1, (name, pages_seen)
        own = (graded / "feedback" / name / LAB / f"{LAB}.html").read_bytes()
        # the server may still be writing it: wait for the whole page, then compare
        assert _wait_for_bytes(pages_seen[0], len(own)) == own, name  # their own, as graded
        scores[name] = own
    assert scores[STUDENTS[0]] != scores[STUDENTS[-1]]
    # the formgrader is the instructor's alone
    for name, page in pages.items():
        assert page.request.get(f"{url}/user/{name}/formgrader").status == 404, name
        # the Assignments tab's API lists the lab; what the labs never use is not loaded
        listed = page.request.get(f"{url}/user/{name}/assignments?course_id={COURSE}")
        assert listed.status == 200 and LAB in listed.text(), (name, listed.text())
        assert page.request.get(f"{url}/user/{name}/lsp/status").status == 404, name
    instructor = _log_in(browser, url, INSTRUCTOR, hub["passwords"][INSTRUCTOR])
    instructor.wait_for_url(
        f"**/user/{INSTRUCTOR}/lab**", timeout=START_S * 1000, wait_until="commit"
    )
    assert instructor.request.get(f"{url}/user/{INSTRUCTOR}/formgrader").status == 200
    assert instructor.request.get(f"{url}/user/{INSTRUCTOR}/lsp/status").status == 200
    instructor.context.close()
    for page in pages.values():
        page.context.close()


def test_students_are_isolated_and_nothing_survives_the_hub(browser, hub) -> None:
    url, state = hub["url"], hub["state"]
    # everyone logs in at once: their servers start together
    # each follows a link to the lab's notebook: JupyterLab opens once, with it
    notebook = f"lab/tree/{LAB}.ipynb"
    pages = {
        name: _log_in(browser, url, name, hub["passwords"][name], notebook) for name in STUDENTS
    }
    for name, page in pages.items():
        # the login goes to the notebook, or to the hub's page saying that the server is
        # not running (as at the first login of this hub), whose button starts it
        page.wait_for_url(
            re.compile(f"/user/{name}/{notebook}$"), timeout=START_S * 1000, wait_until="commit"
        )
        if urlparse(page.url).path.startswith("/hub/"):
            page.click("#start", timeout=START_S * 1000)
    for name, page in pages.items():
        page.wait_for_url(
            f"{url}/user/{name}/{notebook}", timeout=START_S * 1000, wait_until="commit"
        )
        wait_for_notebook(page)
    for name, page in pages.items():
        run_cell(page, cell_index(page, "from rosbook.labs import lab01 as checks"))
        run_cell(page, cell_index(page, "class CounterPublisher(Node)"))
        try_it = run_cell(page, cell_index(page, "ros.spin_for(1.6)"))
        assert_counted_from_zero(f"{name}: {try_it}")
        assert "Error" not in run_cell(page, cell_index(page, f"only_{name}")), name
    # every student's graph, from their own terminal, while all their nodes live
    for page in pages.values():
        terminal(page, "ros2 node list > ~/nodes.txt 2>&1; echo end-of-list >> ~/nodes.txt")
    for name in STUDENTS:
        home = state / "home" / name
        nodes = _wait_for_text(home / "nodes.txt", "end-of-list").split()
        assert f"/only_{name}" in nodes, (name, nodes)
        assert not [n for n in nodes if n.startswith("/only_") and n != f"/only_{name}"], nodes
        assert nodes.count("/counter_publisher") == 1, (name, nodes)
    # a student's files are theirs alone: no other home exists in the sandbox
    page = pages[STUDENTS[0]]
    terminal(page, f"ls -a /home {state} > ~/seen.txt 2>&1; echo end-of-ls >> ~/seen.txt")
    seen = _wait_for_text(state / "home" / STUDENTS[0] / "seen.txt", "end-of-ls")
    assert "student" in seen and "No such file" in seen, seen
    assert not any(other in seen for other in STUDENTS[1:]), seen

    # the hub's stop ends every process of every student
    processes = process_tree(hub["server"].pid)
    kernels = [p for p in still_running(processes) if "ipykernel" in p]
    assert len(kernels) >= len(STUDENTS), kernels  # the walk sees the sandboxes' insides
    for page in pages.values():
        page.context.close()
    # as an instructor's Ctrl-C, to the hub alone (not its process group)
    os.kill(int((state / "jupyterhub.pid").read_text()), signal.SIGINT)
    hub["server"].wait(timeout=STOP_S)
    assert still_running(processes) == []
    for name in STUDENTS:  # nothing of theirs is left: no sandbox's files, no mounted home
        assert leftovers(hub["tmp"], name) == []
        assert not os.path.ismount(state / "home" / name), name


class _NoRedirect(urllib.request.HTTPRedirectHandler):
    def redirect_request(self, *args: Any, **kwargs: Any) -> None:
        return None  # the redirect is the answer under test


def test_a_hub_whose_port_was_taken_is_started_again_then_says_so(tmp_path: Path) -> None:
    """The hub is given ports found free a moment before; when another process took one
    first, ``serve`` starts it again, and after its tries says that a port was taken.
    The hub exits (it once said it was running, the other program answering its URL),
    its proxy with it."""
    add(tmp_path / "roster.json", STUDENTS[0])
    env = child_env()
    env.update(ROSBOOK_HUB_DIR=str(tmp_path))
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = str(taken.getsockname()[1])
        with (tmp_path / "hub.log").open("w") as log:
            with pytest.raises(RuntimeError, match="was taken by another process, 2 time"):
                serve(env, log, url=f"http://127.0.0.1:{port}", tries=2)
        said = (tmp_path / "hub.log").read_text()
        assert said.count(f"port {port} is taken by another program") == 2, said
        proxies = [p for p in psutil.process_iter(["cmdline"]) if port in (p.info["cmdline"] or [])]
        assert proxies == [], proxies


def test_lti13_launch_goes_to_the_lms(tmp_path: Path) -> None:
    """``make hub`` with an LMS's LTI 1.3 registration in its environment: it serves the
    tool's settings for the LMS, and a launch from the LMS goes back to the LMS's
    authorization with the hub's client id (the roster still names who may log in)."""
    add(tmp_path / "roster.json", STUDENTS[0])
    lms, client = "https://lms.example.edu", "rosbook-hub"
    env = child_env()
    env.update(
        ROSBOOK_HUB_DIR=str(tmp_path),
        ROSBOOK_HUB_LTI13_ISSUER=lms,
        ROSBOOK_HUB_LTI13_CLIENT_ID=client,
        ROSBOOK_HUB_LTI13_AUTHORIZE_URL=f"{lms}/auth",
        ROSBOOK_HUB_LTI13_JWKS_URL=f"{lms}/jwks",
    )
    with (tmp_path / "hub.log").open("w") as log:
        try:
            server, url = serve(env, log)
        except (RuntimeError, TimeoutError) as exc:
            pytest.fail(f"{exc}:\n" + (tmp_path / "hub.log").read_text())
        try:
            with urllib.request.urlopen(f"{url}/hub/lti13/config", timeout=START_S) as answer:
                tool = json.loads(answer.read())
            assert tool["oidc_initiation_url"] == f"{url}/hub/lti13/oauth_login", tool
            launch = urlencode(
                {"iss": lms, "login_hint": STUDENTS[0], "target_link_uri": f"{url}/hub",
                 "client_id": client}
            )  # fmt: skip
            opener = urllib.request.build_opener(_NoRedirect)
            with pytest.raises(urllib.error.HTTPError) as redirect:
                opener.open(f"{url}/hub/lti13/oauth_login?{launch}", timeout=START_S)
            assert redirect.value.code == 302, redirect.value
            to = urlparse(redirect.value.headers["Location"])
            assert f"{to.scheme}://{to.netloc}{to.path}" == f"{lms}/auth", to
            asked = parse_qs(to.query)
            assert asked["client_id"] == [client] and asked["login_hint"] == [STUDENTS[0]]
            assert asked["redirect_uri"] == [f"{url}/hub/lti13/oauth_callback"], asked
        finally:
            stop(server, STOP_S)
