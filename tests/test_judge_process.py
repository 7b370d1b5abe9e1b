"""The judge process's life around one submission, and what it reads from a kernel.

Grading speed depends on both ends: the judge starts (interpreter, rclpy, ROS) while the
kernel starts rather than at the first judged cell, and it ends as soon as its stdin
closes instead of asking the already shut-down kernel for a last "stop". Between them,
a guard the judge hits while waiting on a kernel's node says timeout, never wrong.
"""

from __future__ import annotations

import base64
import json
import re
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import nbformat
import pytest

from autograder import judge, sandbox, verdicts
from autograder.verdicts import judging
from rosbook.labs import remote
from rosbook.runtime.kernels import UnixSocketKernelManager
from rosbook.runtime.session import Session
from tests.labtools import (
    answered,
    grade_id,
    notebook_path,
    replace_in_answer,
    solution_answers,
    strip_markers,
)


def test_a_verdict_is_awaited_at_least_as_long_as_the_cells_own_limit() -> None:
    """A cell whose checks run several guarded programs (lab 8 runs pytest seven times)
    may take longer than the verdict guard on a loaded machine: a raised cell limit
    (``--timeout``) raises the wait for its verdict too, so it is a verdict, not a timeout."""
    assert verdicts.verdict_guard(600) == 600
    assert verdicts.verdict_guard(None) == verdicts.verdict_guard(60) == verdicts.VERDICT_GUARD_S


def test_the_judge_starts_with_the_submission_before_any_cell() -> None:
    with sandbox.Network() as network, sandbox.using(network):
        with judging("lab01_nodes_topics") as run:
            process = run.process
            assert process is not None and process.poll() is None
            assert run.verdicts == {}
        assert run.process is None and process.poll() is not None  # ended with the block


def test_a_lab_added_as_a_notebook_alone_is_judged_too() -> None:
    """A lab with no file of the grader's (its test cells are the judge's script) has
    every test cell decided by the judge, which starts with the submission."""
    with sandbox.Network() as network, sandbox.using(network):
        with judging("lab99_new") as run:
            assert run.cells == set()  # none met yet; each will be judged
            assert run.process is not None and run.process.poll() is None


def test_a_judge_prepares_a_notebook_labs_setup_and_preload_before_its_first_cell() -> None:
    """The judge of a lab graded by its notebook alone runs the notebook's setup cells
    and imports what the lab's checks show figures with (``PRELOAD``) at its start,
    while the kernel starts, as a judge module's ``PRELOAD`` was: not in the first cell."""
    import subprocess
    import sys

    probe = (
        "import sys\n"
        "from autograder import judge\n"
        "before = 'rosbook.viz.twin' in sys.modules, bool(judge._setups)\n"
        "judge.prepare('lab05_diff_drive')\n"
        "print(before, ('rosbook.viz.twin' in sys.modules, bool(judge._setups)))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=300, check=True
    )
    assert done.stdout.split("\n")[-2] == "(False, False) (True, True)", done.stdout + done.stderr


def test_what_a_check_shows_travels_with_its_verdict(tmp_path: Path) -> None:
    """A figure the judge shows (``Judgement.show``) is a notebook output in the verdict
    the grader reads back: the test cell shows it instead of making it in the kernel."""
    from dataclasses import asdict

    import matplotlib.pyplot as plt
    import nbformat
    from IPython.display import Image

    from rosbook.sim.plot import png

    j = remote.Judgement(kernel=None, folder=tmp_path)  # type: ignore[arg-type]
    j.show(Image(png(plt.figure(figsize=(1, 1)))))
    sent = json.dumps(asdict(judge.Verdict("test_x", False, "wrong", outputs=j.outputs)))
    (output,) = judge.Verdict(**json.loads(sent)).outputs
    nbformat.validator.validate(
        nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(outputs=[output])])
    )
    assert base64.b64decode(output["data"]["image/png"]).startswith(b"\x89PNG")


def test_closing_a_kernel_sends_it_nothing(tmp_path: Path) -> None:
    """When the judge's stdin closes, the kernel is already gone: a last call would
    only wait out its guard (10 s per submission, every submission)."""
    connection = tmp_path / "kernel.json"
    connection.write_text(
        json.dumps(
            {
                "transport": "ipc",
                "ip": str(tmp_path / "k"),
                "shell_port": 1,
                "iopub_port": 2,
                "stdin_port": 3,
                "control_port": 4,
                "hb_port": 5,
                "key": "",
                "signature_scheme": "hmac-sha256",
            }
        )
    )
    kernel = remote.Kernel(str(connection))
    kernel.agent_ready = True  # as after a check: the agent was defined
    sent: list[dict] = []
    kernel.client.session.send = lambda *a, **k: sent.append({"args": a})  # type: ignore[method-assign]
    kernel.close()
    assert sent == []


