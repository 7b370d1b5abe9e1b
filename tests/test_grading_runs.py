"""Grading a class as an instructor runs it: progress, durable rows, resume, regrade,
Ctrl-C and SIGKILL mid-class, and nbgrader's course gradebook in OUT."""

from __future__ import annotations

import csv
import json
import os
import pty
import select
import signal
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
from nbgrader.api import Gradebook

from autograder.config import ROOT
from tests.labtools import HANG, answered, grade_cmd, marked_processes, submit
from tests.servers import server_url

LAB = "lab01_nodes_topics"


def run_grade(submissions: Path, out: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        grade_cmd(submissions, out, LAB, *extra),
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=HANG,
    )


def journal(out: Path) -> list[dict]:
    path = out / "results.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []


def report(out: Path) -> dict[str, dict]:
    return {r["student_id"]: r for r in json.loads((out / "report.json").read_text())}


def csv_rows(out: Path) -> list[dict[str, str]]:
    with open(out / "grades.csv") as f:
        return list(csv.DictReader(f))


def wait_for_rows(out: Path, count: int, proc: subprocess.Popen[str]) -> None:
    """Until the journal holds ``count`` rows (the event), guarded against a hang."""
    deadline = time.monotonic() + HANG
    while len(journal(out)) < count:
        assert proc.poll() is None, f"the grading run ended early: {proc.communicate()}"
        assert time.monotonic() < deadline, f"timeout: fewer than {count} rows after {HANG} s"
        time.sleep(0.2)


@pytest.fixture
def quick_class(tmp_path: Path) -> Path:
    """Submissions graded without a kernel: a broken file and an empty folder."""
    root = tmp_path / "submitted"
    submit(root, "carol", LAB, '{"cells": [ not JSON')
    submit(root, "dave", LAB, None)
    return root


def test_progress_is_one_plain_line_per_submission_when_not_a_terminal(
    quick_class: Path, tmp_path: Path
) -> None:
    done = run_grade(quick_class, tmp_path / "out", "--workers", "1")  # in order
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert "grading 2 submission(s), 1 at a time" in lines
    assert any(ln.startswith("[1/2] 1 not ok") and "carol" in ln for ln in lines), lines
    assert any(ln.startswith("[2/2] 2 not ok") and "dave" in ln for ln in lines), lines
    assert "\r" not in done.stderr and "\x1b" not in done.stderr


def test_progress_is_one_updating_line_on_a_terminal(quick_class: Path, tmp_path: Path) -> None:
    leader, follower = pty.openpty()
    proc = subprocess.Popen(
        grade_cmd(quick_class, tmp_path / "out", LAB, "--workers", "1"),
        stdout=subprocess.DEVNULL,
        stderr=follower,
        cwd=ROOT,
    )
    os.close(follower)
    seen = b""
    deadline = time.monotonic() + HANG
    while time.monotonic() < deadline:
        ready, _, _ = select.select([leader], [], [], 1.0)
        if ready:
            try:
                chunk = os.read(leader, 4096)
            except OSError:  # the terminal closed: the run is over
                break
            if not chunk:
                break
            seen += chunk
        elif proc.poll() is not None:
            break
    os.close(leader)
    assert proc.wait(timeout=HANG) == 0
    text = seen.decode()
    assert "\r\x1b[K[1/2] 1 not ok" in text and "\r\x1b[K[2/2] 2 not ok" in text
    # the counter rewrites one line; only the submissions that are not ok get lines
    permanent = [ln for ln in text.replace("\r\n", "\n").split("\n") if ln.strip()]
    assert any("carol" in ln and "error" in ln for ln in permanent)
    assert not any(
        ln.count("[1/2]") and ln.count("[2/2]") == 0 and "\x1b" not in ln for ln in permanent
    )


