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
import os
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import nbformat
import pytest

from autograder.config import ROOT
from autograder.sandbox import NOBODY, Network, prepare, start
from autograder.worker import MAX_NOTEBOOK_BYTES
from coursehub import hub, relay, safefs
from rosbook.runtime.isolation import child_env

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
        hub._exchange(name)
    yield folder


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

    assert asyncio.run(attack()) == b""
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