class Following:
    """The kernel's node following a ``/clock`` of the test's own node ``name``
    (``JudgeAgent.follow_clock`` up to ``until``), once it has said its first ack; ``acked``
    holds its acks as the judge reads them."""

    def __init__(
        self,
        session: Session,
        kernel: remote.Kernel,
        name: str,
        until: float,
        gate: str | None = None,
    ) -> None:
        from std_msgs.msg import String

        from rosbook.labs.agent import ACK_TOPIC
        from rosbook.labs.lockstep import read_ack

        self.session, self.kernel, self.until = session, kernel, until
        self.node = remote.ros_node(name)
        self.acked = [read_ack("")]
        self.node.create_subscription(
            String, ACK_TOPIC, lambda m: self.acked.append(read_ack(m.data)), 10
        )
        self.following = kernel.send("follow_clock", until, 60.0, gate)
        assert session.spin_until(lambda: self.acked[-1]["now"] >= 0, self.node, timeout=60)

    def finish(self) -> list[Any]:
        """Publish ``/clock`` at ``until`` until the kernel answers; its answer, in a list,
        once its ack of ``until`` has arrived too."""
        clock = remote.clock_publisher(self.node)
        target = int(round(self.until * 1e9))
        done: list[Any] = []
        waiter = threading.Thread(
            target=lambda: done.append(self.kernel.answer(self.following, 60))
        )
        waiter.start()
        while waiter.is_alive():
            clock.publish(remote.clock_message(self.until))
            self.session.spin_until(lambda: not waiter.is_alive(), self.node, timeout=0.2)
        assert self.session.spin_until(
            lambda: self.acked[-1]["now"] >= target, self.node, timeout=60
        )
        return done


def test_a_kernel_says_which_subscriptions_its_node_can_send_to(session: Session) -> None:
    """A publisher sends only to the subscriptions its own participant has discovered;
    the judge's side matching says nothing of that (each side discovers on its own), and
    a message sent before is lost, not late: lab 3's judge lost an action's first
    feedback that way. While following the judge's /clock the kernel names, in its acks,
    the subscriptions its node discovered on each topic it sends on, and the judge waits
    to be among them before time moves."""
    from std_msgs.msg import Int64

    from rosbook.labs.lockstep import wait_until_discovered

    talker = (
        "from rclpy.node import Node\n"
        "from std_msgs.msg import Int64\n"
        "class Talker(Node):\n"
        "    def __init__(self):\n"
        "        super().__init__('talker')\n"
        "        self.pub = self.create_publisher(Int64, 'counter', 10)\n"
    )
    with judged_kernel(talker) as kernel:
        assert kernel.call("start", "Talker", {}, True)["name"] == "talker"
        run = Following(session, kernel, "judge_listener", until=1.0)
        node, acked = run.node, run.acked
        assert acked[-1]["readers"] == {"/counter": set()}  # nobody listens yet
        node.create_subscription(Int64, "/counter", lambda m: None, 10)
        wait_until_discovered(acked, node, "/counter", "judge_listener", "talker")
        (mine,) = node.get_subscriptions_info_by_topic("/counter")
        assert acked[-1]["readers"]["/counter"] == {bytes(mine.endpoint_gid).hex()}
        assert run.finish() == [{"timeout": False}]


def test_a_kernel_says_when_it_has_discovered_the_judges_publisher(
    session: Session, tmp_path: Path
) -> None:
    """The other way round: a subscription takes nothing from a publisher its own
    participant has not discovered, and what that publisher sent before is lost. Lab 1's
    judge waited for its publisher to match on its own side only, and lost the first
    value sent to a subscriber on a busy machine (the 7 of [7, -2, 0, ...]). The kernel
    says when it has discovered the judge's publisher (``await_writers``): not for a
    publisher that does not exist, and for the judge's once discovery found it."""
    from std_msgs.msg import Int64

    from rosbook.labs.lockstep import await_discovered_by

    with judged_kernel(QUEUED_SUBSCRIBER + IN_ORDER) as kernel:
        assert kernel.call("start", "CounterSubscriber", {}, False)["name"] == "counter_subscriber"
        sender = remote.ros_node("judge_sender")
        try:
            assert not kernel.call("await_writers", "/counter", ["00" * 16], 0.2)
            pub = sender.create_publisher(Int64, "/counter", 10)
            assert session.spin_until(lambda: pub.get_subscription_count() > 0, sender, timeout=60)
            await_discovered_by(
                remote.Judgement(kernel, tmp_path), sender, "/counter", "counter_subscriber"
            )
            (mine,) = sender.get_publishers_info_by_topic("/counter")
            assert kernel.call("await_writers", "/counter", [bytes(mine.endpoint_gid).hex()], 0.0)
            pub.publish(Int64(data=7))
            assert kernel.call("spin_until_length", "received", 1, 30.0) == [7]
        finally:
            session.remove(sender)