def test_resume_regrades_only_changed_submissions(quick_class: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert run_grade(quick_class, out).returncode == 0
    before = report(out)
    (quick_class / "carol" / LAB / f"{LAB}.ipynb").write_text("still not a notebook")
    again = run_grade(quick_class, out, "--resume")
    assert again.returncode == 0, again.stderr
    assert "1 submission(s) already graded and unchanged: kept" in again.stderr
    after = report(out)
    assert after["dave"] == before["dave"]  # not graded again: the same row, same time
    assert "still not a notebook" in after["carol"]["message"] != before["carol"]["message"]
    assert [r["student_id"] for r in csv_rows(out)] == ["carol", "dave"]


def test_regrading_one_student_leaves_the_others_rows(quick_class: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert run_grade(quick_class, out).returncode == 0
    before = report(out)
    submit(quick_class, "dave", LAB, "now a broken file")  # would change dave's row
    again = run_grade(quick_class, out, "--student", "carol", "--workers", "2")
    assert again.returncode == 0, again.stderr
    # one submission to grade: one worker started (of the two asked for), not one idle
    assert "grading 1 submission(s), 1 at a time" in again.stderr.splitlines()
    after = report(out)
    assert after["dave"] == before["dave"] and after["dave"]["status"] == "missing"
    assert len(csv_rows(out)) == 2 and after["carol"]["status"] == "error"
    # the journal: the two rows it held, then carol's, graded again
    graded = [e["student_id"] for e in journal(out)]
    assert sorted(graded[:2]) == ["carol", "dave"] and graded[2:] == ["carol"]
    unknown = run_grade(quick_class, out, "--student", "carol,zed")
    assert unknown.returncode == 2 and "zed" in unknown.stderr


@pytest.fixture(scope="module")
def interrupted_class(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """A class graded in three runs: Ctrl-C after one row, SIGKILL after the next, resumed.

    One worker, so submissions finish in order: alice, bob, carol (broken), erin.
    """
    root = tmp_path_factory.mktemp("submitted")
    right = answered(LAB)
    for student in ("alice", "bob", "erin"):
        submit(root, student, LAB, right)
    submit(root, "carol", LAB, '{"cells": [ not JSON')
    out = tmp_path_factory.mktemp("out")
    seen: dict = {"out": out, "root": root}

    first = subprocess.Popen(
        grade_cmd(root, out, LAB, "--workers", "1"), stderr=subprocess.PIPE, text=True, cwd=ROOT
    )
    wait_for_rows(out, 1, first)
    first.send_signal(signal.SIGINT)
    _, seen["ctrl_c_stderr"] = first.communicate(timeout=HANG)
    seen["ctrl_c_code"] = first.returncode
    seen["after_ctrl_c"] = journal(out)
    seen["left_after_ctrl_c"] = marked_processes(first.pid)

    second = subprocess.Popen(
        grade_cmd(root, out, LAB, "--workers", "1", "--resume"),
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    wait_for_rows(out, 2, second)
    second.kill()  # SIGKILL: no clean-up at all
    second.wait()
    seen["after_kill"] = journal(out)

    third = run_grade(root, out, "--workers", "1", "--resume")
    seen["resumed"] = third
    return seen


@pytest.mark.slow
def test_ctrl_c_stops_cleanly_keeps_rows_and_says_how_to_resume(interrupted_class: dict) -> None:
    assert interrupted_class["ctrl_c_code"] == 130
    said = interrupted_class["ctrl_c_stderr"]
    assert "stopped: 1 of 4 submission(s) graded" in said and "--resume" in said
    assert [e["student_id"] for e in interrupted_class["after_ctrl_c"]] == ["alice"]
    assert interrupted_class["left_after_ctrl_c"] == []


@pytest.mark.slow
def test_killed_run_resumed_has_every_row_once_and_regrades_none(interrupted_class: dict) -> None:
    out, resumed = interrupted_class["out"], interrupted_class["resumed"]
    assert resumed.returncode == 0, resumed.stderr
    kept = interrupted_class["after_kill"]
    assert len(kept) >= 2 and kept[0]["student_id"] == "alice"
    assert f"{len(kept)} submission(s) already graded and unchanged: kept" in resumed.stderr
    rows = csv_rows(out)
    assert [r["student_id"] for r in rows] == ["alice", "bob", "carol", "erin"]
    final = report(out)
    for entry in kept:  # graded before the kill: the very same row, not graded again
        assert final[entry["student_id"]]["seconds"] == entry["seconds"]
    for student in ("alice", "bob", "erin"):
        assert final[student]["status"] == "ok"
        assert final[student]["score"] == final[student]["max_score"] == 10
    assert final["carol"]["status"] == "error"
    for student in final:
        assert (out / "feedback" / student / LAB / f"{LAB}.html").is_file()
        assert (out / "logs" / student / f"{LAB}.log").is_file()


@pytest.mark.slow
def test_gradebook_holds_every_cell_score_read_by_nbgrader(interrupted_class: dict) -> None:
    out = interrupted_class["out"]
    final = report(out)
    with Gradebook(f"sqlite:///{out / 'gradebook.db'}") as gb:
        for student in ("alice", "bob", "erin"):
            sub = gb.find_submission(LAB, student)
            assert sub.score == final[student]["score"] == sub.max_score
            grades = {g.name: g.auto_score for g in sub.notebooks[0].grades}
            assert grades and all(
                v == m
                for v, m in zip(grades.values(), [g.max_score for g in sub.notebooks[0].grades])
            )
        carol = gb.find_submission(LAB, "carol")
        assert carol.score == 0 and carol.needs_manual_grade  # flagged for review
    assert (out / "autograded" / "alice" / LAB / f"{LAB}.ipynb").is_file()


def nbgrader_export(out: Path) -> dict[str, dict[str, str]]:
    subprocess.run(
        [sys.executable, "-m", "nbgrader", "export", "--to", "lms.csv"],
        cwd=out,
        check=True,
        capture_output=True,
        timeout=HANG,
    )
    with open(out / "lms.csv") as f:
        return {r["student_id"]: r for r in csv.DictReader(f) if r["assignment"] == LAB}


@pytest.mark.slow
def test_nbgrader_export_gives_the_lms_the_grades(interrupted_class: dict) -> None:
    exported = nbgrader_export(interrupted_class["out"])
    assert set(exported) == {"alice", "bob", "carol", "erin"}
    assert float(exported["alice"]["score"]) == 10.0 == float(exported["alice"]["max_score"])
    assert float(exported["carol"]["score"]) == 0.0


@pytest.mark.slow
def test_nbgrader_generate_feedback_runs_in_out(interrupted_class: dict) -> None:
    out = interrupted_class["out"]
    page = out / "feedback" / "erin" / LAB / f"{LAB}.html"
    page.unlink()
    done = subprocess.run(
        [sys.executable, "-m", "nbgrader", "generate_feedback", LAB, "--student", "erin"]
        + ["--force"],
        cwd=out,
        capture_output=True,
        text=True,
        timeout=HANG,
    )
    assert done.returncode == 0, done.stderr
    assert "BEGIN HIDDEN TESTS" not in page.read_text()
    assert "Score: 10.0 / 10.0" in page.read_text()  # the score the gradebook holds


@pytest.mark.slow
def test_manual_score_survives_resume_and_regrade_of_another(interrupted_class: dict) -> None:
    out, root = interrupted_class["out"], interrupted_class["root"]
    with Gradebook(f"sqlite:///{out / 'gradebook.db'}") as gb:
        grade = gb.find_submission(LAB, "bob").notebooks[0].grades[0]
        cell, lowered = grade.name, grade.max_score - 1
        grade.manual_score = lowered
        gb.db.commit()
    for extra in (["--resume"], ["--student", "carol"]):
        done = run_grade(root, out, "--workers", "1", *extra)
        assert done.returncode == 0, done.stderr
    with Gradebook(f"sqlite:///{out / 'gradebook.db'}") as gb:
        assert gb.find_grade(cell, LAB, LAB, "bob").manual_score == lowered
        assert gb.find_submission(LAB, "bob").score == 9
    assert float(nbgrader_export(out)["bob"]["score"]) == 9.0


@pytest.fixture
def dask_cluster(tmp_path: Path) -> Iterator[tuple[str, list[subprocess.Popen[bytes]]]]:
    """A Dask scheduler and two workers (one thread each) on loopback."""
    dask = str(Path(sys.executable).parent / "dask")
    info = tmp_path / "scheduler.json"
    logs = open(tmp_path / "dask.log", "wb")  # noqa: SIM115 (closed at teardown)
    common = {"stdout": logs, "stderr": logs, "start_new_session": True, "cwd": ROOT}
    scheduler = subprocess.Popen(
        [dask, "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard"]
        + ["--scheduler-file", str(info)],
        **common,
    )
    workers = [
        subprocess.Popen(
            [dask, "worker", "--scheduler-file", str(info), "--host", "127.0.0.1"]
            + ["--nthreads", "1", "--no-nanny", "--no-dashboard"],
            **common,
        )
        for _ in range(2)
    ]
    try:
        deadline = time.monotonic() + HANG
        while not info.exists() or not info.read_text().strip():
            assert time.monotonic() < deadline, "timeout: the Dask scheduler did not start"
            time.sleep(0.2)
        address = json.loads(info.read_text())["address"]
        from distributed import Client

        with Client(address, timeout=HANG) as client:
            client.wait_for_workers(2, timeout=HANG)
        yield address, workers
    finally:
        for proc in (*workers, scheduler):
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            proc.wait()
        logs.close()


@pytest.mark.slow
def test_dask_workers_grade_like_local_and_retry_a_killed_workers_submission(
    interrupted_class: dict, dask_cluster: tuple, tmp_path: Path
) -> None:
    address, workers = dask_cluster
    out = tmp_path / "out"
    run = subprocess.Popen(
        grade_cmd(interrupted_class["root"], out, LAB, "--scheduler", address),
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    # mid-submission: a kernel is running under a ROS domain the worker reserved
    deadline = time.monotonic() + HANG
    victim = None
    while victim is None:
        assert run.poll() is None, f"the run ended before a worker was killed: {run.communicate()}"
        assert time.monotonic() < deadline, "timeout: no worker started grading"
        victim = next((w for w in workers if marked_processes(w.pid)), None)
        time.sleep(0.2)
    os.killpg(victim.pid, signal.SIGKILL)
    _, said = run.communicate(timeout=HANG)
    assert run.returncode == 0, said
    assert len(journal(out)) == 4  # every submission once, the interrupted one included
    local = report(interrupted_class["out"])
    remote = report(out)
    same = ("score", "max_score", "status", "message")
    assert {s: [r[k] for k in same] for s, r in remote.items()} == {
        s: [r[k] for k in same] for s, r in local.items()
    }
    with Gradebook(f"sqlite:///{out / 'gradebook.db'}") as gb:
        assert gb.find_submission(LAB, "erin").score == 10


@pytest.fixture
def formgrader(interrupted_class: dict, tmp_path: Path) -> Iterator[str]:
    """nbgrader's formgrader over the graded class: ``jupyter server`` in OUT, loopback."""
    out, runtime = interrupted_class["out"], tmp_path / "runtime"
    log = open(tmp_path / "server.log", "wb")  # noqa: SIM115 (closed at teardown)
    server = subprocess.Popen(
        [sys.executable, "-m", "jupyter", "server", "--no-browser", "--ip=127.0.0.1"]
        + ["--port=0", "--IdentityProvider.token=t0ken"]
        + [f"--ServerApp.root_dir={out}", "--ServerApp.allow_root=True"],
        cwd=out,
        env={**os.environ, "JUPYTER_RUNTIME_DIR": str(runtime)},  # it says its port there
        stdout=log,
        stderr=log,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + HANG
        try:
            base = server_url(runtime, server, HANG)
        except (RuntimeError, TimeoutError) as exc:
            pytest.fail(f"{exc}:\n" + (tmp_path / "server.log").read_text())
        while True:
            assert server.poll() is None, (tmp_path / "server.log").read_text()
            assert time.monotonic() < deadline, "timeout: jupyter server did not answer"
            try:
                urllib.request.urlopen(f"{base}/api/status?token=t0ken", timeout=5)
                break
            except OSError:
                time.sleep(0.5)
        yield base
    finally:
        if server.poll() is None:
            os.killpg(server.pid, signal.SIGKILL)
        server.wait()
        log.close()


@pytest.mark.slow
def test_formgrader_shows_the_class_in_a_browser(formgrader: str, browser: object) -> None:
    page = browser.new_page()  # type: ignore[attr-defined]
    try:
        page.goto(f"{formgrader}/formgrader/manage_students?token=t0ken")
        page.locator("td.score").first.wait_for(timeout=HANG * 1000)
        scores = {
            row.locator("td.id").inner_text().strip(): row.locator("td.score").inner_text()
            for row in page.locator("tbody tr").all()
            if row.locator("td.score").count()
        }
        assert scores["alice"] == "10 / 10" and scores["carol"] == "0 / 10", scores
        # manual grading lists the graded notebooks (carol's file was not a notebook)
        page.goto(f"{formgrader}/formgrader/gradebook/{LAB}/{LAB}?token=t0ken")
        page.get_by_text("Submission #3").wait_for(timeout=HANG * 1000)
        graded = sorted(page.locator("td.name a.name-shown").all_text_contents())
        assert graded == ["alice", "bob", "erin"]
    finally:
        page.close()


def test_a_ctrl_c_while_a_row_is_saved_comes_after_the_row_is_saved_and_counted() -> None:
    """CI26: Ctrl-C landed between a row's saving and its counting; the grader then said
    "stopped: 0 of 4 submission(s) graded" with one row saved."""
    from rosbook.runtime.interrupts import ctrl_c_held

    steps = []
    with pytest.raises(KeyboardInterrupt):
        with ctrl_c_held():
            os.kill(os.getpid(), signal.SIGINT)  # as if Ctrl-C came now
            steps.append("saved")
            steps.append("counted")
        steps.append("after")  # never reached: the interrupt comes as the block ends
    assert steps == ["saved", "counted"]
