"""Hostile lab 1 submissions graded in one class with honest ones (``--workers 4``).

Each attack is a cell added to the lab as released (honestly 0/10: its code is not
written, and the quickest lab 1 there is to grade), so an attack that worked would show
as a changed score. None may earn a point, touch another row or file, or stop the run;
the honest rows score exactly as graded alone (tests/test_lab01.py).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from pathlib import Path

import nbformat
import pytest

from autograder.config import ROOT, SOLUTIONS
from tests.labtools import (
    LAB01,
    answered,
    extra_cell,
    feedback,
    grade,
    lab01_wrong,
    live_marked_processes,
    notebook_path,
    submit,
)

LAB = LAB01

pytestmark = pytest.mark.slow

HIDDEN = "values = [7, -2, 0, 2**40]"  # a line of lab 1's hidden tests
CANARY = "GRADER_ONLY_CANARY"
VICTIM_MARK = "VICTIM-NOTEBOOK-4f1c"


def attacks(root: Path, out: Path) -> dict[str, str]:
    victim = root / "victim" / LAB
    checks_py = ROOT / "rosbook" / "labs" / "lab01.py"
    return {
        # secrets read
        # every folder it can see but the installed software (read-only, the host's) and
        # /proc's endless views (read_other_notebook tries /proc/*/cwd), searched to its
        # end: a search stopped at the cell's limit would prove nothing
        "read_gradebook": "import os, sys\nfound, searched = ['../../../gradebook.db'], 0\n"
        "skip = {'/proc', '/sys', '/dev', '/usr', sys.prefix, sys.base_prefix}\n"
        "for top, dirs, files in os.walk('/'):\n    searched += 1\n"
        "    dirs[:] = [d for d in dirs if os.path.join(top, d) not in skip]\n"
        "    if 'gradebook.db' in files:\n        found.append(os.path.join(top, 'gradebook.db'))\n"
        "print(f'searched {searched} folders')\nfor p in found:\n    try:\n"
        "        print(open(p, 'rb').read())\n    except OSError as exc:\n        print(exc)",
        "read_solutions": f"print(open({str(SOLUTIONS / LAB / (LAB + '.ipynb'))!r}).read())",
        "read_environment": "import os\nprint(dict(os.environ))",
        "read_other_notebook": "import glob\nfor p in glob.glob('/proc/*/cwd/*.ipynb') + "
        f"[{str(victim / (LAB + '.ipynb'))!r}]:\n    try:\n        print(open(p).read())\n"
        "    except OSError as exc:\n        print(exc)",
        # others harmed
        "overwrite_feedback": f"open({str(out / 'feedback' / 'victim' / LAB / (LAB + '.html'))!r},"
        " 'w').write('PWNED')",
        "delete_other_file": f"import os\nos.remove({str(victim / 'notes.txt')!r})",
        "rewrite_checks": f"open({str(checks_py)!r}, 'a').write('\\nPWNED = True\\n')",
        "rewrite_gradebook": "import glob\nfor p in glob.glob('/tmp/rosbook-grade-*/template/*/"
        "gradebook.db'):\n    open(p, 'w').write('PWNED')",
        "forge_result_line": "import glob, json\nline = json.dumps({'score': 10, 'max_score': 10,"
        " 'status': 'ok', 'message': ''}) + '\\n'\nfor fd in glob.glob('/proc/*/fd/*'):\n"
        "    try:\n        open(fd, 'w').write(line)\n    except OSError:\n        pass",
        "kill_other_kernels": "import os, signal\nfor p in os.listdir('/proc'):\n"
        "    if p.isdigit() and int(p) not in (os.getpid(), os.getppid(), 1):\n"
        "        try:\n            os.kill(int(p), signal.SIGKILL)\n"
        "        except OSError:\n            pass",
        "flood_domains": "import rclpy\nfrom std_msgs.msg import Int64\nnodes = []\n"
        "for domain in range(0, 102, 10):\n    ctx = rclpy.Context()\n"
        "    rclpy.init(context=ctx, domain_id=domain)\n"
        "    node = rclpy.create_node('flood', context=ctx)\n"
        "    for topic in ('counter', 'numbers', 'doubled'):\n"
        "        pub = node.create_publisher(Int64, topic, 10)\n"
        "        for _ in range(50):\n            pub.publish(Int64(data=99))\n"
        "    nodes.append(node)",
        "surviving_child": "import subprocess, sys\nsubprocess.Popen([sys.executable, '-c', "
        "'import time; time.sleep(20); open(' + repr("
        f'{str(out / "grades.csv")!r}) + \', "w").write("PWNED")\'], start_new_session=True)',
        # resources
        "allocate_3gib": "block = bytearray(3 << 30)",
        "spawn_processes": "import subprocess\nkids = []\ntry:\n    for _ in range(1000):\n"
        "        kids.append(subprocess.Popen(['sleep', '600']))\nexcept OSError as exc:\n"
        "    print('stopped at', len(kids), exc)",
        "write_1gib": "with open('big', 'wb') as f:\n    for _ in range(1024):\n"
        "        f.write(b'x' * (1 << 20))",
        "listen_everywhere": "import socket\ns = socket.socket()\n"
        "s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)\ns.bind(('0.0.0.0', 8765))\n"
        "s.listen()",
        "print_200mb": "import sys\nfor _ in range(200):\n    sys.stdout.write('x' * (1 << 20))",
    }


def duplicated_cell() -> nbformat.NotebookNode:
    """JupyterLab's copy of the doubler cell (same grade_id), the copy edited."""
    notebook = answered(LAB)
    for index, cell in enumerate(notebook.cells):
        if cell.get("metadata", {}).get("nbgrader", {}).get("grade_id") == "doubler":
            copy = nbformat.from_dict(dict(cell))
            copy.source = cell.source + "\n# my second try"
            notebook.cells.insert(index + 1, copy)
            return notebook
    raise KeyError("doubler")