def test_a_kernel_acks_a_time_once_every_callback_due_then_has_run(session: Session) -> None:
    """The judge stamps what the kernel's node sent with the time it acked: every
    callback due at that time must have run before the ack, however many fall due
    together (the agent ran a fixed 8, so a ninth timer's message was stamped late)."""
    timers = (
        "from rclpy.node import Node\n"
        "from std_msgs.msg import Int64\n"
        "class Many(Node):\n"
        "    def __init__(self):\n"
        "        super().__init__('many')\n"
        "        self.pub = self.create_publisher(Int64, 'counter', 10)\n"
        "        self.ticks = [self.create_timer(0.1, self.tick) for _ in range(12)]\n"
        "    def tick(self):\n"
        "        self.pub.publish(Int64(data=1))\n"
    )
    with judged_kernel(timers) as kernel:
        assert kernel.call("start", "Many", {}, True)["name"] == "many"
        run = Following(session, kernel, "judge_acks", until=0.1)
        assert run.finish() == [{"timeout": False}]
        first = next(ack for ack in run.acked if ack["now"] >= 100_000_000)
        assert first["published"].get("/counter") == 12, first


#: A node whose timer records its time and the stamp of the latest odom it took.
READER = (
    "from rclpy.node import Node\n"
    "from nav_msgs.msg import Odometry\n"
    "class Reader(Node):\n"
    "    def __init__(self):\n"
    "        super().__init__('reader')\n"
    "        self.seen, self.records = None, []\n"
    "        self.create_subscription(Odometry, 'odom', self.on_odom, 10)\n"
    "        self.timer = self.create_timer(0.1, self.tick)\n"
    "    def on_odom(self, msg):\n"
    "        self.seen = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec\n"
    "    def tick(self):\n"
    "        self.records.append([self.get_clock().now().nanoseconds, self.seen])\n"
)


def test_a_gated_time_moves_on_in_the_kernel_once_the_reading_stamped_with_it_is_taken(
    session: Session,
) -> None:
    """Lab 5's judge sends a step's odom and its /clock together (one round trip per
    step): the kernel holds the new time until its node has taken the odom stamped with
    it, so a controller's timer at that time acts on that reading, however the two
    messages arrive."""
    from nav_msgs.msg import Odometry

    with judged_kernel(READER) as kernel:
        assert kernel.call("start", "Reader", {}, True)["name"] == "reader"
        run = Following(session, kernel, "judge_odom", until=0.2, gate="/odom")
        odom = run.node.create_publisher(Odometry, "/odom", 10)
        assert session.spin_until(lambda: odom.get_subscription_count() > 0, run.node, timeout=60)
        clock = remote.clock_publisher(run.node)
        step = 100_000_000

        def acked_step() -> bool:
            return run.acked[-1]["now"] >= step

        # the time first: held (a kernel without the gate acks it at once, its timer
        # having run without the reading); /clock is best effort, so sent again
        for _ in range(10):
            clock.publish(remote.clock_message(0.1))
            if session.spin_until(acked_step, run.node, timeout=0.2):
                break
        msg = Odometry()
        msg.header.stamp.nanosec = step
        odom.publish(msg)
        for _ in range(300):
            clock.publish(remote.clock_message(0.1))
            if session.spin_until(acked_step, run.node, timeout=0.2):
                break
        assert acked_step(), "timeout: the kernel did not ack t = 0.1 s after its odom"
        assert run.finish() == [{"timeout": False}]
        records = kernel.call("spin_until_length", "records", 1, 10.0)
        assert records[0] == [step, step], records


