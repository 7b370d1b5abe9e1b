"""A hostile student against the course server's root process (``coursehub``).

Each attack is made as the student: links, FIFOs and files are made by the student's
uid inside a sandbox with the student's folders bound where their server sees them
(their home at ``/home/student``, their exchange at nbgrader's root, their socket
folder at ``/run/hub``). Then the instructor's command (``python -m coursehub.hub
release|collect|feedback``) or the server's start runs as root, and must harm nothing
outside the student's own folders, naming each link it refused.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import json
import os
import re
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import nbformat
import pytest

from autograder.config import ROOT
from autograder.sandbox import HOME, NOBODY, Network, enter_argv, prepare, process_tree, start
from autograder.worker import MAX_NOTEBOOK_BYTES
from coursehub import hub, relay, safefs
from rosbook.runtime.isolation import child_env
from tests.servers import leftovers, running_hub, still_running

LAB = "lab01_nodes_topics"
STUDENTS = ("ada", "ben")
#: nbgrader's inbound names: STUDENT+LAB+TIME+RANDOM (inside, everyone is "student").
OLD, NEW = "2026-11-01 10:00:00.000000 UTC", "2026-11-02 10:00:00.000000 UTC"
#: A hang guard for one command.
COMMAND_S = 300

needs_root = pytest.mark.skipif(os.geteuid() != 0, reason="the course server's root side")


@pytest.fixture
def state(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A hub's state folder with two students, their exchanges made as the hub makes
    them."""
    folder = tmp_path / "hub"
    for name in STUDENTS:
        hub.add(folder / "roster.json", name)
    monkeypatch.setenv("ROSBOOK_HUB_DIR", str(folder))
    for name in STUDENTS:
        _give_exchange(name, folder)
    yield folder


def _give_exchange(name: str, state: Path) -> None:
    """``name``'s exchange made, and theirs, as their server's start leaves it."""
    hub._exchange(name)
    root = state / "exchange" / name
    for path in (root, *root.rglob("*")):
        os.chown(path, NOBODY, NOBODY)


def exchange(state: Path, name: str) -> Path:
    return state / "exchange" / name / hub.COURSE