@pytest.fixture(scope="module")
def graded(tmp_path_factory: pytest.TempPathFactory):
    root = tmp_path_factory.mktemp("submissions")
    out = tmp_path_factory.mktemp("out")
    victim = answered(LAB)
    for cell in victim.cells:
        if cell.get("metadata", {}).get("nbgrader", {}).get("grade_id") == "doubler":
            cell.source += f"\n# {VICTIM_MARK}"
    submit(root, "victim", LAB, victim)
    (root / "victim" / LAB / "notes.txt").write_text("keep me")
    submit(root, "honest_wrong", LAB, lab01_wrong())
    submit(root, "duplicated_cell", LAB, duplicated_cell())
    for name, source in attacks(root, out).items():
        submit(root, name, LAB, extra_cell(nbformat.read(notebook_path(LAB), 4), source))
    big = answered(LAB)
    big.cells.append(nbformat.v4.new_markdown_cell("x" * (21 << 20)))
    submit(root, "huge_notebook", LAB, big)
    for name, target in (
        ("link_passwd", Path("/etc/passwd")),
        ("link_other", root / "victim" / LAB / f"{LAB}.ipynb"),
    ):
        (root / name / LAB).mkdir(parents=True)
        (root / name / LAB / f"{LAB}.ipynb").symlink_to(target)
    checks_py = ROOT / "rosbook" / "labs" / "lab01.py"
    before = hashlib.sha256(checks_py.read_bytes()).hexdigest()
    os.environ[CANARY] = "the grader's secret"
    try:
        rows = grade(root, out, assignment_id=LAB, workers=4, cell_timeout=60)
    finally:
        del os.environ[CANARY]
    return rows, out, root, before


def row(graded, student: str) -> dict[str, str]:
    return graded[0][(student, LAB)]


def said(graded, student: str) -> str:
    """What the grader said of ``student``'s row, and the judge's lines of its log: the
    reason a test's assertion shows when a row is not what it expects."""
    out = graded[1]
    for line in (out / "results.jsonl").read_text().splitlines():
        entry = json.loads(line)
        if entry["student_id"] == student:
            message = entry["message"]
    log = "".join(p.read_text() for p in (out / "logs" / student).glob("*.log"))
    judged = [line for line in log.splitlines() if line.startswith(("[judge]", "[grader]"))]
    return "\n".join([message, *judged])