def test_the_judges_drive_is_the_kernels_own_simulation_to_the_bit(session: Session) -> None:
    """Lab 5's drive, graded, runs the simulator in the judge and the student's node in
    the kernel, a round trip per tick (the reading carries the time); a student's own run
    has both in one process (``Simulation``). The robot's path is the same to the bit: the node sees
    each reading before its timer at that time, in both."""
    import math

    import nbformat
    import numpy as np

    from rosbook.labs import lab05, remote
    from rosbook.sim.physics import World

    cells = nbformat.read(notebook_path("lab05_diff_drive", released=False), as_version=4).cells
    code = strip_markers(
        "\n".join(c.source for c in cells if grade_id(c) in ("setup", "go_to_pose"))
    )
    goal = (1.5, 1.0, math.pi / 2)
    world = World(arena=(-1.0, -1.0, 2.5, 2.0))
    finish = lab05.Finish(goal[:2], 0.05, still=1.1)
    own: dict[str, Any] = {}
    exec(code, own)  # noqa: S102 - the course's own solution
    mine = lab05.drive(
        own["GoToPose"],
        world=world,
        seconds=25.0,
        finish=finish,
        parameter_overrides=[own["Parameter"]("goal", value=list(goal))],
    )
    with judged_kernel(code) as kernel, remote.judging_cell(remote.Judgement(kernel, Path("."))):
        judged = lab05.drive(
            remote.Student("GoToPose", "class"),
            world=world,
            seconds=25.0,
            finish=finish,
            parameter_overrides=[own["Parameter"]("goal", value=list(goal))],
        )
    assert judged.seconds == mine.seconds
    assert np.array_equal(judged.path, mine.path)


#: Lab 5's kinematics with the lecture robot's wheel radius written in: right for the
#: visible checks (r = 0.04), wrong for the hidden ones (other robots).
FIXED_RADIUS = (
    "def wheel_speeds(v, w, wheel_radius, wheel_separation):\n"
    "    return (v - w * wheel_separation / 2) / 0.04, (v + w * wheel_separation / 2) / 0.04\n"
)

#: Lab 5's kinematics raising: said as a local run says it (``make check``), once.
RAISES = (
    "def wheel_speeds(v, w, wheel_radius, wheel_separation):\n    raise ZeroDivisionError('boom')\n"
)


@pytest.mark.parametrize(
    ("answer", "verdict"),
    [
        ("", None),
        (FIXED_RADIUS, r"^wheel_speeds\(-0\.4, 0\.3, 0\.05, 0\.3\) returned \(-11\.12, -8\.875\)"),
        (RAISES, r"^wheel_speeds\(0\.2, 0\.0, 0\.04, 0\.4\) raised ZeroDivisionError: boom$"),
    ],
    ids=["right", "fixed-radius", "raises"],
)
def test_lab5s_kinematics_cell_runs_in_the_judge_hidden_values_included(
    tmp_path: Path, answer: str, verdict: str | None
) -> None:
    """The test cell as the instructor wrote it runs in the judge, the student's
    functions called in the kernel: an answer right only for the visible robot fails on
    the hidden block's first robot, with the lab's message."""
    cells = {grade_id(c): c.source for c in answered("lab05_diff_drive").cells}
    with judged_kernel(cells["setup"] + "\n" + cells["wheel_speeds"] + "\n" + answer) as kernel:
        got = judge_check(kernel, "lab05_diff_drive", "test_wheel_speeds", tmp_path)
    assert not got.broken and not got.timeout, got
    said = "passed" if got.passed else got.message
    assert re.search(verdict or "^passed$", said), said


@pytest.mark.slow  # drives the visible square and the hidden one
def test_lab5s_hidden_drive_is_the_notebooks_own_line_and_its_figures_come_with_it(
    tmp_path: Path,
) -> None:
    """A SquareDriver that drops its ``node_name`` drives the visible square right; the
    hidden block's own assert names the node it made, and the verdict carries the path
    of the run the judge drove (shown in the cell's place)."""
    lab = "lab05_diff_drive"
    notebook = answered(
        lab, **replace_in_answer(lab, "square_driver", "super().__init__(node_name)",
                                 "super().__init__('square_driver')")
    )  # fmt: skip
    code = "\n".join(c.source for c in notebook.cells if grade_id(c) in ("setup", "square_driver"))
    with judged_kernel(code) as kernel:
        got = judge_check(kernel, lab, "test_square_driver", tmp_path)
    assert (got.passed, got.timeout, got.broken) == (False, False, False), got
    assert got.message == (
        "SquareDriver(node_name='square_b') made a node named 'square_driver'"
    ), got.message
    (shown,) = got.outputs
    assert base64.b64decode(shown["data"]["image/png"]).startswith(b"\x89PNG")