def as_student(tmp_path: Path, binds: dict[str, Path], script: str) -> None:
    """Run ``script`` (sh) as the student, in a sandbox with ``binds`` (inside path ->
    host folder), as the student's server is."""
    # the sandbox's own files where its outside user can traverse (as the hub's)
    with tempfile.TemporaryDirectory(prefix="attack-") as private, Network() as network:
        launch = prepare(
            ["/bin/sh", "-ec", script], network=network, private=Path(private), env=child_env(),
            binds={k: str(v) for k, v in binds.items()}, label="attack",
        )  # fmt: skip
        proc, _ = start(launch, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        out, err = proc.communicate(timeout=COMMAND_S)
    assert proc.returncode == 0, (out + err).decode(errors="replace")


def in_exchange(tmp_path: Path, state: Path, name: str, script: str) -> None:
    """``script`` run by ``name`` in their exchange's course folder."""
    inside = f"{hub.EXCHANGE}/{hub.COURSE}"
    as_student(tmp_path, {hub.EXCHANGE: state / "exchange" / name}, f"cd {inside}\n{script}")


def instructor(state: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """The instructor's command on the hub's machine (as root)."""
    env = child_env()
    env["ROSBOOK_HUB_DIR"] = str(state)
    done = subprocess.run(
        [sys.executable, "-m", "coursehub.hub", *args], env=env, cwd=ROOT,
        capture_output=True, text=True, timeout=COMMAND_S,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    return done


def root_file(path: Path, text: str = "root's secret\n") -> Path:
    """A file only root may read, as /etc/shadow is."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    os.chmod(path, 0o600)
    return path


def submission(
    tmp_path: Path, state: Path, name: str, when: str, suffix: str, extra: str = ""
) -> str:
    """``name`` submits lab 1 (as nbgrader's submit leaves it) at ``when``; then runs
    ``extra`` in the submission's folder. Its folder's name."""
    folder = f"student+{LAB}+{when}+{suffix}"
    notebook = nbformat.writes(nbformat.v4.new_notebook(metadata={"who": name, "when": when}))
    staged = tmp_path / f"{name}-{suffix}.ipynb"
    staged.write_text(notebook)
    os.chmod(staged, 0o644)
    os.chmod(tmp_path, 0o755)
    script = (
        f"mkdir 'inbound/{folder}' && cd 'inbound/{folder}'\n"
        f"cat > {LAB}.ipynb < /run/staged/{staged.name}\n"
        f"printf %s '{when}' > timestamp.txt\nprintf %s secret-{suffix} > submission_secret.txt\n"
        f"{extra}\n"
    )
    as_student(
        tmp_path,
        {hub.EXCHANGE: state / "exchange" / name, "/run/staged": tmp_path},
        f"cd {hub.EXCHANGE}/{hub.COURSE}\n{script}",
    )
    return folder


@needs_root
def test_release_never_deletes_or_writes_through_a_linked_outbound(tmp_path, state) -> None:
    """ada's outbound is a link to a stand-in for solutions/ (its path is in her
    mountinfo), ben's outbound/LAB is one: release leaves the stand-in as it was, owner
    and files, names both links, and releases to nobody through them."""
    standin = tmp_path / "solutions"
    kept = root_file(standin / LAB / f"{LAB}.ipynb", "the answers\n")
    in_exchange(tmp_path, state, "ada", f"rm -r outbound && ln -s {standin} outbound")
    in_exchange(tmp_path, state, "ben", f"ln -s {standin}/{LAB} outbound/{LAB}")
    done = instructor(state, "release", LAB)
    assert done.stdout.split()[2:] == [], done.stdout
    assert kept.read_text() == "the answers\n"
    assert sorted(p.name for p in (standin / LAB).iterdir()) == [f"{LAB}.ipynb"]
    assert kept.stat().st_uid == 0 and (standin / LAB).stat().st_uid == 0
    assert f"outbound: a symbolic link to {standin}" in done.stderr, done.stderr
    assert f"outbound/{LAB}: a symbolic link to {standin}/{LAB}" in done.stderr, done.stderr


@needs_root
def test_release_replaces_a_students_own_copy_and_gives_it_to_them(tmp_path, state) -> None:
    """What a student left in outbound/LAB (a link inside among it) is replaced by the
    lab, owned by the sandbox's outside user; the link's target is untouched."""
    target = root_file(tmp_path / "elsewhere" / "keep.txt")
    in_exchange(tmp_path, state, "ada", f"mkdir outbound/{LAB} && ln -s {target} outbound/{LAB}/x")
    assert instructor(state, "release", LAB).stdout.split()[2:] == list(STUDENTS)
    released = exchange(state, "ada") / "outbound" / LAB
    assert sorted(p.name for p in released.iterdir()) == [f"{LAB}.ipynb"]
    assert (released / f"{LAB}.ipynb").read_bytes() == (
        ROOT / "labs" / LAB / f"{LAB}.ipynb"
    ).read_bytes()
    assert (released / f"{LAB}.ipynb").stat().st_uid == NOBODY
    assert target.read_text() == "root's secret\n" and target.stat().st_uid == 0


@needs_root
def test_collect_copies_no_link_fifo_or_oversized_file(tmp_path, state) -> None:
    """Submissions holding a link to a root-only file, a link to another student's
    notebook, a FIFO, or a file past the grader's size limit are not collected, and
    each is named; an honest one is."""
    shadow = root_file(tmp_path / "shadow")
    other = submission(tmp_path, state, "ben", OLD, "b")
    bens = exchange(state, "ben") / "inbound" / other / f"{LAB}.ipynb"
    attacks = {
        "shadow": f"ln -sf {shadow} {LAB}.ipynb",
        "theirs": f"ln -sf '{bens}' {LAB}.ipynb",
        "zero": f"ln -sf /dev/zero {LAB}.ipynb",
        "fifo": f"rm {LAB}.ipynb && mkfifo {LAB}.ipynb",
        "huge": f"truncate -s {MAX_NOTEBOOK_BYTES + 1} {LAB}.ipynb",
    }
    out = tmp_path / "submissions"
    for attack, script in attacks.items():
        submission(tmp_path, state, "ada", NEW, attack, script)
        done = instructor(state, "collect", LAB, str(out))
        assert done.stdout.split()[2:] == ["ben"], (attack, done.stdout)
        assert not (out / "ada").exists() or not any((out / "ada").iterdir()), attack
        assert f"ada: {exchange(state, 'ada') / 'inbound'}" in done.stderr, (attack, done.stderr)
        in_exchange(tmp_path, state, "ada", "rm -r inbound/*")
    assert shadow.read_text() == "root's secret\n"


@needs_root
def test_collect_takes_the_latest_submission_by_its_time(tmp_path, state) -> None:
    """Of two submissions, the later one is collected, whatever nbgrader's random
    suffix (the earlier one's sorts last)."""
    submission(tmp_path, state, "ada", OLD, "zzzz")
    submission(tmp_path, state, "ada", NEW, "aaaa")
    out = tmp_path / "submissions"
    assert instructor(state, "collect", LAB, str(out)).stdout.split()[2:] == ["ada"]
    collected = nbformat.read(out / "ada" / LAB / f"{LAB}.ipynb", as_version=4)
    assert collected.metadata["when"] == NEW


@needs_root
def test_feedback_never_overwrites_through_a_link(tmp_path, state) -> None:
    """The feedback page's name is the hash of the student's secret and the notebook:
    ada links it to a root file before feedback. The root file keeps its content; her
    feedback folder gets the page itself."""
    submission(tmp_path, state, "ada", NEW, "a")
    page = hub.notebook_hash(secret="secret-a", notebook_id=LAB)
    target = root_file(tmp_path / "etc" / "config")
    in_exchange(tmp_path, state, "ada", f"ln -s {target} feedback/{page}.html")
    graded = tmp_path / "graded"
    (graded / "feedback" / "ada" / LAB).mkdir(parents=True)
    (graded / "feedback" / "ada" / LAB / f"{LAB}.html").write_text("<p>ada's feedback</p>")
    assert instructor(state, "feedback", LAB, str(graded)).stdout.split()[2:] == ["ada"]
    assert target.read_text() == "root's secret\n"
    given = exchange(state, "ada") / "feedback" / f"{page}.html"
    assert not given.is_symlink() and given.read_text() == "<p>ada's feedback</p>"
    assert given.stat().st_uid == NOBODY


@needs_root
def test_feedback_reads_no_secret_through_a_link(tmp_path, state) -> None:
    """A submission whose secret is a link to /dev/zero: feedback names it and goes on
    (it never reads without end)."""
    submission(tmp_path, state, "ada", NEW, "a", "ln -sf /dev/zero submission_secret.txt")
    graded = tmp_path / "graded"
    (graded / "feedback" / "ada" / LAB).mkdir(parents=True)
    (graded / "feedback" / "ada" / LAB / f"{LAB}.html").write_text("<p>feedback</p>")
    done = instructor(state, "feedback", LAB, str(graded))
    assert done.stdout.split()[2:] == [], done.stdout
    assert "submission_secret.txt: a symbolic link to /dev/zero" in done.stderr, done.stderr


@needs_root
def test_dangling_links_in_a_students_course_folder_make_no_root_files(tmp_path, state) -> None:
    """ada's course folder in her exchange is a dangling link: no command creates the
    folders at its target."""
    target = tmp_path / "made-by-root"
    in_exchange(
        tmp_path, state, "ada", f"cd .. && rm -r {hub.COURSE} && ln -s {target} {hub.COURSE}"
    )
    done = instructor(state, "release", LAB)
    assert done.stdout.split()[2:] == ["ben"], done.stdout
    assert not target.exists() and not os.path.lexists(target)
    assert f"{hub.COURSE}: a symbolic link to {target}" in done.stderr, done.stderr


def test_the_relay_connects_only_to_the_servers_own_socket(tmp_path) -> None:
    """The server's socket replaced by a link to another socket (the hub's own, root's):
    the relay refuses it, says why, and never connects there."""
    hubs = tmp_path / "hub.sock"
    students = tmp_path / "server"
    students.mkdir()
    os.symlink(hubs, students / hub.SOCKET)
    said: list[str] = []

    async def attack() -> bytes:
        reached: list[bytes] = []

        async def root_service(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            reached.append(await reader.read(100))
            writer.close()

        service = await asyncio.start_unix_server(root_service, str(hubs))
        owner = os.getuid() + 1  # the server's user is not the hub's
        to_server = await relay.serve(
            "tcp:127.0.0.1:0", f"unix:{students / hub.SOCKET}", owner=owner, refused=said.append
        )
        reader, writer = await asyncio.open_connection("127.0.0.1", relay.port(to_server))
        writer.write(b"POST /hub/api/users HTTP/1.1\r\n\r\n")
        await writer.drain()
        try:
            answer = await reader.read()  # closed by the relay
        except ConnectionResetError:
            answer = b""
        to_server.close()
        service.close()
        assert reached == []
        return answer

    # a loop of its own, in a thread of its own (a browser's test may hold this one's)
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        assert pool.submit(asyncio.run, attack()).result(timeout=COMMAND_S) == b""
    assert said == [f"{students / hub.SOCKET}: a link; refused, never connected to"], said


def test_safe_copy_counts_bytes_while_copying(tmp_path) -> None:
    """A file that is larger than the limit is stopped at the limit, never read whole,
    and the refusal names it."""
    source = tmp_path / "in"
    source.mkdir()
    with (source / "big").open("wb") as big:
        big.truncate(MAX_NOTEBOOK_BYTES + 1)
    fd = os.open(source, safefs.FOLDER)
    try:
        with pytest.raises(safefs.Refused, match=f"big: more than {MAX_NOTEBOOK_BYTES} bytes"):
            safefs.copy_out(fd, source, tmp_path / "out", MAX_NOTEBOOK_BYTES)
    finally:
        os.close(fd)


# --- against a running hub (make hub): a student's server starting, and logins --------

#: A hang guard for a server to start on a loaded machine, and for the hub's stop.
START_S = 600
#: The students' home quota in these tests.
QUOTA_MB = 64


def _log_in(url: str, name: str, password: str) -> tuple[int, urllib.request.OpenerDirector]:
    """The hub's login form, posted as a browser posts it: the answer's status, and the
    session (its cookies) to go on with."""
    session = urllib.request.build_opener(urllib.request.HTTPCookieProcessor())
    form = session.open(f"{url}/hub/login", timeout=START_S).read().decode()
    xsrf = re.search(r'name="_xsrf" value="([^"]+)"', form)
    assert xsrf, form
    data = urllib.parse.urlencode({"_xsrf": xsrf[1], "username": name, "password": password})
    try:
        with session.open(f"{url}/hub/login", data=data.encode(), timeout=START_S) as answer:
            return answer.status, session
    except urllib.error.HTTPError as error:
        return error.code, session


def _server_answers(url: str, name: str, session: urllib.request.OpenerDirector) -> bool:
    """Whether ``name``'s server serves JupyterLab to the session (logging it in to the
    server on the way, as a browser is)."""
    try:
        with session.open(f"{url}/user/{name}/lab", timeout=START_S) as answer:
            return answer.status == 200 and answer.url.startswith(f"{url}/user/{name}/lab")
    except urllib.error.HTTPError:
        return False


def _wait_for(done: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + START_S
    while not done():
        assert time.monotonic() < deadline, f"timeout: {what}"
        time.sleep(0.5)  # polling for the event, not waiting for time


@pytest.fixture(scope="module")
def attacked(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    """``make hub`` whose student ada filled her home, socket folder and exchange with
    links (as her own server would) before her server starts: root-only files, a
    dangling link where the hub writes her nbgrader settings, her JupyterLab settings
    folder a link to a root folder."""
    state = tmp_path_factory.mktemp("hub")
    host = tmp_path_factory.mktemp("host")  # what the links aim at: root's
    passwords = {name: hub.add(state / "roster.json", name) for name in STUDENTS}
    run = state / "run" / "ada" / "server"
    home = state / "home" / "ada"
    for folder in (home, run):
        folder.mkdir(parents=True)
        os.chown(folder, NOBODY, NOBODY)
    os.environ["ROSBOOK_HUB_DIR"] = str(state)
    try:
        _give_exchange("ada", state)
    finally:
        del os.environ["ROSBOOK_HUB_DIR"]
    targets = {where: root_file(host / where) for where in ("jupyter", "run", "exchange")}
    labconfig = host / "labconfig"
    root_file(labconfig / "page_config.json", "root's page\n")
    made = host / "made-by-root.py"
    script = (
        f"mkdir -p ~/.jupyter && ln -s {targets['jupyter']} ~/.jupyter/x\n"
        f"ln -s {made} ~/.jupyter/nbgrader_config.py\n"
        f"ln -s {labconfig} ~/.jupyter/labconfig\n"
        f"ln -s {targets['run']} /run/hub/x\n"
        f"ln -s {targets['exchange']} {hub.EXCHANGE}/{hub.COURSE}/inbound/x\n"
    )
    as_student(
        tmp_path_factory.mktemp("attack"),
        {HOME: home, hub.RUN: run, hub.EXCHANGE: state / "exchange" / "ada"},
        script,
    )
    env = child_env()
    env.update(ROSBOOK_HUB_DIR=str(state), ROSBOOK_HUB_QUOTA_MB=str(QUOTA_MB))
    with running_hub(env, state, START_S) as (server, url, tmp):
        yield {
            "url": url, "state": state, "server": server, "passwords": passwords,
            "targets": targets, "labconfig": labconfig, "made": made, "tmp": tmp,
            "log": state / "hub.log",
        }  # fmt: skip


@needs_root
@pytest.mark.slow
def test_a_servers_start_follows_no_link_in_the_students_folders(attacked) -> None:
    """ada's server starts: the root files her links aim at keep their owner, the
    dangling link makes no file, the linked settings folder keeps root's page, and the
    hub's log names each link; her server runs all the same."""
    url = attacked["url"]
    status, session = _log_in(url, "ada", attacked["passwords"]["ada"])
    assert status == 200, status
    _wait_for(lambda: _server_answers(url, "ada", session), "ada's server never answered")
    for where, target in attacked["targets"].items():
        assert target.stat().st_uid == 0 and stat.S_IMODE(target.stat().st_mode) == 0o600, where
    assert not os.path.lexists(attacked["made"])
    assert (attacked["labconfig"] / "page_config.json").read_text() == "root's page\n"
    assert attacked["labconfig"].stat().st_uid == 0
    said = attacked["log"].read_text()
    assert f"nbgrader_config.py: a symbolic link to {attacked['made']}" in said, said
    assert f"labconfig: a symbolic link to {attacked['labconfig']}" in said, said


def _sandbox_of(server: subprocess.Popen[bytes], name: str) -> int:
    """The first process (PID 1 inside) of ``name``'s running sandbox, seen from here."""
    for pid in process_tree(server.pid):
        try:
            status = Path(f"/proc/{pid}/status").read_text()
        except OSError:
            continue
        nspid = next(line.split()[1:] for line in status.splitlines() if line.startswith("NSpid"))
        if nspid[-1] == "1" and f"/user/{name}/" in Path(f"/proc/{pid}/environ").read_text():
            return pid
    raise AssertionError(f"no sandbox of {name} under the hub")


def _in_sandbox(pid: int, script: str) -> str:
    """``script`` run by the student in their running sandbox; its output."""
    done = subprocess.run(
        enter_argv(pid, HOME, ["/bin/sh", "-c", script]), capture_output=True, text=True,
        timeout=COMMAND_S,
    )  # fmt: skip
    return done.stdout + done.stderr


def _save(
    url: str, name: str, session: urllib.request.OpenerDirector, path: str, text: str
) -> tuple[int, str]:
    """JupyterLab's save of the notebook ``path`` holding ``text``: its status and
    answer."""
    jar = next(h.cookiejar for h in session.handlers if hasattr(h, "cookiejar"))
    xsrf = next(c.value for c in jar if c.name == "_xsrf" and c.path.startswith(f"/user/{name}"))
    notebook = nbformat.v4.new_notebook(cells=[nbformat.v4.new_markdown_cell(text)])
    body = json.dumps({"type": "notebook", "format": "json", "content": notebook})
    request = urllib.request.Request(
        f"{url}/user/{name}/api/contents/{path}", data=body.encode(), method="PUT",
        headers={"X-XSRFToken": xsrf, "Content-Type": "application/json"},
    )  # fmt: skip
    try:
        with session.open(request, timeout=START_S) as answer:
            return answer.status, answer.read().decode()
    except urllib.error.HTTPError as error:
        return error.code, error.read().decode()


@needs_root
@pytest.mark.slow
def test_a_student_at_their_quota_cannot_save_and_their_server_runs_on(attacked) -> None:
    """ada fills her home past its quota from her own sandbox: the write stops at the
    quota (the host's disk is not filled); JupyterLab's save of her notebook says "No
    space left on device" and leaves it as it was; her server still serves, and once she
    deletes the file she saves again. Her sandbox's mountinfo shows her home as a
    device, naming no host folder."""
    url, state = attacked["url"], attacked["state"]
    status, session = _log_in(url, "ada", attacked["passwords"]["ada"])
    assert status == 200, status
    _wait_for(lambda: _server_answers(url, "ada", session), "ada's server never answered")
    assert _save(url, "ada", session, "work.ipynb", "first draft")[0] == 201
    sandbox = _sandbox_of(attacked["server"], "ada")
    said = _in_sandbox(sandbox, f"dd if=/dev/zero of=fill bs=1M count={2 * QUOTA_MB}")
    assert "No space left on device" in said, said
    assert (state / "home" / "ada" / "fill").stat().st_size <= QUOTA_MB << 20
    # more than a full disk keeps free in partly used blocks
    longer = "x" * (4 << 20)
    saved, answer = _save(url, "ada", session, "work.ipynb", longer)
    assert saved == 500 and "No space left on device" in answer, (saved, answer)
    kept = nbformat.read(state / "home" / "ada" / "work.ipynb", as_version=4)
    assert kept.cells[0].source == "first draft"
    assert _server_answers(url, "ada", session)
    _in_sandbox(sandbox, "rm fill")
    assert _save(url, "ada", session, "work.ipynb", longer)[0] == 200
    mounts = _in_sandbox(sandbox, "cat /proc/self/mountinfo")
    home = next(line for line in mounts.splitlines() if f" {HOME} " in line)
    assert str(state) not in home and home.split()[3] == "/", home


@needs_root
@pytest.mark.slow
def test_the_hub_never_connects_to_a_socket_the_student_links(attacked, tmp_path) -> None:
    """ada replaces her server's socket with a link to a root service's socket: her
    requests reach nothing (the relay refuses the link and the log names it), and the
    service never hears from the hub."""
    url, state = attacked["url"], attacked["state"]
    status, session = _log_in(url, "ada", attacked["passwords"]["ada"])
    assert status == 200, status
    _wait_for(lambda: _server_answers(url, "ada", session), "ada's server never answered")
    heard: list[bytes] = []
    service = socket.socket(socket.AF_UNIX)
    service.bind(str(tmp_path / "root.sock"))
    service.listen()
    service.settimeout(0)
    run = state / "run" / "ada" / "server"
    as_student(tmp_path, {hub.RUN: run}, f"ln -sf {tmp_path / 'root.sock'} /run/hub/{hub.SOCKET}")
    assert not _server_answers(url, "ada", session)
    try:
        heard.append(service.accept()[0].recv(100))
    except BlockingIOError:
        pass  # nobody connected: the relay refused
    service.close()
    assert heard == []
    said = attacked["log"].read_text()
    assert f"{run / hub.SOCKET}: a link; refused, never connected to" in said, said


@needs_root
@pytest.mark.slow
def test_wrong_passwords_lock_the_name_and_the_address(attacked) -> None:
    """After the throttle's free wrong passwords for ada, her right password is refused;
    so is ben's, from the same address, who never typed a wrong one."""
    url, passwords = attacked["url"], attacked["passwords"]
    for _ in range(hub.LOGIN_THROTTLE.free):
        assert _log_in(url, "ada", "not-her-password")[0] == 403
    assert _log_in(url, "ada", passwords["ada"])[0] == 403
    assert _log_in(url, "ben", passwords["ben"])[0] == 403
    said = attacked["log"].read_text()
    assert "login refused: username 'ada' throttled for" in said, said
    assert "login refused: address 127.0.0.1 throttled for" in said, said


@needs_root
@pytest.mark.slow
def test_sigterm_to_make_hub_stops_every_process_and_leaves_no_folder(attacked) -> None:
    """SIGTERM to ``make hub`` alone (not its group): the hub, its proxy, ada's server
    and sandbox all end, and no temporary folder of hers is left."""
    server = attacked["server"]
    processes = process_tree(server.pid)
    assert any("jupyterhub-singleuser" in _cmdline(pid) for pid in processes), processes
    os.kill(server.pid, signal.SIGTERM)
    server.wait(timeout=START_S)
    _wait_for(lambda: not still_running(processes), "processes of the hub outlived it")
    assert leftovers(attacked["tmp"], "ada") == []
    assert not os.path.ismount(attacked["state"] / "home" / "ada")


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""
