"""Scores come from the judge, not from the student's kernel: attacks graded for real.

Each attack is lab 1's "wrong" submission (only the subscriber is right: 2 points
earned by working code) plus one cell that makes the test cells pass inside the kernel.
Graded with the documented ``python -m autograder grade`` in one class with honest
submissions, none may score more than the 2 points its code earns, and every attack
whose test cells claimed a pass is marked ``tampered`` with the cells named.
"""

from __future__ import annotations

import base64
import csv
import html
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from autograder.config import ROOT
from tests.labtools import answered, feedback, grade, replace_in_answer, submit
from tests.test_lab01 import LAB, extra_cell, wrong

#: Each case grades attack notebooks with the documented command: out of `make test-fast`.
pytestmark = pytest.mark.slow

#: Replaces every check in the module ``_m`` (except building the node) by a mock
#: that accepts anything: the test cells then pass in the kernel whatever the code does.
NEUTER = """
from unittest import mock as _mock
for _name in list(vars(_m)):
    if not _name.startswith('_') and _name != 'make_node' and callable(getattr(_m, _name)):
        setattr(_m, _name, _mock.MagicMock())
"""

ATTACKS = {
    # The kernel runs every later cell, hidden tests included, as `pass`.
    "input_transformer": "get_ipython().input_transformers_post.append(lambda lines: ['pass\\n'])",
    # Test cells (they call checks.) become SystemExit, every other cell runs.
    "system_exit": (
        "get_ipython().input_transformers_post.append(\n"
        "    lambda lines: ['raise SystemExit(0)\\n'] if 'checks.' in ''.join(lines) else lines)"
    ),
    # Before every cell, the checks are replaced again.
    "pre_run_cell_hook": (
        "def _hook(info):\n    import rosbook.labs.lab01 as _m\n"
        + "\n".join("    " + ln for ln in NEUTER.strip().splitlines())
        + "\nget_ipython().events.register('pre_run_cell', _hook)"
    ),
    # Errors are neither shown nor reported: the cell looks like it passed.
    "post_run_cell_hook": (
        "ip = get_ipython()\nip.showtraceback = lambda *a, **k: None\n"
        "def _clear(result):\n    result.error_in_exec = None\n"
        "ip.events.register('post_run_cell', _clear)"
    ),
    # Cells that call the checks are run as `pass`.
    "run_cell_replaced": (
        "ip = get_ipython()\n_run, _run_async = ip.run_cell, ip.run_cell_async\n"
        "def _skip(cell):\n    return 'pass' if 'checks.' in cell else cell\n"
        "ip.run_cell = lambda raw_cell, *a, **k: _run(_skip(raw_cell), *a, **k)\n"
        "ip.run_cell_async = lambda raw_cell, *a, **k: _run_async(_skip(raw_cell), *a, **k)"
    ),
    "importlib": "import importlib\n_m = importlib.import_module('rosbook.labs.lab01')" + NEUTER,
    "alias": "import rosbook.labs.lab01 as _m" + NEUTER,
    "sys_modules": "import sys\n_m = sys.modules['rosbook.labs.lab01']" + NEUTER,
    "gc": (
        "import gc\n_m = next(o for o in gc.get_objects()\n"
        "          if type(o).__name__ == 'module' and o.__name__ == 'rosbook.labs.lab01')" + NEUTER
    ),
    "exec_base64": (
        "import base64\nexec(base64.b64decode("
        + repr(base64.b64encode(("import rosbook.labs.lab01 as _m" + NEUTER).encode()).decode())
        + "))"
    ),
    # `checks` is looked up in the builtins once the notebook's own name is gone.
    "builtins_override": (
        "import builtins, types\n_m = types.SimpleNamespace(**vars(checks))"
        + NEUTER
        + "builtins.checks = _m\ndel checks"
    ),
    # A test cell's output that says "pass", and no error output at all.
    "fake_pass_printed": (
        "ip = get_ipython()\nip.showtraceback = lambda *a, **k: print('PASS: all checks passed')"
    ),
}

#: The attack that ships a package: the submission folder holds its own `rosbook`
#: (the real one, with neutered checks), first on the kernel's sys.path.
SHIPPED = "shipped_rosbook"