def test_a_gated_reading_alone_carries_its_time_into_the_kernel(session: Session) -> None:
    """With the gate, the judge sends a step's odom only: once the node has taken it, its
    /clock reads the reading's stamp and its timer then acts on that reading."""
    from nav_msgs.msg import Odometry

    with judged_kernel(READER) as kernel:
        assert kernel.call("start", "Reader", {}, True)["name"] == "reader"
        run = Following(session, kernel, "judge_odom", until=0.2, gate="/odom")
        odom = run.node.create_publisher(Odometry, "/odom", 10)
        assert session.spin_until(lambda: odom.get_subscription_count() > 0, run.node, timeout=60)
        step = 100_000_000
        msg = Odometry()
        msg.header.stamp.nanosec = step
        odom.publish(msg)  # reliable: it arrives
        assert session.spin_until(lambda: run.acked[-1]["now"] >= step, run.node, timeout=60), (
            "timeout: the kernel did not move to the time of the odom it took"
        )
        assert run.finish() == [{"timeout": False}]
        records = kernel.call("spin_until_length", "records", 1, 10.0)
        assert records[0] == [step, step], records


@contextmanager
def judged_kernel(code: str, cwd: Path | None = None) -> Iterator[remote.Kernel]:
    """A kernel that ran ``code`` (a student's cells) in ``cwd``, as the judge reaches it."""
    km = UnixSocketKernelManager()
    km.start_kernel(**({"cwd": str(cwd)} if cwd else {}))
    kernel = None
    try:
        setup = km.client()
        setup.start_channels()
        setup.wait_for_ready(timeout=60)
        reply = setup.execute_interactive(code, timeout=60)
        assert reply["content"]["status"] == "ok", reply["content"]
        setup.stop_channels()
        kernel = remote.Kernel(km.connection_file)
        yield kernel
    finally:
        if kernel is not None:
            kernel.client.stop_channels()
        km.shutdown_kernel(now=True)


def judge_check(
    kernel: remote.Kernel,
    assignment: str,
    check: str,
    folder: Path,
    edit: Callable[[str], str] = str,
) -> judge.Verdict:
    """The judge's verdict on ``check`` of ``assignment`` for the student in ``kernel``
    (``edit``: how the instructor changed the test cell's source, if they did)."""
    notebook = nbformat.read(notebook_path(assignment, released=False), as_version=4)
    cell = next(c for c in notebook.cells if grade_id(c) == check)
    request = {
        "check": check,
        "assignment": assignment,
        "connection_file": kernel.client.connection_file,
        "folder": str(folder),
        "source": edit(cell.source),
        "setup": judge.setup_cells(notebook),
    }
    return judge.judge_one(request, {kernel.client.connection_file: kernel})


#: Lab 1's CounterSubscriber whose work is done by a thread, in order, from a queue;
#: ``WORK`` says how that thread goes.
QUEUED_SUBSCRIBER = """
import queue, threading, time
from rclpy.node import Node
from std_msgs.msg import Int64

class CounterSubscriber(Node):
    def __init__(self, node_name='counter_subscriber'):
        super().__init__(node_name)
        self.received = []
        self.inbox = queue.Queue()
        self.subscription = self.create_subscription(Int64, 'counter', self.inbox.put, 10)
        threading.Thread(target=self.work, daemon=True).start()
"""
#: Right: every value, in order.
IN_ORDER = """
    def work(self):
        while True:
            self.received.append(self.inbox.get().data)
"""
#: Right, but the thread starts 12 s late: a starved machine, slower than the judge's
#: 10 s wait for each value.
LATE = """
    def work(self):
        time.sleep(12)
        while True:
            self.received.append(self.inbox.get().data)
"""
#: Wrong: zero is dropped (``if msg.data:``); values after it are handled.
SKIPS_ZERO = """
    def work(self):
        while True:
            value = self.inbox.get().data
            if value:
                self.received.append(value)
"""
#: Stalls after two values (as a deadlock would), every value before right.
STALLS = """
    def work(self):
        while len(self.received) < 2:
            self.received.append(self.inbox.get().data)
        threading.Event().wait()
"""


@pytest.mark.slow  # each waits out the judge's guard on a value: about 25 s
@pytest.mark.parametrize(
    ("work", "verdict"),
    [
        (LATE, None),
        (SKIPS_ZERO, r"expected \[7, -2, 0, .*got \[7, -2, 1099511627776"),
        (STALLS, r"timeout: handled 2 of the 3 values sent on /counter"),
    ],
    ids=["late", "skips-zero", "stalls"],
)
def test_a_value_not_handled_in_the_guard_is_waited_out_not_marked_wrong(
    session: Session, tmp_path: Path, work: str, verdict: str | None
) -> None:
    """A subscriber that is slow past the judge's guard passes once it catches up; one
    that skips a value fails as wrong; one that falls silent, right so far, is a timeout."""
    with judged_kernel(QUEUED_SUBSCRIBER + work) as kernel:
        got = judge_check(kernel, "lab01_nodes_topics", "test_counter_subscriber", tmp_path)
    said = "passed" if got.passed else got.message
    assert re.search(verdict or "passed", said), said


