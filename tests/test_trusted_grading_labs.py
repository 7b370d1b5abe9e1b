"""Labs 2 to 6: scores come from the judge, not from the student's kernel.

Each lab's checks skipped or replaced inside the kernel (an input transformer, a hook
before each cell, the checks module patched) earn no point the code did not earn, and the
feedback names the cells that passed only inside the notebook. Lab 1's attacks, the
catalogue these reuse, are in ``test_trusted_grading.py``.
"""

from __future__ import annotations

import html
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest

from autograder.config import ROOT
from tests.labtools import (
    ATTACKS,
    LAB04,
    LAB05,
    NEUTER,
    answered,
    extra_cell,
    feedback,
    grade,
    lab02_volatile_map_publisher,
    lab04_axis_wrong,
    lab05_swapped,
    live_marked_processes,
    replace_in_answer,
    submit,
)

#: Each case grades attack notebooks with the documented command: out of `make test-fast`.
pytestmark = pytest.mark.slow


def test_lab4_functions_are_judged_by_their_return_values(tmp_path: Path) -> None:
    """Lab 4's checks replaced in the kernel: the judge calls the functions itself."""

    root = tmp_path / "submissions"
    attack = "import rosbook.labs.lab04 as _m" + NEUTER.replace("'make_node'", "'load'")
    notebook = lab04_axis_wrong()
    notebook.cells.insert(2, nbformat.v4.new_code_cell(attack))
    submit(root, "neutered_urdf_checks", LAB04, notebook)
    out = tmp_path / "out"
    rows = grade(root, out, assignment_id=LAB04, workers=1, cell_timeout=60)
    r = rows[("neutered_urdf_checks", LAB04)]
    assert (r["score"], r["status"]) == ("3", "tampered")  # only wheel_separation is right
    page = feedback(out, "neutered_urdf_checks", LAB04)
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
    from autograder.judge import Verdict, setup_cells
    from rosbook.runtime.kernels import UnixSocketKernelManager
    from tests.labtools import answered, grade_id, notebook_path, replace_in_answer

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
    km = UnixSocketKernelManager()
    km.start_kernel(cwd=str(kernel_home))
    try:
        client = km.client()
        client.start_channels()
        client.wait_for_ready(timeout=60)
        for gid in ("setup", "two_robots"):
            cell = next(c for c in notebook.cells if grade_id(c) == gid)
            reply = client.execute_interactive(cell.source, timeout=120, output_hook=lambda m: None)
            assert reply["content"]["status"] == "ok", reply["content"]
        source = nbformat.read(notebook_path(lab6, released=False), as_version=4)
        test = next(c for c in source.cells if grade_id(c) == "test_two_robots")
        request = {"assignment": lab6, "check": "test_two_robots",
                   "connection_file": km.connection_file, "folder": str(folder),
                   "source": test.source, "setup": setup_cells(source)}  # fmt: skip
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
    return {
        "input_transformer": ATTACKS["input_transformer"],
        "test_cells_transformed": (
            "get_ipython().input_transformers_post.append(\n"
            "    lambda lines: ['pass\\n'] if 'checks.' in ''.join(lines) else lines)"
        ),
        "pre_run_cell_hook": ATTACKS["pre_run_cell_hook"].replace("rosbook.labs.lab01", module),
        "patched_checks": f"import {module} as _m" + NEUTER,
    }


def honest_wrong(lab: str) -> nbformat.NotebookNode:
    """Lab 2: a VOLATILE map publisher (7 of 10). Lab 3: a service callback that returns
    nothing (8 of 10)."""
    if lab == "lab02_qos":
        return lab02_volatile_map_publisher()
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
    swapped = extra_cell(lab05_swapped(), LAB5_TEST_CELLS_PASS)
    # test_go_to_pose: its cell only calls checks, replaced
    rows, out = attacked_release(
        tmp_path, LAB05, LAB5_ATTACKS, "test_go_to_pose", {"lab5_swapped_transformed": swapped}
    )
    r = rows[("lab5_swapped_transformed", LAB05)]
    assert (r["score"], r["status"]) == ("8", "tampered"), r
    page = feedback(out, "lab5_swapped_transformed", LAB05)
    # the cell that claimed a pass, and the judge's finding in the lab's words
    assert "test_wheel_speeds" in page and "left and right are swapped" in page