def ship_rosbook(root: Path) -> None:
    package = root / SHIPPED / LAB / "rosbook"
    shutil.copytree(ROOT / "rosbook", package, ignore=shutil.ignore_patterns("__pycache__"))
    checks = package / "labs" / "lab01.py"  # what lab 1 imports as `checks`
    checks.write_text(checks.read_text() + "\nimport sys as _s\n_m = _s.modules[__name__]" + NEUTER)


def duplicated_cell() -> nbformat.NotebookNode:
    """JupyterLab's copy of a solution cell keeps its nbgrader metadata."""
    notebook = answered(LAB)
    index = next(
        i
        for i, c in enumerate(notebook.cells)
        if c.metadata.get("nbgrader", {}).get("grade_id") == "counter_subscriber"
    )
    notebook.cells.insert(index + 1, nbformat.from_dict(dict(notebook.cells[index])))
    return notebook


@pytest.fixture(scope="module")
def graded(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, dict[str, str]], Path]:
    root = tmp_path_factory.mktemp("submissions")
    submit(root, "right", LAB, answered(LAB))
    submit(root, "wrong", LAB, wrong())
    submit(root, "duplicated_cell", LAB, duplicated_cell())
    # rclpy.spin() left at the end of a solution cell: a timer wakes the spin, so the
    # interrupt stops it; a subscription alone never wakes it, and the kernel stays busy.
    spinning = replace_in_answer(
        LAB,
        "counter_publisher",
        "self.count += 1",
        "self.count += 1\n\n\nimport rclpy\nrclpy.spin(CounterPublisher())",
    )
    submit(root, "spin_left_in_cell", LAB, answered(LAB, **spinning))
    stuck = replace_in_answer(
        LAB, "doubler", "2 * msg.data))", "2 * msg.data))\n\n\nimport rclpy\nrclpy.spin(Doubler())"
    )
    submit(root, "spin_stuck_in_cell", LAB, answered(LAB, **stuck))
    for name, source in ATTACKS.items():
        submit(root, name, LAB, extra_cell(wrong(), source))
    submit(root, SHIPPED, LAB, wrong())
    ship_rosbook(root)
    out = tmp_path_factory.mktemp("out")
    done = subprocess.run(
        [sys.executable, "-m", "autograder", "grade", str(root), "--assignment", LAB,
         "--workers", "2", "--timeout", "30", "--out", str(out)],
        capture_output=True, text=True, timeout=3600, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    with open(out / "grades.csv") as f:
        rows = {r["student_id"]: r for r in csv.DictReader(f)}
    return rows, out


def test_honest_submissions_score_as_their_code_earns(graded) -> None:
    rows, _ = graded
    assert (rows["right"]["score"], rows["right"]["status"]) == ("10", "ok")
    assert (rows["wrong"]["score"], rows["wrong"]["status"]) == ("2", "ok")


def test_a_duplicated_solution_cell_is_graded_like_the_original(graded) -> None:
    rows, _ = graded
    assert (rows["duplicated_cell"]["score"], rows["duplicated_cell"]["status"]) == ("10", "ok")


def test_a_spin_left_in_a_cell_costs_only_that_cell_and_is_named(graded) -> None:
    rows, out = graded
    assert (rows["spin_left_in_cell"]["score"], rows["spin_left_in_cell"]["status"]) == (
        "10",
        "timeout",
    )
    assert "interrupted: counter_publisher." in feedback(out, "spin_left_in_cell", LAB)


def test_a_kernel_left_busy_keeps_the_points_earned_before_it(graded) -> None:
    """nbgrader does not abandon the notebook (it used to: 0/10 "error")."""
    rows, out = graded
    r = rows["spin_stuck_in_cell"]
    assert (r["score"], r["status"]) == ("5", "timeout")  # publisher 3 + subscriber 2
    assert "interrupted: doubler" in feedback(out, "spin_stuck_in_cell", LAB)


@pytest.mark.parametrize("attack", [*ATTACKS, SHIPPED])
def test_an_attack_in_the_kernel_earns_no_point_its_code_did_not(graded, attack: str) -> None:
    rows, out = graded
    r = rows[attack]
    assert float(r["score"]) <= 2, r  # the wrong submission's code earns 2
    page = feedback(out, attack, LAB)
    if r["status"] == "tampered":
        assert "test_doubler" in page or "Grading code changed" in page, page[:2000]


@pytest.mark.parametrize(
    "attack",
    [
        "input_transformer",
        "pre_run_cell_hook",
        "post_run_cell_hook",
        "run_cell_replaced",
        "importlib",
        "alias",
        "sys_modules",
        "gc",
        "exec_base64",
        "builtins_override",
        SHIPPED,
    ],
)
def test_a_pass_claimed_in_the_kernel_but_not_judged_is_flagged_by_cell(graded, attack) -> None:
    rows, out = graded
    assert rows[attack]["status"] == "tampered"
    page = feedback(out, attack, LAB)
    assert "Checks that passed only inside your notebook" in page
    assert "test_talker_script" in page


def test_lab4_functions_are_judged_by_their_return_values(tmp_path: Path) -> None:
    """Lab 4's checks replaced in the kernel: the judge calls the functions itself."""
    from tests.test_lab04 import LAB as LAB4
    from tests.test_lab04 import axis_wrong

    root = tmp_path / "submissions"
    attack = "import rosbook.labs.lab04 as _m" + NEUTER.replace("'make_node'", "'load'")
    notebook = axis_wrong()
    notebook.cells.insert(2, nbformat.v4.new_code_cell(attack))
    submit(root, "neutered_urdf_checks", LAB4, notebook)
    out = tmp_path / "out"
    rows = grade(root, out, assignment_id=LAB4, workers=1, cell_timeout=60)
    r = rows[("neutered_urdf_checks", LAB4)]
    assert (r["score"], r["status"]) == ("3", "tampered")  # only wheel_separation is right
    page = feedback(out, "neutered_urdf_checks", LAB4)
    assert "Checks that passed only inside your notebook" in page and "test_arm_fk" in page


#: Replaces every function of the module ``_m`` by one that accepts anything and whose
#: result accepts anything (a MagicMock refuses ``report.assert_rates``).
LAB6_NEUTER = """
class _Anything:
    def __call__(self, *a, **k):
        return self
    def __getattr__(self, name):
        return self
for _name in list(vars(_m)):
    if not _name.startswith('_') and callable(getattr(_m, _name)):
        setattr(_m, _name, _Anything())
"""

#: Lab 6's attacks, each a cell added to the untouched release (its code earns 0).
LAB6_ATTACKS = {
    "lab6_input_transformer": ATTACKS["input_transformer"],
    "lab6_pre_run_cell_hook": (
        "def _hook(info):\n    import rosbook.labs.lab06 as _m\n"
        + "\n".join("    " + ln for ln in LAB6_NEUTER.strip().splitlines())
        + "\nget_ipython().events.register('pre_run_cell', _hook)"
    ),
    "lab6_checks_patched": "import rosbook.labs.lab06 as _m" + LAB6_NEUTER,
}


def attacked_release(
    tmp_path: Path,
    lab: str,
    attacks: dict[str, str],
    cell: str,
    others: dict[str, nbformat.NotebookNode] | None = None,
) -> tuple[dict[tuple[str, str], dict[str, str]], Path]:
    """``lab``'s release with each attack added, graded (with ``others``) by the
    documented command: every attack scores 0, is ``tampered``, and its feedback names
    ``cell`` as a check that passed only inside the notebook. The rows and OUT."""
    from tests.labtools import notebook_path

    root = tmp_path / "submissions"
    for name, source in attacks.items():
        submit(root, name, lab, extra_cell(nbformat.read(notebook_path(lab), 4), source))
    for name, notebook in (others or {}).items():
        submit(root, name, lab, notebook)
    out = tmp_path / "out"
    rows = grade(root, out, assignment_id=lab, workers=2, cell_timeout=120)
    for name in attacks:
        r = rows[(name, lab)]
        assert (r["score"], r["status"]) == ("0", "tampered"), r
        page = feedback(out, name, lab)
        assert "Checks that passed only inside your notebook" in page, page[:2000]
        assert cell in page
    return rows, out


def test_lab6_builds_and_launches_are_judged_outside_the_kernel(tmp_path: Path) -> None:
    """Lab 6's checks skipped or replaced in the kernel earn nothing: the judge builds,
    runs and launches the student's work itself; and no process is left behind."""
    from tests.test_lab01 import live_marked_processes

    lab6 = "lab06_launch_system"
    # test_two_robots: its check is a module function, replaced
    rows, out = attacked_release(tmp_path, lab6, LAB6_ATTACKS, "test_two_robots")
    # the transformer also turned the manifest's check (a plain assert first) into `pass`
    assert "test_package_manifest" in feedback(out, "lab6_input_transformer", lab6)
    assert live_marked_processes() == []


def _cwd_within(folder: Path) -> list[int]:
    """Live processes whose working folder is ``folder`` or below it."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            cwd = Path(os.readlink(entry / "cwd"))
        except (OSError, ValueError):
            continue
        if entry.name.isdigit() and (cwd == folder or folder in cwd.parents):
            found.append(int(entry.name))
    return found


def test_lab6_judge_names_an_int_rate_and_leaves_no_process(tmp_path: Path) -> None:
    """The judge itself (a kernel of the student's own, unsandboxed as in a self-check):
    an int rate kills the talker at launch; the verdict says why, and every process of
    the launch is gone afterwards (stopped by one Ctrl-C to `ros2 launch`)."""
    from jupyter_client import KernelManager

    from autograder.judge import Verdict
    from tests.labtools import answered, replace_in_answer

    lab6 = "lab06_launch_system"
    notebook = answered(
        lab6,
        **replace_in_answer(
            lab6, "two_robots", "('robot1', 2.0), ('robot2', 5.0)", "('robot1', 2), ('robot2', 5)"
        ),
    )
    kernel_home, folder = tmp_path / "kernel", tmp_path / "judge"
    kernel_home.mkdir()
    folder.mkdir()
    km = KernelManager()
    km.start_kernel(cwd=str(kernel_home))
    try:
        client = km.client()
        client.start_channels()
        client.wait_for_ready(timeout=60)
        for gid in ("setup", "two_robots"):
            cell = next(
                c for c in notebook.cells if c.metadata.get("nbgrader", {}).get("grade_id") == gid
            )
            reply = client.execute_interactive(cell.source, timeout=120, output_hook=lambda m: None)
            assert reply["content"]["status"] == "ok", reply["content"]
        request = {"assignment": lab6, "check": "test_two_robots",
                   "connection_file": km.connection_file, "folder": str(folder)}  # fmt: skip
        judged = subprocess.run(
            [sys.executable, "-I", "-m", "autograder.judge"],
            input=json.dumps(request) + "\n", capture_output=True, text=True,
            timeout=600, check=False, cwd=ROOT,
        )  # fmt: skip
        client.stop_channels()
    finally:
        km.shutdown_kernel(now=True)
    assert judged.returncode == 0, judged.stderr[-3000:]
    verdict = Verdict(**json.loads(judged.stdout.splitlines()[-1]))
    assert not verdict.passed and not verdict.timeout, verdict
    assert "exited right after the launch with code 1" in verdict.message, verdict.message
    assert "The rate must be a float" in verdict.message
    assert "InvalidParameterTypeException" in verdict.message
    assert _cwd_within(folder) == []


# -- labs 2 and 3: QoS and services decided by the judge --------------------------------

#: Each lab's checks module, as its notebook imports it.
JUDGED_MODULES = {"lab02_qos": "rosbook.labs.lab02", "lab03_services_actions": "rosbook.labs.lab03"}


def lab_attacks(lab: str) -> dict[str, str]:
    """Attacks on the test cells of ``lab``: every later cell turned into `pass`; only the
    test cells (all call the lab's checks module) turned into `pass`; the checks replaced
    before every cell by a hook; the checks module patched once."""
    module = JUDGED_MODULES[lab]
    alias = "qos_checks" if lab == "lab02_qos" else "service_checks"
    return {
        "input_transformer": ATTACKS["input_transformer"],
        "test_cells_transformed": (
            "get_ipython().input_transformers_post.append(\n"
            f"    lambda lines: ['pass\\n'] if '{alias}.' in ''.join(lines) else lines)"
        ),
        "pre_run_cell_hook": ATTACKS["pre_run_cell_hook"].replace("rosbook.labs.lab01", module),
        "patched_checks": f"import {module} as _m" + NEUTER,
    }


def honest_wrong(lab: str) -> nbformat.NotebookNode:
    """Lab 2: a VOLATILE map publisher (7 of 10). Lab 3: a service callback that returns
    nothing (8 of 10)."""
    if lab == "lab02_qos":
        from tests.test_lab02 import volatile_map_publisher

        return volatile_map_publisher()
    return answered(lab, **replace_in_answer(lab, "clock_server", "return response", "response"))


#: What the honest but wrong submission earns, and what the judge tells it.
EARNED = {"lab02_qos": 7, "lab03_services_actions": 8}
TOLD = {
    "lab02_qos": ("test_map_publisher", "use durability=DurabilityPolicy.TRANSIENT_LOCAL"),
    "lab03_services_actions": (
        "test_clock_server",
        "end the callback with `return response`",
    ),
}


@pytest.fixture(scope="module", params=list(JUDGED_MODULES))
def graded_lab(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory):
    lab = request.param
    root = tmp_path_factory.mktemp("submissions")
    submit(root, "honest_wrong", lab, honest_wrong(lab))
    for name, source in lab_attacks(lab).items():
        submit(root, name, lab, extra_cell(honest_wrong(lab), source))
    out = tmp_path_factory.mktemp("out")
    return lab, grade(root, out, assignment_id=lab, workers=2, cell_timeout=30), out


def test_an_honest_wrong_submission_of_labs_2_and_3_scores_what_its_code_earns(
    graded_lab,
) -> None:
    lab, rows, _ = graded_lab
    r = rows[("honest_wrong", lab)]
    assert (r["score"], r["status"]) == (str(EARNED[lab]), "ok"), r


@pytest.mark.parametrize("attack", list(lab_attacks("lab02_qos")))
def test_an_attack_on_labs_2_and_3_earns_no_point_and_is_told_the_judges_finding(
    graded_lab, attack: str
) -> None:
    lab, rows, out = graded_lab
    r = rows[(attack, lab)]
    assert float(r["score"]) <= EARNED[lab], r
    assert r["status"] == "tampered", r
    if attack == "input_transformer":
        return  # every cell was `pass`: nothing was defined, nothing to tell
    if lab == "lab02_qos" and attack != "test_cells_transformed":
        return  # lab 2's map cell asserts on what the (mocked) check returned: it fails
    page = html.unescape(re.sub(r"<[^>]+>", "", feedback(out, attack, lab)))
    assert "Checks that passed only inside your notebook" in page
    cell, told = TOLD[lab]
    assert cell in page and told in page, page[-3000:]


# -- lab 5: the simulator runs in the judge ---------------------------------------------

LAB5 = "lab05_diff_drive"

#: Lab 5's attacks, each a cell added to the untouched release (its code earns 0).
LAB5_ATTACKS = {
    "lab5_input_transformer": ATTACKS["input_transformer"],
    "lab5_pre_run_cell_hook": ATTACKS["pre_run_cell_hook"].replace(
        "rosbook.labs.lab01", "rosbook.labs.lab05"
    ),
    "lab5_checks_patched": "import rosbook.labs.lab05 as _m" + NEUTER,
}
#: Only the test cells (all call ``checks.``) turned into `pass`: the student's cells run.
LAB5_TEST_CELLS_PASS = (
    "get_ipython().input_transformers_post.append(\n"
    "    lambda lines: ['pass\\n'] if 'checks.' in ''.join(lines) else lines)"
)


def test_lab5_drives_are_judged_by_the_judges_own_simulator(tmp_path: Path) -> None:
    """Lab 5's test cells skipped or its checks replaced in the kernel earn nothing; a
    submission whose driving works but whose kinematics are wrong keeps exactly the
    driving points under the same attack (the judge ran its simulator against the node)."""
    from tests.test_lab05 import fixtures

    swapped = extra_cell(fixtures()["swapped"], LAB5_TEST_CELLS_PASS)  # type: ignore[arg-type]
    # test_go_to_pose: its cell only calls checks, replaced
    rows, out = attacked_release(
        tmp_path, LAB5, LAB5_ATTACKS, "test_go_to_pose", {"lab5_swapped_transformed": swapped}
    )
    r = rows[("lab5_swapped_transformed", LAB5)]
    assert (r["score"], r["status"]) == ("8", "tampered"), r
    page = feedback(out, "lab5_swapped_transformed", LAB5)
    # the cell that claimed a pass, and the judge's finding in the lab's words
    assert "test_wheel_speeds" in page and "left and right are swapped" in page