def deaf_talker(folder: Path, on_ctrl_c: str) -> None:
    """Lab 1's talker.py, right, written to ``folder``, but running ``on_ctrl_c`` (lines of
    ``main``'s ``except`` block) when Ctrl-C reaches it."""
    answer = next(a for a in solution_answers("lab01_nodes_topics").values() if "talker.py" in a)
    talker = strip_markers(answer).split("\n", 1)[1]  # the program, without %%writefile
    deaf = "        pass\n    finally:"
    assert deaf in talker
    (folder / "talker.py").write_text(
        "import os\nimport threading\n" + talker.replace(deaf, f"{on_ctrl_c}\n    finally:")
    )


@pytest.mark.slow  # waits out the guard after Ctrl-C, twice
def test_a_script_still_running_after_ctrl_c_is_a_timeout_not_wrong(
    session: Session, tmp_path: Path
) -> None:
    """The wall-clock guard after Ctrl-C cannot tell a hang from a starved machine."""
    deaf_talker(tmp_path, "        threading.Event().wait()  # never ends")
    with judged_kernel("") as kernel:
        verdict = judge_check(kernel, "lab01_nodes_topics", "test_talker_script", tmp_path)
    assert (verdict.passed, verdict.timeout) == (False, True), verdict
    assert verdict.message.startswith("timeout: talker.py was still running 15 s after Ctrl-C")


