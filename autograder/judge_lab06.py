"""Lab 6's checks as the judge runs them: builds, runs and launches started by the judge.

Everything that runs the student's work runs as the student, inside the kernel's
sandbox, started by the judge (``Judgement.student_command``), never in the kernel:

- ``test_package_manifest``: the judge takes ``PACKAGE_XML`` and ``SETUP_PY`` from the
  kernel (two strings), has ``python -m rosbook.labs.lab06 manifest`` build them with
  colcon (``setup.py`` is the student's code) and report the first failing check of
  the built package, then starts ``ros2 run robot_talk talker`` and ``... listener``
  itself and sees them publish on and subscribe to ``/chatter`` from its own nodes.
- ``test_two_robots``: the kernel calls ``generate_launch_description()`` and pickles
  what it returns into the sandbox (the judge never unpickles it); the judge starts
  ``ros2 launch`` on a launch file that loads it (``lab06.pickled_description``:
  after ``SetParameter('use_sim_time', True)``), against a reference build of
  ``robot_talk`` (the one ``share`` made for the grading run, read-only in the
  sandbox; else one made there), and judges from its own nodes the ROS graph,
  the message counts on its own ``/clock``, and ``ros2 launch``'s exit code after one
  Ctrl-C.

A report of the build program comes from a process that also ran the student's
``setup.py``: forging it would take a ``setup.py`` written to write into its parent's
output. What the points mostly rest on (the nodes' traffic, the graph, exit codes) the
judge sees itself. The expected values (executables, dependencies, rates) are here.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

from rcl_interfaces.srv import GetParameters
from rclpy.node import Node
from std_msgs.msg import String

from autograder.judge import (
    EVENT_GUARD_S,
    CheckFailed,
    Judgement,
    JudgeTimeout,
    KernelError,
    clock_message,
    clock_publisher,
    ros_node,
)
from rosbook.labs import lab06
from rosbook.labs.lockstep import (
    CLOCK_RETRY_S,
)
from rosbook.labs.probes import Probe, ScriptRun, run_program
from rosbook.launch.launcher import ESCALATED
from rosbook.runtime.session import ros

#: What the hidden checks expect (the lab's contract).
RATES = {"robot1": 2.0, "robot2": 5.0}
#: The judge keeps one participant from its first check to its end (``judge.
#: holds_participant``): its watchers and probes come and go while the student's nodes
#: start and stop, and a participant destroyed then can hang (Fast DDS's teardown hang).
HOLD_PARTICIPANT = True
#: Simulated seconds the two robots run for, in steps of /clock.
SECONDS, STEP = 2.0, 0.05

#: Hang guards (wall clock): a colcon build; programs started in the sandbox showing up
#: (its cgroup shares the CPU as one process does: slow on a busy machine); a program's
#: stop after Ctrl-C (``ros2 launch`` waits that long before it escalates to SIGTERM).
BUILD_GUARD_S = 300.0
START_GUARD_S = 120.0
EXIT_GUARD_S = 60.0


#: Lines of a program's output that a stop which timed out reports.
STOP_TAIL = 20


class StopTimeout(JudgeTimeout):
    """A program did not end after Ctrl-C within its hang guard."""


class Program:
    """A program the judge started as the student; its output, read as it comes."""

    def __init__(self, run: ScriptRun) -> None:
        self.run = run
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.run.proc.stdout is not None
        for line in self.run.proc.stdout:
            if len(self.lines) < 10_000:
                self.lines.append(line.rstrip("\n"))

    def alive(self) -> bool:
        return self.run.alive()

    def printed(self) -> str:
        return "\n".join(self.lines)

    def stop(self, what: str, whole_group: bool = False, guard: float = EXIT_GUARD_S) -> int:
        """Ctrl-C (``whole_group``: to every process of its group, as a terminal's
        Ctrl-C); its exit code. A hang guard: "timeout" if it does not stop."""
        if self.alive():
            try:
                if whole_group:
                    os.killpg(self.run.proc.pid, signal.SIGINT)
                else:
                    self.run.proc.send_signal(signal.SIGINT)
            except ProcessLookupError:
                pass
        try:
            code = self.run.proc.wait(timeout=guard)
        except subprocess.TimeoutExpired:
            last = "\n".join(self.lines[-STOP_TAIL:])
            raise StopTimeout(
                f"{what} was still running {guard:.0f} s after Ctrl-C (SIGINT); "
                f"the last it printed:\n{last}"
            ) from None
        self._reader.join(timeout=EVENT_GUARD_S)
        return code


@contextmanager
def started(j: Judgement, argv: list[str], what: str) -> Iterator[Program]:
    """``argv`` started as the student (gone afterwards, with what it started)."""
    with run_program(argv, cwd=j.folder, wrap=j.student_command, path=Path(what)) as run:
        yield Program(run)


def finished(j: Judgement, argv: list[str], what: str, stdin: str = "") -> tuple[int, str]:
    """``argv`` run to its end as the student: (exit code, output)."""
    with run_program(argv, cwd=j.folder, wrap=j.student_command, stdin=True) as run:
        try:
            output, _ = run.proc.communicate(stdin, timeout=BUILD_GUARD_S)
        except subprocess.TimeoutExpired:
            raise JudgeTimeout(f"{what} did not finish within {BUILD_GUARD_S:.0f} s") from None
    return run.proc.returncode, output


def as_student(j: Judgement, what: str, folder: str, request: dict[str, Any]) -> dict[str, Any]:
    """``python -I -m rosbook.labs.lab06 WHAT FOLDER`` run as the student, given
    ``request``; its report (the line that repeats the nonce sent on its stdin)."""
    nonce = uuid.uuid4().hex
    argv = [sys.executable, "-I", "-m", "rosbook.labs.lab06", what, folder]
    doing = {"manifest": "building robot_talk with colcon"}.get(what, f"the {what} build")
    code, output = finished(j, argv, doing, json.dumps({**request, "nonce": nonce}))
    for line in output.splitlines():
        if line.startswith(lab06.REPORT):
            try:
                report = dict(json.loads(line[len(lab06.REPORT) :]))
            except (ValueError, TypeError):
                continue
            if report.get("nonce") == nonce and code == 0:
                return report
    tail = "\n".join(output.strip().splitlines()[-8:])
    raise CheckFailed(f"{doing} failed (exit code {code}):\n{tail}")


@contextmanager
def scratch_folder(j: Judgement) -> Iterator[str]:
    """A folder for one check's builds, made and removed by the student's own ``mktemp``
    and ``rm`` (the judge writes nothing where the student's code can put a symlink)."""
    argv = ["mktemp", "-d", "-p", "/tmp", "rosbook_lab06.XXXXXX"]
    code, output = finished(j, argv, "mktemp")
    if code != 0:
        raise CheckFailed(f"no scratch folder could be made for the build: {output.strip()}")
    folder = output.strip().splitlines()[-1]
    try:
        yield folder
    finally:
        finished(j, ["rm", "-rf", folder], "rm")


def text_value(j: Judgement, name: str) -> str:
    try:
        value = j.value(name)
    except CheckFailed:
        raise CheckFailed(
            "define PACKAGE_XML and SETUP_PY (two strings) in the task cell above"
        ) from None
    if not isinstance(value, str):
        raise CheckFailed(f"{name} must be a string (the text of the file), not {value!r}")
    return value


# -- test_package_manifest ---------------------------------------------------------------


def check_package_manifest(j: Judgement) -> None:
    package_xml, setup_py = text_value(j, "PACKAGE_XML"), text_value(j, "SETUP_PY")
    expected = {
        "expected_executables": lab06.EXECUTABLES,
        "dependencies": list(lab06.DEPENDENCIES),
        "installed": f"launch/{lab06.LAUNCH_FILE}",
    }
    with scratch_folder(j) as folder:
        request = {"package_xml": package_xml, "setup_py": setup_py, "expected": expected}
        report = as_student(j, "manifest", folder, request)
        failure = report.get("failure")
        if failure and failure[0] in lab06.CHECKED_BEFORE_RUN:
            raise CheckFailed(str(failure[1]))
        ros2_run(j, folder, "talker", publishes=True)
        if failure:
            raise CheckFailed(str(failure[1]))
        ros2_run(j, folder, "listener", publishes=False)


def ros2_run(j: Judgement, folder: str, executable: str, publishes: bool) -> None:
    """``ros2 run robot_talk EXECUTABLE`` in the built workspace, as the student: it
    publishes on (or subscribes to) /chatter. How it stops is not this check's (the
    notebook's check does not judge it either): a node that hangs on Ctrl-C, as honest
    code sometimes does (Fast DDS's teardown hang, ``judge.py``), is killed."""
    command = (
        f"source {shlex.quote(folder)}/ws/install/setup.bash && "
        f"exec ros2 run {lab06.PACKAGE} {shlex.quote(executable)}"
    )
    with started(j, ["bash", "-c", command], f"ros2 run {lab06.PACKAGE} {executable}") as run:
        lab06.watch_run(
            executable,
            run.alive,
            run.printed,
            publishes=publishes,
            guard=START_GUARD_S,
            silent=JudgeTimeout,
        )
        with suppress(JudgeTimeout):  # then killed with its group as it ends
            run.stop(f"`ros2 run {lab06.PACKAGE} {executable}`", True, EVENT_GUARD_S)


# -- test_two_robots ---------------------------------------------------------------------


def check_two_robots(j: Judgement) -> None:
    with scratch_folder(j) as folder:
        description = f"{folder}/description.pickle"
        try:
            made = j.kernel.call("call_to_file", "generate_launch_description", description)
        except KernelError as exc:
            if "KeyError" in str(exc) and "generate_launch_description" in str(exc):
                raise CheckFailed(
                    "generate_launch_description is not defined: run its task's cell"
                ) from None
            if "NotImplementedError" in str(exc):
                raise CheckFailed(
                    "generate_launch_description(): this task is not done yet (NotImplementedError)"
                ) from None
            raise CheckFailed(f"generate_launch_description() raised {exc}") from None
        if made.get("type") != "LaunchDescription":
            raise lab06.not_a_description(str(made.get("type")))
        if made.get("error"):
            raise CheckFailed(
                "the LaunchDescription cannot be handed to `ros2 launch` (it is pickled "
                f"to get there): {made['error']}. Use plain values in it, not functions."
            )
        workspace = reported_workspace(folder, as_student(j, "reference", folder, {}))
        print(f"[judge] the reference {lab06.PACKAGE}: {workspace}", flush=True)
        try:
            counts, codes, code, lines = launch_two_robots(j, folder, workspace, description)
            again = raced(codes, lines)  # rclpy's own race on Ctrl-C: once more
        except StopTimeout:  # a node stuck in Fast DDS's teardown hang (judge.py): once more
            again = True
        if again:
            counts, codes, code, lines = launch_two_robots(j, folder, workspace, description)
        lab06.assert_stopped_cleanly(
            codes,
            code != 0 and not any(codes.values()),
            {name: _lines_of(lines, name) for name in codes},
        )
    lab06.TwoRobotsReport([], counts, SECONDS, codes, lines).assert_rates(RATES)


def share(folder: Path) -> None:
    """The reference ``robot_talk`` built once for a grading run (``judge.shared_env``):
    every submission's try-it cells and two-robot launches use it, read-only, instead
    of building their own (two colcon builds fewer per submission)."""
    lab06.build_reference(folder / lab06.SHARED_REFERENCE)


def reported_workspace(folder: str, report: dict[str, Any]) -> str:
    """The workspace the ``reference`` run used: the run's shared build, or its own in
    ``folder``; any other is an error of the grader's, never the student's."""
    shared = os.environ.get(lab06.SHARED_ENV)
    expected = {f"{folder}/ws"} | ({f"{shared}/{lab06.SHARED_REFERENCE}"} if shared else set())
    workspace = str(report.get("workspace"))
    if workspace not in expected:
        raise RuntimeError(f"the reference build reported {workspace}, not one of {expected}")
    return workspace


def launch_two_robots(
    j: Judgement, folder: str, workspace: str, description: str
) -> tuple[dict[str, int], dict[str, int], int, list[str]]:
    """``ros2 launch`` of the pickled description, judged and stopped with one Ctrl-C:
    messages per robot, each process's exit code, the launch's, and what it printed.
    It waits ``EXIT_GUARD_S`` after Ctrl-C before SIGTERM (a slow stop is no mistake)."""
    command = (
        f"source {shlex.quote(workspace)}/install/setup.bash && "
        f"ROSBOOK_LAB06_DESCRIPTION={shlex.quote(description)} "
        f"exec ros2 launch {shlex.quote(folder)}/{lab06.JUDGED_LAUNCH} "
        f"sigterm_timeout:={EXIT_GUARD_S:g}"
    )
    guard = EXIT_GUARD_S + 2 * EVENT_GUARD_S  # past the launch's SIGTERM and SIGKILL
    lingering()
    with started(j, ["bash", "-c", command], "ros2 launch") as launch:
        try:
            counts = launched(launch)
        except BaseException:
            with suppress(JudgeTimeout):  # the nodes are stopped as always: Ctrl-C
                launch.stop("`ros2 launch`", guard=guard)
            raise
        code = launch.stop("`ros2 launch`", guard=guard)
    return counts, exit_codes(launch.lines), code, launch.lines


def lingering() -> None:
    """Wait until an earlier launch's nodes have left the graph: killed, they linger
    until their DDS lease ends (then the launch goes on regardless). Live nodes only
    (``lab06.graph_nodes``): a report left of one that has gone never leaves."""
    watcher = ros_node("judge_lab06_gone")
    expected = set(lab06.expected_nodes(RATES))

    def gone() -> bool:
        return not expected & set(lab06.graph_nodes(watcher))

    try:
        ros.spin_until(gone, watcher, timeout=START_GUARD_S)
    finally:
        ros.remove(watcher)


def raced(codes: dict[str, int], lines: list[str]) -> bool:
    """A node that did not stop cleanly on the one Ctrl-C, or was escalated to. The
    nodes are the reference's (``robot_talk``, honest code the description only starts
    and names), so this is a race or hang in shutdown that honest code meets on a
    loaded machine: rclpy's own race on Ctrl-C (``rclpy_raced``), Fast DDS's teardown
    hang (``judge.py``), a node stopped by a signal, and once in a stress run a listener
    that ended with exit code 1. The launch runs once more; a second unclean stop is
    the verdict, with what the node printed last."""
    return any(codes.values()) or any(ESCALATED in line for line in lines)


#: ``ros2 launch``'s own lines about its processes.
STARTED = re.compile(r"^\[INFO\] \[([^\]]+)\]: process started with pid")
DIED = re.compile(r"^\[ERROR\] \[([^\]]+)\]: process has died \[pid \d+, exit code (-?\d+)")
CLEAN = re.compile(r"^\[INFO\] \[([^\]]+)\]: process has finished cleanly")


def exit_codes(lines: list[str]) -> dict[str, int]:
    codes: dict[str, int] = {}
    for line in lines:
        if match := DIED.match(line):
            codes[match[1]] = int(match[2])
        elif match := CLEAN.match(line):
            codes[match[1]] = 0
    return codes


def launched(launch: Program) -> dict[str, int]:
    """Judge the graph the launch made, then run it on the judge's /clock; the number
    of messages each robot's talker published."""
    watcher = ros_node("judge_lab06_graph")
    expected = lab06.expected_nodes(RATES)
    probes = {robot: Probe(f"/{robot}/chatter", String, name="rate") for robot in RATES}
    probe = probes["robot1"]

    def processes() -> list[str]:
        return [m[1] for line in list(launch.lines) if (m := STARTED.match(line))]

    def started() -> int | None:
        names = processes()  # none until ros2 launch says it started them
        return lab06.started_nodes(names) if names else None

    def ended() -> bool:
        return not launch.alive() or bool(exit_codes(launch.lines))

    try:
        nodes = lab06.wait_for_launch(probe, started, ended, watcher, START_GUARD_S)
        codes = exit_codes(launch.lines)
        died = [(name, code, _lines_of(launch.lines, name)) for name, code in codes.items()]
        if not launch.alive():
            launch.stop("`ros2 launch`")  # it has exited: its last lines are read
        if not launch.alive() and not processes():
            raise CheckFailed(
                "`ros2 launch` stopped before it started a process; it printed:\n"
                + "\n".join(launch.lines[-8:])
            )
        lab06.assert_graph(probe, nodes, expected, len(processes()), died)
        return run_on_clock(watcher, probes)
    finally:
        for p in probes.values():
            p.close()
        ros.remove(watcher)


def _lines_of(lines: list[str], process: str) -> list[str]:
    prefix = f"[{process}] "
    return [line[len(prefix) :] for line in lines if line.startswith(prefix)]


def talker_rates(node: Node) -> dict[str, float | None]:
    """Each robot's talker's ``rate`` parameter, asked over its parameter service: it
    paces the judge's /clock (what is judged is the messages that arrive)."""
    rates: dict[str, float | None] = {}
    for robot in RATES:
        client = node.create_client(GetParameters, f"/{robot}/talker/get_parameters")
        try:
            if not ros.spin_until(client.service_is_ready, node, timeout=START_GUARD_S):
                raise JudgeTimeout(f"/{robot}/talker's parameter service did not appear")
            future = client.call_async(GetParameters.Request(names=["rate"]))
            if not ros.spin_until(future.done, node, timeout=START_GUARD_S):
                raise JudgeTimeout(f"/{robot}/talker did not say its rate")
            values = future.result().values
            rates[robot] = values[0].double_value if values and values[0].type == 3 else None
        finally:
            node.destroy_client(client)
    return rates


def run_on_clock(node: Node, probes: dict[str, Any]) -> dict[str, int]:
    clock = clock_publisher(node)

    def listening() -> bool:
        return clock.get_subscription_count() >= 4

    if not ros.spin_until(listening, node, timeout=START_GUARD_S):
        raise CheckFailed(
            "the launched nodes do not all listen to /clock although the check adds "
            "SetParameter('use_sim_time', True) first: did the description change "
            "use_sim_time?"
        )
    rates = talker_rates(node)
    listening = [node, *(probe.node for probe in probes.values())]
    steps = round(SECONDS / STEP)
    for k in range(1, steps + 1):
        t = k * STEP
        clock.publish(clock_message(t))

        def arrived(t: float = t) -> bool:
            return all(
                len(probes[robot].received.messages) >= int(t * rate + 1e-9)
                for robot, rate in rates.items()
                if rate
            )

        # a /clock message to a best-effort subscription can be lost: sent again
        deadline = time.monotonic() + START_GUARD_S
        while not ros.spin_until(arrived, *listening, timeout=CLOCK_RETRY_S):
            if time.monotonic() > deadline:
                raise JudgeTimeout(f"the talkers did not publish on /clock's t = {t:.2f} s")
            clock.publish(clock_message(t))
    return {robot: len(p.received.messages) for robot, p in probes.items()}


CHECKS = {
    "test_package_manifest": check_package_manifest,
    "test_two_robots": check_two_robots,
}