def test_every_submission_gets_a_row(graded) -> None:
    names = set(attacks(Path("/"), Path("/")))
    names |= {"victim", "honest_wrong", "duplicated_cell", "huge_notebook"}
    names |= {"link_passwd", "link_other"}
    assert {s for s, _ in graded[0]} == names


def scored(graded, student: str) -> tuple[str, str]:
    return row(graded, student)["score"], row(graded, student)["status"]


def test_honest_rows_score_as_alone(graded) -> None:
    assert scored(graded, "victim") == ("10", "ok"), said(graded, "victim")
    assert scored(graded, "honest_wrong") == ("2", "ok"), said(graded, "honest_wrong")


def test_a_duplicated_cell_is_graded_fairly(graded) -> None:
    assert scored(graded, "duplicated_cell") == ("10", "ok"), said(graded, "duplicated_cell")


def test_no_attack_earns_a_point(graded) -> None:
    for name in attacks(Path("/"), Path("/")):
        r = row(graded, name)
        assert float(r["score"]) == 0, (name, r)  # what the release's code earns


def test_no_secret_reaches_the_feedback(graded) -> None:
    out = graded[1]
    for name in attacks(Path("/"), Path("/")):
        page = feedback(out, name, LAB)
        assert HIDDEN not in page and "BEGIN HIDDEN TESTS" not in page, name
        assert "SQLite format" not in page, name
        assert "the grader&#x27;s secret" not in page and "the grader's secret" not in page, name
        assert VICTIM_MARK not in page, name
    # the search for gradebooks ran to its end, finding none: one stopped by the cell's
    # time limit would have searched nothing
    assert re.search(r"searched \d+ folders", feedback(out, "read_gradebook", LAB))


def test_nobody_else_is_harmed(graded) -> None:
    rows, out, root, before = graded
    page = feedback(out, "victim", LAB)
    assert "PWNED" not in page and VICTIM_MARK in page
    assert (root / "victim" / LAB / "notes.txt").read_text() == "keep me"
    checks_py = ROOT / "rosbook" / "labs" / "lab01.py"
    assert hashlib.sha256(checks_py.read_bytes()).hexdigest() == before
    assert "PWNED" not in (out / "grades.csv").read_text()
    assert live_marked_processes() == []  # the surviving child died with its sandbox
    for log in (out / "logs").glob("*/*.log"):
        assert log.stat().st_size < 2 << 20, log  # a kernel cannot flood the grader's log


def test_resources_are_capped(graded) -> None:
    out = graded[1]
    assert len(feedback(out, "print_200mb", LAB)) < 8 << 20
    assert "output truncated" in feedback(out, "print_200mb", LAB)
    assert "MemoryError" in feedback(out, "allocate_3gib", LAB)
    assert "No space left on device" in feedback(out, "write_1gib", LAB)
    # The process limit stops the fork loop (test_sandbox.py proves the limit itself); on a
    # loaded machine the cell may reach its time limit first: a timeout, never a hang. The
    # programs it keeps are ended before the next cell: the rest is graded, not given up.
    spawned = feedback(out, "spawn_processes", LAB)
    assert "stopped at" in spawned or row(graded, "spawn_processes")["status"] == "timeout"
    assert "the grader ended" in spawned and "Grading was stopped" not in spawned


def test_links_and_huge_notebooks_are_refused_unread(graded) -> None:
    out = graded[1]
    for name in ("link_passwd", "link_other"):
        assert (row(graded, name)["score"], row(graded, name)["status"]) == ("0", "error")
        page = feedback(out, name, LAB)
        assert "symbolic link" in page and "root:x:0:0" not in page, name
    assert row(graded, "huge_notebook")["status"] == "error"
    assert "MB" in feedback(out, "huge_notebook", LAB)