@pytest.mark.slow  # waits out the guard after Ctrl-C once
def test_a_cell_that_hit_a_guard_once_runs_again_and_is_judged_by_that_run(
    session: Session, tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """A guard cannot tell a hang from a starved machine or from a DDS participant that
    once in a while takes a minute to end: a cell that hit one runs once more, and a right
    talker that hung only at its first Ctrl-C passes."""
    once = (
        "        if not os.path.exists('interrupted'):\n"
        "            open('interrupted', 'w').close()\n"
        "            threading.Event().wait()  # this time only"
    )
    deaf_talker(tmp_path, once)
    with judged_kernel("") as kernel:
        verdict = judge_check(kernel, "lab01_nodes_topics", "test_talker_script", tmp_path)
    assert verdict.passed, verdict
    assert (tmp_path / "interrupted").exists()  # the first run did hang
    said = capfd.readouterr()
    assert "test_talker_script: timeout: talker.py was still running" in said.out + said.err
    assert "the cell once more" in said.out + said.err


def lab03_kernel_code(grade_ids: tuple[str, ...], extra: str = "") -> str:
    """Lab 3's set-up cell and the solution of ``grade_ids``, then ``extra``."""
    cells = {grade_id(c): c.source for c in answered("lab03_services_actions").cells}
    return "\n\n".join([cells["setup"], *(cells[g] for g in grade_ids), extra])


#: Lab 3's RatePublisher, right, on a starved machine: it answers the first change of
#: its rate after 3 s, longer than the 2 s the checks once gave a parameter call.
LATE_PARAMETERS = """
import time

class RatePublisher(RatePublisher):
    def on_set_parameters(self, parameters):
        if any(p.name == 'rate_hz' and p.value == 5.0 for p in parameters):
            time.sleep(3.0)
        return super().on_set_parameters(parameters)
"""


@pytest.mark.slow  # a lab 3 check, twice, with 3 s pauses
def test_a_node_answering_its_parameters_late_is_waited_for_not_marked_wrong(
    session: Session, tmp_path: Path
) -> None:
    """The judge's parameter calls to a student's node are bounded by a generous hang
    guard: a right node on a starved machine that answers after 3 s passes."""
    code = lab03_kernel_code(("rate_parameter",), LATE_PARAMETERS)
    with judged_kernel(code) as kernel:
        verdict = judge_check(kernel, "lab03_services_actions", "test_rate_parameter", tmp_path)
    assert verdict.passed, verdict


def test_a_call_whose_limit_passed_is_a_timeout_not_wrong(
    session: Session, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A check's call that got no answer within its limit (here no server at all, with
    the limit cut to 0.5 s) is a verdict of "timeout" (a hang guard), not of wrong code;
    a call that failed otherwise still fails the check."""
    from rosbook.labs import lab03
    from rosbook.runtime.params import ParameterError

    monkeypatch.setattr(lab03, "DISCOVERY_S", 0.5)
    unanswered = (
        "class Nobody:\n"
        "    def get_name(self):\n"
        "        return 'nobody_here'\n"
        "    def get_fully_qualified_name(self):\n"
        "        return '/nobody_here'\n"
        "checks.set_from_outside(Nobody(), 'rate_hz', 5.0)\n"
    )
    with judged_kernel("") as kernel:
        verdict = judge_check(
            kernel, "lab03_services_actions", "test_rate_parameter", tmp_path, lambda _: unanswered
        )
    assert (verdict.passed, verdict.timeout) == (False, True), verdict
    assert verdict.message.startswith(
        "timeout: no server for '/nobody_here/set_parameters (rcl_interfaces/srv/SetParameters)'"
        " appeared within 0.5 s"
    ), verdict.message
    with pytest.raises(lab03.CheckFailed, match="reading the parameters of 'x' failed: no"):
        with lab03.call_failing("reading the parameters of 'x'"):
            raise ParameterError("no parameter")


def test_a_node_whose_callback_raised_is_told_at_once_not_waited_for(
    session: Session, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A service callback that returns nothing makes rclpy raise in the kernel, and the
    node answers nothing more: the kernel says so, and the judge stops waiting for the
    answer (its limit here an hour) and tells the likely mistake."""
    from rosbook.labs import lab03

    monkeypatch.setattr(lab03, "DISCOVERY_S", 3600.0)
    code = lab03_kernel_code(("clock_server",))
    assert code.count("return response") == 1
    verdicts: list[judge.Verdict] = []
    with judged_kernel(code.replace("return response", "response")) as kernel:
        worker = threading.Thread(
            target=lambda: verdicts.append(
                judge_check(kernel, "lab03_services_actions", "test_clock_server", tmp_path)
            ),
            daemon=True,
        )
        worker.start()
        worker.join(300)  # a hang guard: it takes about a second
        assert verdicts, "the judge still waited for the answer after 300 s"
    verdict = verdicts[0]
    assert (verdict.passed, verdict.timeout) == (False, False), verdict
    assert verdict.message.startswith("the service callback returned nothing (None)"), verdict


#: Lab 3's RatePublisher with a callback that raises as soon as the node runs: at the
#: first time the judge's clock gives it.
RAISES_AT_ONCE = """
class RatePublisher(RatePublisher):
    def __init__(self, node_name='rate_publisher'):
        super().__init__(node_name)
        self.create_timer(0.0, self.fail)

    def fail(self):
        raise ValueError('the first callback fails')
"""


def test_a_callback_that_raises_at_the_first_time_is_named_not_a_judge_failure(
    session: Session, tmp_path: Path
) -> None:
    """The kernel's error, even before the node acked any time, is the verdict's reason."""
    with judged_kernel(lab03_kernel_code(("rate_parameter",), RAISES_AT_ONCE)) as kernel:
        verdict = judge_check(kernel, "lab03_services_actions", "test_rate_parameter", tmp_path)
    assert (verdict.passed, verdict.timeout, verdict.broken) == (False, False, False), verdict
    assert verdict.message == (
        "a callback of node 'rate_publisher' raised ValueError: the first callback fails"
    ), verdict


def test_lab6s_judge_keeps_one_participant_while_the_students_nodes_come_and_go(
    session: Session, tmp_path: Path
) -> None:
    """rmw_fastrtps_cpp destroys a participant with its last node, and Fast DDS can hang
    for good destroying one while another process's nodes are being discovered or leave
    (``judge.py``, eProsima/Fast-DDS#6513). Lab 6's judge made and destroyed one for
    each watcher of a launch, and in a suite run gave no verdict on a two-robot launch
    (a "timeout" after 300 s). It now holds one participant from its first check on,
    through a launch, its stop and the next check."""
    lab6 = "lab06_launch_system"
    notebook = answered(
        lab6, **replace_in_answer(lab6, "two_robots", "namespace=robot, parameters", "parameters")
    )
    code = "\n".join(c.source for c in notebook.cells if grade_id(c) in ("setup", "two_robots"))
    (tmp_path / "home").mkdir()
    try:
        with judged_kernel(code, tmp_path / "home") as kernel:
            keepers = []
            for _ in range(2):
                verdict = judge_check(kernel, lab6, "test_two_robots", tmp_path)
                assert "not expected: ['/talker', '/talker']" in verdict.message, verdict
                keepers.append(session.participant_keeper)
        first = keepers[0]
        assert first is not None and first.context.ok(), "the participant went with the check"
        assert keepers[1] is first, "a participant was made again"
    finally:
        session.hold_participant(False)


def test_lab6s_manifest_is_judged_by_the_cells_own_hidden_checks(
    session: Session, tmp_path: Path
) -> None:
    """The judge builds the student's manifest as the student and runs the test cell as
    the source notebook holds it: the solution passes, and a hidden check the
    instructor edited (one more dependency asked for) fails it with the cell's message."""
    lab6 = "lab06_launch_system"
    notebook = answered(lab6)
    code = "\n".join(
        c.source for c in notebook.cells if grade_id(c) in ("setup", "package_manifest")
    )
    hidden = "checks.assert_dependencies(built)"
    more = "checks.assert_dependencies(built, ['rclpy', 'std_msgs', 'geometry_msgs'])"
    (tmp_path / "home").mkdir()
    try:
        with judged_kernel(code, tmp_path / "home") as kernel:
            right = judge_check(kernel, lab6, "test_package_manifest", tmp_path)
            assert right.passed, right
            edited = judge_check(
                kernel, lab6, "test_package_manifest", tmp_path, lambda s: s.replace(hidden, more)
            )
    finally:
        session.hold_participant(False)
    assert (edited.passed, edited.timeout, edited.broken) == (False, False, False), edited
    assert edited.message == (
        "package.xml does not declare geometry_msgs as a run-time dependency (the nodes "
        "import them): add <depend>geometry_msgs</depend>"
    )


def test_a_judge_failure_passes_through_the_labs_checks_as_it_was_said() -> None:
    """One ``CheckFailed`` for the labs' checks and the judge: a check that calls the
    student's function through the judge lets the judge's own failure (the kernel gave
    no answer) through as it said it, not as the student's function raising."""
    from rosbook.labs import lab02, probes

    assert remote.CheckFailed is probes.CheckFailed

    def predict(*args: Any) -> list[int]:
        raise remote.KernelError("the kernel gave no answer to the judge")

    with pytest.raises(remote.KernelError, match="^the kernel gave no answer to the judge$"):
        lab02.assert_model_matches(predict, [(2, 1.7, 3, 6)])


#: Lab 3's test cells, as its notebook orders them.
LAB3_TESTS = ("test_clock_server", "test_trigger_client", "test_countdown_action",
              "test_rate_parameter")  # fmt: skip


@pytest.mark.slow  # four lab 3 cells, hidden blocks included
def test_lab3s_test_cells_pass_in_the_judge_on_the_solution(
    session: Session, tmp_path: Path
) -> None:
    """The judge runs lab 3's test cells as the notebook holds them, hidden blocks
    included, against the solution's nodes and function in the kernel: each passes."""
    code = lab03_kernel_code(
        ("clock_server", "trigger_client", "countdown_action", "rate_parameter")
    )
    with judged_kernel(code) as kernel:
        verdicts = [
            judge_check(kernel, "lab03_services_actions", check, tmp_path) for check in LAB3_TESTS
        ]
    assert [(v.grade_id, v.passed, v.message) for v in verdicts] == [
        (check, True, "") for check in LAB3_TESTS
    ]


@pytest.mark.slow  # a lab 3 cell in the judge
def test_an_edited_hidden_lab3_test_is_what_the_judge_runs(
    session: Session, tmp_path: Path
) -> None:
    """The instructor's hidden block is the judge's script: a check added to it (here
    one that the solution cannot pass, run while the node follows the judge's clock)
    decides the verdict, with no other file touched."""
    notebook = nbformat.read(notebook_path("lab03_services_actions", released=False), 4)
    cell = next(c for c in notebook.cells if grade_id(c) == "test_clock_server")
    hidden = "checks.assert_tells_time(server, clock, at=40.0)\n"
    assert hidden in cell.source
    edited = cell.source.replace(
        hidden, hidden + "checks.assert_serves(server, 'what_time_b', Trigger)\n"
    )
    with judged_kernel(lab03_kernel_code(("clock_server",))) as kernel:
        verdict = judge_check(
            kernel, "lab03_services_actions", "test_clock_server", tmp_path, lambda _: edited
        )
    assert (verdict.passed, verdict.timeout) == (False, False), verdict
    assert verdict.message.startswith(
        "node 'clock_b' serves no std_srvs/srv/Trigger on /what_time_b"
    ), verdict.message
