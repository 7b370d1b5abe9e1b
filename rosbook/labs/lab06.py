"""Checks for lab 6: a student's package manifest built with colcon, and a launch of two robots.

The package is ``robot_talk``: a talker whose rate is a parameter and a listener, laid
out by ``write_layout``. ``build_package`` builds it with the student's ``package.xml``
and ``setup.py`` in a scratch workspace, for real; ``check_two_robots`` launches the
student's description against a reference build and inspects the ROS graph on
simulated time. Failures are ``CheckFailed`` errors (``AssertionError``s) naming the mistake.

The same test cells run in the grader's judge (``rosbook.labs.remote``), outside the
student's kernel, where the student's names are handles and plain data; there every
run of the student's work is started by the judge as the student, where the student's
code runs (``Judgement.wrap``), never in the judge:

- ``build_package``: ``python -I -m rosbook.labs.lab06 manifest`` builds the two texts
  with colcon (``setup.py`` is the student's code) and reports what the build shows
  (``BuildFacts``: plain data), which the cell's ``assert_*`` then judge;
  ``assert_runs`` starts ``ros2 run robot_talk ...`` and watches /chatter from the
  judge's own nodes.
- ``check_two_robots``: the kernel pickles what ``generate_launch_description()``
  returns into the sandbox (the judge never unpickles it); the judge starts ``ros2
  launch`` on a launch file that loads it (``pickled_description``), against the
  reference build (the one ``share`` made for the grading run, read-only there), and
  judges from its own nodes the ROS graph, the messages on its own ``/clock`` and
  ``ros2 launch``'s exit codes after one Ctrl-C.

A build's report comes from a process that also ran the student's ``setup.py``:
forging it would take a ``setup.py`` written to write into its parent's output. What
the points mostly rest on (the nodes' traffic, the graph, exit codes) the judge sees
itself. What is expected (executables, dependencies, rates) is what the test cell
passes, the contract's constants below when it passes nothing: never the judge's.
"""

from __future__ import annotations

import atexit
import json
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager, suppress
from dataclasses import asdict, dataclass, field, fields
from functools import cache, cached_property
from importlib.resources import files
from pathlib import Path
from typing import Any

from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters
from rclpy.node import Node as RclpyNode
from rclpy.topic_endpoint_info import TopicEndpointInfo
from std_msgs.msg import String

from rosbook.labs.deferral import deferrable
from rosbook.labs.lockstep import CLOCK_RETRY_S
from rosbook.labs.probes import CheckFailed, Probe, ScriptRun, StillRunning, TimedOut, run_program
from rosbook.labs.remote import (
    EVENT_GUARD_S,
    Judgement,
    KernelError,
    Student,
    clock_message,
    clock_publisher,
    decode,
    judgement,
    judging,
    ros_node,
)
from rosbook.launch.launcher import (
    ESCALATED,
    Launch,
    LaunchDescription,
    LaunchError,
    Node,
    SetParameter,
    launch,
)
from rosbook.launch.workspace import ColconRun, Workspace, create_package, executables, packages
from rosbook.runtime.session import ros

PACKAGE = "robot_talk"
VERSION = "1.0.0"
DEPENDENCIES = ("rclpy", "std_msgs")
EXECUTABLES = {"talker": "robot_talk.talker:main", "listener": "robot_talk.listener:main"}
LAUNCH_FILE = "talk.launch.py"

#: The reference package, all but its manifest: real files (ruff lints them), shipped
#: as package data.
REFERENCE = Path(str(files("rosbook") / "reference" / "lab06_package" / PACKAGE))


def write_layout(destination: str | Path) -> Path:
    """Write the ``robot_talk`` package, all but its manifest, into ``destination``."""
    root = Path(destination) / PACKAGE
    shutil.copytree(
        REFERENCE, root, dirs_exist_ok=True, ignore=shutil.ignore_patterns("__pycache__")
    )
    return root


# -- task 1: the manifest, built for real ------------------------------------------------


@dataclass
class BuildFacts:
    """What the checks of a build read: plain data, so that a build made where the
    student's code runs (``main``, graded) reports them and the same checks judge them."""

    ok: bool
    returncode: int
    #: colcon's output (its end, when long)
    output: str
    #: what package.xml declares, or why it cannot be read (``manifest_error``)
    name: str | None = None
    version: str | None = None
    exec_depends: list[str] = field(default_factory=list)
    manifest_error: str | None = None
    #: the version setup.py gave, read back from the build's egg-info
    setup_version: str | None = None
    #: the package is in the ament index under its name
    indexed: bool = False
    executables: list[str] = field(default_factory=list)
    #: the files installed into ``share/robot_talk/``, relative to it
    installed: list[str] = field(default_factory=list)

    @classmethod
    def from_plain(cls, plain: object) -> BuildFacts:
        """Facts from a build's report, each field of its own type, else ``CheckFailed``."""
        if not isinstance(plain, dict):
            raise CheckFailed("the build's report was not readable")
        kinds = {
            "ok": bool,
            "returncode": int,
            "output": str,
            "name": str,
            "version": str,
            "exec_depends": list,
            "manifest_error": str,
            "setup_version": str,
            "indexed": bool,
            "executables": list,
            "installed": list,
        }
        given = {f.name: plain.get(f.name) for f in fields(cls) if f.name in plain}
        for key, value in given.items():
            if value is not None and type(value) is not kinds[key]:
                raise CheckFailed(f"the build's report was not readable ({key})")
            if isinstance(value, list) and not all(type(v) is str for v in value):
                raise CheckFailed(f"the build's report was not readable ({key})")
        try:
            return cls(**given)
        except TypeError:
            raise CheckFailed("the build's report was not readable") from None


#: The most of colcon's output and of the installed files a build's facts keep.
OUTPUT_LIMIT = 100_000
INSTALLED_LIMIT = 2_000


@dataclass
class BuiltPackage:
    """A scratch workspace with ``robot_talk`` in it, after ``colcon build``."""

    workspace: Workspace
    build: ColconRun
    env: dict[str, str] = field(default_factory=dict)

    @property
    def source(self) -> Path:
        return self.workspace.src / PACKAGE

    @cached_property
    def facts(self) -> BuildFacts:
        """What the build shows (``BuildFacts``)."""
        run = self.build
        facts = BuildFacts(run.ok, run.returncode, run.output[-OUTPUT_LIMIT:])
        try:
            manifest = _parse_manifest(self.source / "package.xml")
        except CheckFailed as error:
            facts.manifest_error = str(error)
        else:
            facts.name, facts.version = str(manifest.name), str(manifest.version)
            facts.exec_depends = [str(dep.name) for dep in manifest.exec_depends]
        facts.setup_version = setup_py_version(self.workspace)
        facts.indexed = run.ok and PACKAGE in packages(self.env)
        if facts.indexed:
            facts.executables = executables(PACKAGE, self.env)
        facts.installed = _installed(self.workspace.install / PACKAGE / "share" / PACKAGE)
        return facts


@dataclass
class JudgedBuild:
    """A build the judge had made where the student's code runs (``build_package``
    when graded): what it showed, and its scratch folder there (the workspace is
    ``FOLDER/ws``), removed when the test cell ends."""

    facts: BuildFacts
    folder: str


_builds: dict[tuple[str, str], BuiltPackage] = {}


def _scratch(prefix: str) -> Workspace:
    """A scratch workspace that is deleted when this process exits (graders make many)."""
    ws = Workspace.scratch(prefix)
    atexit.register(ws.remove)
    return ws


def build_package(
    package_xml: str, setup_py: str, root: str | Path | None = None
) -> BuiltPackage | JudgedBuild:
    """Lay out ``robot_talk`` with these manifests in a workspace (``root``, else a
    scratch one); colcon-build it.

    The same two texts are built once per process (a check after a try-it cell reuses
    the build). When graded, the build is made as the student where the student's code
    runs, and what it shows comes back (``JudgedBuild``).
    """
    for name, text in (("PACKAGE_XML", package_xml), ("SETUP_PY", setup_py)):
        if not isinstance(text, str):
            shown = f"a {text.kind}" if isinstance(text, Student) else repr(text)
            raise CheckFailed(f"{name} must be a string (the text of the file), not {shown}")
    j = judging()
    if j is not None:
        folder = j.ends.enter_context(scratch_folder(j))
        report = as_student(
            j, "manifest", folder, {"package_xml": package_xml, "setup_py": setup_py}
        )
        return JudgedBuild(BuildFacts.from_plain(report.get("facts")), folder)
    key = (package_xml, setup_py)
    if root is None and key in _builds and _builds[key].workspace.root.exists():
        return _builds[key]
    ws = _scratch("lab06_ws_") if root is None else Workspace(root)
    root = write_layout(ws.src)
    (root / "package.xml").write_text(package_xml)
    (root / "setup.py").write_text(setup_py)
    run = ws.build()
    built = BuiltPackage(ws, run)
    if run.ok:
        built.env = ws.environ()
    _builds[key] = built
    return built


def _installed(share: Path) -> list[str]:
    """The files under ``share`` (links followed, as an install found through them is
    found), relative to it; at most ``INSTALLED_LIMIT``."""
    found: list[str] = []
    for top, _dirs, names in os.walk(share, followlinks=True):
        for name in names:
            path = Path(top) / name
            if path.exists():
                found.append(path.relative_to(share).as_posix())
        if len(found) >= INSTALLED_LIMIT:
            break
    return sorted(found[:INSTALLED_LIMIT])


def _tail(text: str, lines: int = 12) -> str:
    return "\n".join(text.strip().splitlines()[-lines:])


def assert_built(built: BuiltPackage | JudgedBuild) -> None:
    """colcon succeeded and the package is in the ament index under its name."""
    facts = built.facts
    if not facts.ok:
        hint = ""
        if "resource/" in facts.output and "can't copy" in facts.output:
            hint = (
                " setup.py installs 'resource/' + package_name as the package marker: "
                f"package_name in setup.py must be '{PACKAGE}', the name in package.xml."
            )
        elif "SyntaxError" in facts.output or "Traceback" in facts.output:
            hint = " setup.py does not run: look at the Python error above."
        raise CheckFailed(
            f"colcon build failed (exit code {facts.returncode}).{hint}\n"
            f"colcon printed:\n{_tail(facts.output)}"
        )
    _manifest_read(facts)
    if facts.name != PACKAGE:
        raise CheckFailed(
            f"package.xml names the package '{facts.name}'; the folder and the task "
            f"call it '{PACKAGE}'"
        )
    if not facts.indexed:
        raise CheckFailed(
            f"colcon built the folder, but '{PACKAGE}' is not in the ament index, so "
            "`ros2 run` cannot find it. setup.py's data_files must install "
            f"('share/ament_index/resource_index/packages', ['resource/{PACKAGE}'])."
        )


def _manifest_read(facts: BuildFacts) -> None:
    """package.xml could be read as a manifest (else ``CheckFailed``, saying why)."""
    if facts.manifest_error is not None:
        raise CheckFailed(facts.manifest_error)


def _parse_manifest(path: Path):  # -> catkin_pkg.package.Package
    from catkin_pkg.package import InvalidPackage, parse_package

    try:
        return parse_package(str(path))
    except InvalidPackage as error:
        raise CheckFailed(
            f"package.xml is not a valid manifest: {str(error).splitlines()[-1]}. colcon "
            "then builds the folder as a plain Python package, outside the ament index, "
            "so `ros2 run` and `ros2 launch` cannot find it."
        ) from None
    except Exception as error:  # not XML at all
        raise CheckFailed(f"package.xml cannot be read as XML: {error}") from None


def setup_py_version(workspace: Workspace) -> str | None:
    """The version setup.py gave, read back from the build's egg-info."""
    for info in (workspace.root / "build" / PACKAGE).glob("*.egg-info/PKG-INFO"):
        match = re.search(r"^Version: (.+)$", info.read_text(), re.MULTILINE)
        if match:
            return match.group(1).strip()
    return None


def assert_versions_agree(built: BuiltPackage | JudgedBuild, expected: str = VERSION) -> None:
    """package.xml and setup.py state the same version, the one the task asks for."""
    facts = built.facts
    _manifest_read(facts)
    if facts.setup_version != facts.version:
        raise CheckFailed(
            f"package.xml says version {facts.version} but setup.py says "
            f"{facts.setup_version}: colcon builds it anyway, without a word, but the two "
            "must agree (tools and the package index read package.xml, Python reads setup.py)"
        )
    if facts.version != expected:
        raise CheckFailed(f"the version is {facts.version}; the task asks for {expected}")


def assert_dependencies(
    built: BuiltPackage | JudgedBuild, needed: Iterable[str] = DEPENDENCIES
) -> None:
    """package.xml declares every package the nodes import, for run time."""
    facts = built.facts
    _manifest_read(facts)
    missing = [name for name in needed if name not in facts.exec_depends]
    if missing:
        tags = " ".join(f"<depend>{name}</depend>" for name in missing)
        raise CheckFailed(
            f"package.xml does not declare {', '.join(missing)} as a run-time dependency "
            f"(the nodes import them): add {tags}"
        )


def assert_executables(
    built: BuiltPackage | JudgedBuild, expected: dict[str, str] = EXECUTABLES
) -> None:
    """Every node is an executable of the package (an entry point in setup.py)."""
    have = built.facts.executables
    missing = [name for name in expected if name not in have]
    if missing:
        entries = ", ".join(f"'{name} = {expected[name]}'" for name in missing)
        raise CheckFailed(
            f"`ros2 run {PACKAGE} {missing[0]}` finds no executable '{missing[0]}': the "
            f"package's executables are {have or 'none'}. The entry point is not "
            f"registered: add {entries} to entry_points={{'console_scripts': [...]}} in "
            "setup.py"
        )


def assert_installed(
    built: BuiltPackage | JudgedBuild, relative: str = f"launch/{LAUNCH_FILE}"
) -> None:
    """A data file was installed into ``share/robot_talk/``."""
    if relative not in built.facts.installed:
        folder = relative.split("/")[0]
        raise CheckFailed(
            f"{relative} was not installed into share/{PACKAGE}/{folder}/, so "
            f"`ros2 launch {PACKAGE} {Path(relative).name}` cannot find it: add "
            f"(os.path.join('share', package_name, '{folder}'), glob('{folder}/*')) "
            "to data_files in setup.py"
        )


def assert_runs(
    built: BuiltPackage | JudgedBuild,
    executable: str,
    topic: str = "/chatter",
    publishes: bool = True,
) -> list[str]:
    """``ros2 run robot_talk EXECUTABLE`` starts a node that uses ``topic``; Ctrl-C stops
    it. Each process's exit code."""
    if isinstance(built, JudgedBuild):
        return _judged_run(built, executable, topic, publishes)
    ros.init()
    description = LaunchDescription([Node(package=PACKAGE, executable=executable)])
    try:
        system = launch(description, env=built.env, echo=None)
    except LaunchError as error:
        raise CheckFailed(str(error)) from None

    def printed() -> str:
        system.wait(1.0)
        return "\n".join(system.processes[0].lines)

    try:
        watch_run(executable, system.running, printed, topic, publishes)
    finally:
        codes = system.shutdown(sigterm_timeout=3.0, sigkill_timeout=2.0)
    return [f"{name}: exit code {code}" for name, code in codes.items()]


def _judged_run(built: JudgedBuild, executable: str, topic: str, publishes: bool) -> list[str]:
    """``assert_runs`` on a build the judge had made: ``ros2 run`` in its workspace, as
    the student. How it stops is not judged (the cell does not judge it either): a node
    that hangs on Ctrl-C, as honest code sometimes does (Fast DDS's teardown hang,
    ``autograder/judge.py``), is killed."""
    j = judgement()
    command = (
        f"source {shlex.quote(built.folder)}/ws/install/setup.bash && "
        f"exec ros2 run {PACKAGE} {shlex.quote(executable)}"
    )
    what = f"`ros2 run {PACKAGE} {executable}`"
    with started(j, ["bash", "-c", command], what) as run:
        watch_run(
            executable,
            run.alive,
            run.printed,
            topic,
            publishes,
            guard=START_GUARD_S,
            silent=TimedOut,
        )
        with suppress(TimedOut):  # then killed with its group as it ends
            return [f"{executable}: exit code {run.stop(what, True, EVENT_GUARD_S)}"]
    return []


def watch_run(
    executable: str,
    running: Callable[[], bool],
    printed: Callable[[], str],
    topic: str = "/chatter",
    publishes: bool = True,
    guard: float = 10.0,
    silent: type[Exception] = CheckFailed,
) -> None:
    """Wait until the started ``ros2 run robot_talk EXECUTABLE`` publishes on (or
    subscribes to) ``topic``, seen from a probe of this process; ``silent`` is raised
    when ``guard`` seconds pass without it (the judge's says "timeout")."""
    probe = Probe(topic, String, name=f"probe_{executable}")
    try:
        if publishes:
            ok = ros.spin_until(
                lambda: bool(probe.received.messages) or not running(), timeout=guard
            )
            what = f"publish on {topic}"
        else:
            ok = ros.spin_until(
                lambda: probe.node.count_subscribers(topic) > 1 or not running(), timeout=guard
            )
            what = f"subscribe to {topic}"
        if not running():
            raise CheckFailed(
                f"`ros2 run {PACKAGE} {executable}` exited by itself; it printed:\n"
                + _tail(printed(), 8)
            )
        if not ok:
            raise silent(
                f"`ros2 run {PACKAGE} {executable}` runs but did not {what} within {guard:g} "
                f"s: does its entry point name the right module ({EXECUTABLES.get(executable)})?"
            )
    finally:
        probe.close()


# -- task 2: two robots, launched and inspected ------------------------------------------


def add_reference_package(src: str | Path) -> Path:
    """``robot_talk`` in ``src`` with a manifest made by ``ros2 pkg create`` (+ entry points)."""
    root = create_package(
        PACKAGE,
        src,
        dependencies=DEPENDENCIES,
        version=VERSION,
        license="Apache-2.0",
        maintainer_name="Course Staff",
        maintainer_email="staff@example.com",
        description="A talker and a listener",
        log=None,
    )
    write_layout(src)
    setup = (root / "setup.py").read_text()
    entries = "".join(f"\n            '{n} = {target}'," for n, target in EXECUTABLES.items())
    setup = setup.replace("'console_scripts': [", "'console_scripts': [" + entries)
    setup = setup.replace(
        "('share/' + package_name, ['package.xml']),",
        "('share/' + package_name, ['package.xml']),\n"
        "        ('share/' + package_name + '/launch', glob('launch/*.launch.py')),",
    )
    (root / "setup.py").write_text("from glob import glob\n" + setup)
    return root


#: The folder a grader shares, read-only, with every sandbox of a grading run
#: (``autograder.sandbox.SHARED_ENV``), and the reference build it makes there once for
#: all the run's submissions (``share``).
SHARED_ENV = "ROSBOOK_SHARED"
SHARED_REFERENCE = "lab06_reference"


def shared_reference() -> Workspace | None:
    """The reference build the grader shared with this process, if it has one."""
    shared = os.environ.get(SHARED_ENV)
    root = Path(shared) / SHARED_REFERENCE if shared else None
    if root is None or not (root / "install" / "setup.bash").is_file():
        return None
    return Workspace(root)


@cache
def reference_workspace() -> Workspace:
    """A workspace with the reference ``robot_talk``: the grader's shared one when
    graded, else one built once per process."""
    return shared_reference() or build_reference(_scratch("lab06_ref_").root)


def build_reference(root: str | Path) -> Workspace:
    """The reference ``robot_talk`` built in the workspace ``root``."""
    ws = Workspace(root)
    add_reference_package(ws.src)
    run = ws.build()
    if not run.ok:
        raise RuntimeError(f"the reference robot_talk did not build:\n{run.output}")
    return ws


ROBOTS = {"robot1": 2.0, "robot2": 5.0}


@dataclass
class TwoRobotsReport:
    """What one launch of the student's description showed."""

    nodes: list[str]
    counts: dict[str, int]
    seconds: float
    exit_codes: dict[str, int]
    output: list[str]

    def assert_rates(self, rates: dict[str, float] = ROBOTS, tolerance: int = 1) -> None:
        """Each robot's talker published ``rate * seconds`` messages (simulated time)."""
        for robot, rate in rates.items():
            got = self.counts.get(robot, 0)
            want = round(rate * self.seconds)
            if abs(got - want) > tolerance:
                seen = got / self.seconds
                raise CheckFailed(
                    f"/{robot}/chatter carried {got} messages in {self.seconds:g} s of "
                    f"simulated time, that is {seen:g} Hz; expected {rate:g} Hz ({want} "
                    f"messages): give {robot}'s talker parameters=[{{'rate': {rate}}}]"
                )


def expected_nodes(robots: Iterable[str]) -> list[str]:
    """The talker and listener of each robot, by full name."""
    return sorted(f"/{robot}/{name}" for robot in robots for name in ("talker", "listener"))


def check_two_robots(
    generate: Callable[[], LaunchDescription] | Student, seconds: float = 2.0
) -> TwoRobotsReport:
    """Launch ``generate()``, check the graph, drive /clock for ``seconds``, stop it
    (when graded: ``generate`` is the student's function in the kernel, and the launch
    is the judge's, ``_judged_two_robots``)."""
    if isinstance(generate, Student):
        return _judged_two_robots(judgement(), generate, seconds)
    try:
        description = generate()
    except Exception as error:
        raise CheckFailed(
            f"generate_launch_description() raised {type(error).__name__}: {error}"
        ) from None
    assert_description(description)
    ws = reference_workspace()
    env = ws.environ()
    clock = ros.sim_clock()
    full = LaunchDescription([SetParameter("use_sim_time", True), *description.entities])
    try:
        system = launch(full, env=env, echo=None)
    except LaunchError as error:
        raise CheckFailed(str(error)) from None
    probes = {robot: Probe(f"/{robot}/chatter", String, name="rate") for robot in ROBOTS}
    try:
        expected = expected_nodes(ROBOTS)
        nodes = _wait_for_nodes(system, probes["robot1"])
        died = [p for p in system.processes if not p.alive()]
        if died:
            system.pump(0.0)
        assert_graph(
            probes["robot1"],
            nodes,
            expected,
            len(system.processes),
            [(f"{p.name} ({p.namespace or '/'})", p.returncode, p.lines) for p in died],
        )
        local = len(ros.nodes)
        if not ros.spin_until(lambda: clock.subscriber_count() >= local + 4, timeout=10.0):
            raise CheckFailed(
                "the launched nodes do not all listen to /clock although the check adds "
                "SetParameter('use_sim_time', True) first: did the description change "
                "use_sim_time?"
            )
        for probe in probes.values():
            probe.received.messages.clear()
        clock.advance_remote(seconds, step=0.05, settle=0.02)
        ros.spin_for(0.3)
        counts = {robot: len(probe.received.messages) for robot, probe in probes.items()}
    finally:
        codes = system.shutdown(sigterm_timeout=5.0, sigkill_timeout=2.0)
        for probe in probes.values():
            probe.close()
    report = TwoRobotsReport(nodes, counts, seconds, codes, system.output)
    assert_stopped_cleanly(
        codes,
        any(p.alive() for p in system.processes),
        {p.name: p.lines for p in system.processes},
    )
    return report


def assert_description(description: object) -> None:
    """What ``generate_launch_description()`` returned is a ``LaunchDescription``."""
    if not isinstance(description, LaunchDescription):
        raise not_a_description(type(description).__name__)


def not_a_description(type_name: str) -> CheckFailed:
    return CheckFailed(
        f"generate_launch_description() must return LaunchDescription([...]), not {type_name}"
    )


def assert_stopped_cleanly(
    codes: dict[str, int],
    left_running: bool = False,
    printed: Mapping[str, list[str]] | None = None,
) -> None:
    """One Ctrl-C stopped every process with exit code 0; ``printed``: each process's
    lines, the last of the first unclean one are shown."""
    unclean = {name: code for name, code in codes.items() if code != 0}
    if unclean or left_running:
        said = ""
        for name in unclean:
            if lines := (printed or {}).get(name):
                said = f" {name} printed last:\n" + _tail("\n".join(lines), 8)
                break
        raise CheckFailed(
            f"not every node stopped cleanly on Ctrl-C: exit codes {unclean} (0 is clean).{said}"
        )


#: Name prefixes of nodes that are the checks' own, never the student's.
OWN_NODES = ("_", "probe", "rate", "sim_clock", "sender", "rosout", "judge")


def graph_nodes(watcher: Probe | RclpyNode) -> list[str]:
    """The live nodes on the ROS graph by full name (a name twice: two nodes), not the
    checks' own.

    The graph's list of nodes is what each participant last reported of its nodes. A
    participant that watches for long (the judge holds one across a class's launches)
    can be left with the report of one that has left: the report came on one DDS
    thread, the leaving on another, and nothing removes a report that came after its
    participant left (the "ghost" nodes of a long-running ``ros2`` daemon). Seen in a
    stress run: a launch's graph held a listener of the previous launch. The endpoints
    of a participant that left are gone, so a name counts as often as live nodes of that
    name publish ``/rosout`` (every rclpy node does, unless told not to), at most as
    often as it is reported; a name without a ``/rosout`` publisher counts as reported
    if it has any endpoint (a node without ``/rosout`` still publishes parameter events).
    While a ``/rosout`` publisher is not tied to a reported node yet (its node's report
    is behind its endpoints), the reports are all there is to go by: ``settled_nodes``
    waits that out.
    """
    node = _graph_node(watcher)
    reported, logging = _reports(node)
    return _full_names(live_counts(reported, logging, lambda key: _has_endpoints(node, key)))


Key = tuple[str, str]  # (namespace, name) of a node


def _reports(node: RclpyNode) -> tuple[Counter[Key], Counter[Key]]:
    """Each node the graph's reports list, and each publisher of ``/rosout`` by its node
    (``_NODE_NAME_UNKNOWN_`` while that node's report is behind its endpoints)."""
    reported = Counter((ns, name) for name, ns in node.get_node_names_and_namespaces())
    logging = Counter(
        (info.node_namespace, info.node_name)
        for info in node.get_publishers_info_by_topic("/rosout")
    )
    return reported, logging


def live_counts(
    reported: Counter[Key], logging: Counter[Key], has_endpoints: Callable[[Key], bool]
) -> Counter[Key]:
    """How many live nodes of each name, not the checks' own (``graph_nodes``)."""
    counts = _not_own(reported)
    if not logging.keys() <= reported.keys():  # a /rosout publisher is not tied to a report
        return counts
    return Counter(
        {
            key: min(times, logging[key]) if logging[key] else times * has_endpoints(key)
            for key, times in counts.items()
        }
    )


def sure_nodes(reported: Counter[Key], logging: Counter[Key]) -> int | None:
    """How many nodes, not the checks' own, are surely live: reported and publishing
    ``/rosout``, as often as both; None while a ``/rosout`` publisher is not tied to a
    report (then a report left of a node that has gone cannot be told from a live
    node's: seen in a quiet run, a launch's graph listed a talker of the previous
    launch while a listener's report was late, and the count of nodes looked right)."""
    if not logging.keys() <= reported.keys():
        return None
    return sum(min(times, logging[key]) for key, times in _not_own(reported).items())


#: Topics every node has, not the node's own work.
COMMON_TOPICS = ("/rosout", "/parameter_events", "/clock")


def settled_nodes(watcher: Probe | RclpyNode, started: int) -> list[str] | None:
    """The live nodes (``graph_nodes``) once the graph shows all of a launch that
    started ``started`` nodes: that many are surely live (``sure_nodes``), and each
    talker and listener of a robot has its own topic (a publisher or a subscription
    besides the ``COMMON_TOPICS``); None until then."""
    node = _graph_node(watcher)
    reported, logging = _reports(node)
    sure = sure_nodes(reported, logging)
    if sure is None or sure < started:
        return None
    nodes = _full_names(live_counts(reported, logging, lambda key: _has_endpoints(node, key)))
    for robot in ROBOTS:
        published, subscribed = endpoints(watcher, robot)
        for name, found in (("talker", published), ("listener", subscribed)):
            if f"/{robot}/{name}" in nodes and not set(found) - set(COMMON_TOPICS):
                return None
    return nodes


def reported_nodes(watcher: Probe | RclpyNode) -> list[str]:
    """The nodes the graph's reports list, live or not (``graph_nodes``: the live ones)."""
    node = _graph_node(watcher)
    return _full_names(_not_own(Counter((ns, n) for n, ns in node.get_node_names_and_namespaces())))


def _graph_node(watcher: Probe | RclpyNode) -> RclpyNode:
    return watcher.node if isinstance(watcher, Probe) else watcher


def _not_own(nodes: Counter[tuple[str, str]]) -> Counter[tuple[str, str]]:
    return Counter({key: n for key, n in nodes.items() if not key[1].startswith(OWN_NODES)})


def _full_names(nodes: Counter[tuple[str, str]]) -> list[str]:
    return sorted(f"{ns.rstrip('/')}/{name}" for ns, name in nodes.elements())


def _has_endpoints(node: RclpyNode, key: tuple[str, str]) -> bool:
    namespace, name = key
    try:
        return bool(
            node.get_publisher_names_and_types_by_node(name, namespace)
            or node.get_subscriber_names_and_types_by_node(name, namespace)
        )
    except Exception:  # gone from the graph since it was listed
        return False


def endpoints(
    watcher: Probe | RclpyNode, robot: str
) -> tuple[dict[str, list[str]], dict[str, list[str]]]:
    """Topics of /robot/talker's publishers and /robot/listener's subscriptions.

    Found topic by topic, by the node each endpoint belongs to: the graph's lookup by
    node name asks the first participant that reports the name, which can be one that
    has left (``graph_nodes``) and has no endpoints any more."""
    node = _graph_node(watcher)
    talker, listener = (f"/{robot}", "talker"), (f"/{robot}", "listener")
    published: dict[str, list[str]] = {}
    subscribed: dict[str, list[str]] = {}
    for topic, types in node.get_topic_names_and_types():
        if talker in _endpoint_nodes(node.get_publishers_info_by_topic(topic)):
            published[topic] = types
        if listener in _endpoint_nodes(node.get_subscriptions_info_by_topic(topic)):
            subscribed[topic] = types
    return published, subscribed


def _endpoint_nodes(infos: Iterable[TopicEndpointInfo]) -> set[Key]:
    return {(info.node_namespace, info.node_name) for info in infos}


#: How long the check waits for a launch's nodes to show on the graph: a guard against
#: a hang only (they show in seconds), and when it is hit the feedback says so.
GRAPH_GUARD_S = 120.0


def wait_for_launch(
    probe: Probe,
    started: Callable[[], int | None],
    ended: Callable[[], bool],
    spinning: RclpyNode,
    guard: float = GRAPH_GUARD_S,
) -> list[str]:
    """Spin ``spinning`` until the graph shows every node the launch started
    (``settled_nodes``; ``started()``: how many, None before the launch said) or
    ``ended()`` (a process has exited); the live nodes. ``TimeoutError`` after ``guard``."""
    nodes: list[str] | None = None

    def settled() -> bool:
        nonlocal nodes
        count = started()
        nodes = None if count is None else settled_nodes(probe, count)
        return nodes is not None or ended()

    if not ros.spin_until(settled, spinning, timeout=guard):
        raise TimeoutError(not_on_graph(guard, started() or 0, probe))
    return graph_nodes(probe) if nodes is None else nodes


def _wait_for_nodes(system: Launch, probe: Probe, guard: float = GRAPH_GUARD_S) -> list[str]:
    """``wait_for_launch`` for a launch started here."""
    return wait_for_launch(
        probe,
        lambda: started_nodes(p.name for p in system.processes),
        lambda: len(system.running()) < len(system.processes),
        probe.node,
        guard,
    )


def started_nodes(processes: Iterable[str]) -> int:
    """How many of a launch's processes (``talker-1``: as ``ros2 launch`` names them) run
    one of the package's executables, each a node (another process, such as a
    ``sleep``, makes none)."""
    return sum(re.sub(r"-\d+$", "", name) in EXECUTABLES for name in processes)


def not_on_graph(guard: float, started: int, watcher: Probe | RclpyNode) -> str:
    """What the feedback says when a launch's nodes did not all show within ``guard``."""
    node = _graph_node(watcher)
    reported, logging = _reports(node)
    return (
        f"timeout: {guard:.0f} s after the launch, {sure_nodes(reported, logging) or 0} of "
        f"its {started} nodes were on the ROS graph (live: {graph_nodes(watcher)}; "
        f"reported: {reported_nodes(watcher)}). The check waits for each launched node "
        "to show with its topics; one that never shows is stuck before it makes its node."
    )


def assert_graph(
    probe: Probe,
    nodes: list[str],
    expected: list[str],
    started: int,
    died: list[tuple[str, int | None, list[str]]],
) -> None:
    """The launch made exactly the ``expected`` nodes, with their chatter endpoints.
    ``started``: how many processes it started; ``died``: (process, exit code, what it
    printed) of those that exited right after the launch."""
    if died:
        name, code, lines = died[0]
        last = _tail("\n".join(lines), 6)
        hint = ""
        if "InvalidParameterTypeException" in last:
            hint = " The rate must be a float: {'rate': 5.0}, not {'rate': 5}."
        raise CheckFailed(
            f"{name} exited right after the launch with code {code}.{hint} It printed:\n{last}"
        )
    missing = [n for n in expected if n not in nodes]
    extra = [n for n in nodes if n not in expected]
    if missing or extra or started != len(expected):
        hint = ""
        if any(n.count("/") == 1 for n in extra):
            hint = (
                " A node launched without namespace= runs in the root namespace '/': "
                "give each robot's nodes namespace='robot1' or namespace='robot2'."
            )
        raise CheckFailed(
            f"the launch started {started} processes, and the graph holds "
            f"{nodes}; expected exactly {expected}. Missing: {missing or 'none'}; not "
            f"expected: {extra or 'none'}.{hint}"
        )
    for robot in ROBOTS:
        published, subscribed = endpoints(probe, robot)
        for node, kind, found in (
            ("talker", "publish on", published),
            ("listener", "subscribe to", subscribed),
        ):
            if f"/{robot}/chatter" not in found:
                topics = sorted(t for t in found if not t.startswith(("/rosout", "/parameter")))
                raise CheckFailed(
                    f"/{robot}/{node} does not {kind} /{robot}/chatter (its topics: "
                    f"{topics}): keep the relative topic name 'chatter', without a "
                    "remapping, so that the namespace applies to it"
                )


# -- graded: what the judge starts as the student, and judges from its own nodes -------

#: The judge keeps one participant from the first test cell it runs to its own end
#: (read by ``autograder.judge``): its watchers and probes come and go while the
#: student's nodes start and stop, and a participant destroyed then can hang (Fast
#: DDS's teardown hang, ``autograder/judge.py``).
HOLD_PARTICIPANT = True

#: Hang guards (wall clock): a colcon build; programs started in the sandbox showing up
#: (its cgroup shares the CPU as one process does: slow on a busy machine); a program's
#: stop after Ctrl-C (``ros2 launch`` waits that long before it escalates to SIGTERM).
BUILD_GUARD_S = 300.0
START_GUARD_S = 120.0
EXIT_GUARD_S = 60.0
#: Simulated seconds between the judge's /clock messages on a two-robot launch.
CLOCK_STEP_S = 0.05
#: Lines of a program's output that a stop which timed out reports.
STOP_TAIL = 20


def share(folder: Path) -> None:
    """The reference ``robot_talk`` built once for a grading run (read by
    ``autograder.judge.shared_env``): every submission's try-it cells and two-robot
    launches use it, read-only, instead of building their own."""
    build_reference(folder / SHARED_REFERENCE)


class StopTimeout(StillRunning):
    """A program did not end after Ctrl-C within its hang guard: a timeout."""


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
        Ctrl-C); its exit code. A hang guard: ``StopTimeout`` if it does not stop."""
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
    with run_program(argv, cwd=j.folder, wrap=j.wrap, path=Path(what)) as run:
        yield Program(run)


def finished(j: Judgement, argv: list[str], what: str, stdin: str = "") -> tuple[int, str]:
    """``argv`` run to its end as the student: (exit code, output)."""
    with run_program(argv, cwd=j.folder, wrap=j.wrap, stdin=True) as run:
        try:
            output, _ = run.proc.communicate(stdin, timeout=BUILD_GUARD_S)
        except subprocess.TimeoutExpired:
            raise TimedOut(f"{what} did not finish within {BUILD_GUARD_S:.0f} s") from None
    return run.proc.returncode, output


def as_student(j: Judgement, what: str, folder: str, request: dict[str, Any]) -> dict[str, Any]:
    """``python -I -m rosbook.labs.lab06 WHAT FOLDER`` run as the student, given
    ``request``; its report (the line that repeats the nonce sent on its stdin)."""
    nonce = uuid.uuid4().hex
    argv = [sys.executable, "-I", "-m", "rosbook.labs.lab06", what, folder]
    doing = {"manifest": f"building {PACKAGE} with colcon"}.get(what, f"the {what} build")
    code, output = finished(j, argv, doing, json.dumps({**request, "nonce": nonce}))
    for line in output.splitlines():
        if line.startswith(REPORT):
            try:
                report = dict(json.loads(line[len(REPORT) :]))
            except (ValueError, TypeError):
                continue
            if report.get("nonce") == nonce and code == 0:
                return report
    raise CheckFailed(f"{doing} failed (exit code {code}):\n{_tail(output, 8)}")


@contextmanager
def scratch_folder(j: Judgement) -> Iterator[str]:
    """A folder for a check's builds, made and removed by the student's own ``mktemp``
    and ``rm`` (the judge writes nothing where the student's code can put a link)."""
    argv = ["mktemp", "-d", "-p", "/tmp", "rosbook_lab06.XXXXXX"]
    code, output = finished(j, argv, "mktemp")
    if code != 0:
        raise CheckFailed(f"no scratch folder could be made for the build: {output.strip()}")
    folder = output.strip().splitlines()[-1]
    try:
        yield folder
    finally:
        finished(j, ["rm", "-rf", folder], "rm")


def _judged_two_robots(j: Judgement, generate: Student, seconds: float) -> TwoRobotsReport:
    """``check_two_robots`` graded: the kernel pickles the description into a scratch
    folder, and ``ros2 launch`` runs it as the student, against the reference build."""
    with scratch_folder(j) as folder:
        description = f"{folder}/description.pickle"
        _description_into(j, generate, description)
        workspace = reported_workspace(folder, as_student(j, "reference", folder, {}))
        print(f"[judge] the reference {PACKAGE}: {workspace}", flush=True)
        try:
            report, code = launch_two_robots(j, folder, workspace, description, seconds)
            again = raced(report.exit_codes, report.output)  # rclpy's own race on Ctrl-C
        except StopTimeout:  # a node stuck in Fast DDS's teardown hang: once more
            again = True
        if again:
            report, code = launch_two_robots(j, folder, workspace, description, seconds)
    codes = report.exit_codes
    assert_stopped_cleanly(
        codes,
        code != 0 and not any(codes.values()),
        {name: _lines_of(report.output, name) for name in codes},
    )
    return report


def _description_into(j: Judgement, generate: Student, path: str) -> None:
    """What the student's ``generate()`` returns, pickled by the kernel into ``path``."""
    call = f"{generate.name}()"
    try:
        made = decode(j.kernel.call("call_to_file", generate.name, path))
    except KernelError as exc:
        if "NotImplementedError" in str(exc):
            raise CheckFailed(f"{call}: this task is not done yet (NotImplementedError)") from None
        raise CheckFailed(f"{call} raised {exc}") from None
    if not isinstance(made, dict) or made.get("type") != "LaunchDescription":
        raise not_a_description(str(made.get("type") if isinstance(made, dict) else made))
    if made.get("error"):
        raise CheckFailed(
            "the LaunchDescription cannot be handed to `ros2 launch` (it is pickled "
            f"to get there): {made['error']}. Use plain values in it, not functions."
        )


def reported_workspace(folder: str, report: dict[str, Any]) -> str:
    """The workspace the ``reference`` run used: the run's shared build, or its own in
    ``folder``; any other is an error of the grader's, never the student's."""
    shared = os.environ.get(SHARED_ENV)
    expected = {f"{folder}/ws"} | ({f"{shared}/{SHARED_REFERENCE}"} if shared else set())
    workspace = str(report.get("workspace"))
    if workspace not in expected:
        raise RuntimeError(f"the reference build reported {workspace}, not one of {expected}")
    return workspace


def launch_two_robots(
    j: Judgement, folder: str, workspace: str, description: str, seconds: float
) -> tuple[TwoRobotsReport, int]:
    """``ros2 launch`` of the pickled description, judged for ``seconds`` of the judge's
    /clock and stopped with one Ctrl-C: what it showed, and the launch's exit code. It
    waits ``EXIT_GUARD_S`` after Ctrl-C before SIGTERM (a slow stop is no mistake)."""
    command = (
        f"source {shlex.quote(workspace)}/install/setup.bash && "
        f"ROSBOOK_LAB06_DESCRIPTION={shlex.quote(description)} "
        f"exec ros2 launch {shlex.quote(folder)}/{JUDGED_LAUNCH} "
        f"sigterm_timeout:={EXIT_GUARD_S:g}"
    )
    guard = EXIT_GUARD_S + 2 * EVENT_GUARD_S  # past the launch's SIGTERM and SIGKILL
    lingering()
    with started(j, ["bash", "-c", command], "ros2 launch") as system:
        try:
            nodes, counts = launched(system, seconds)
        except BaseException:
            with suppress(TimedOut):  # the nodes are stopped as always: Ctrl-C
                system.stop("`ros2 launch`", guard=guard)
            raise
        code = system.stop("`ros2 launch`", guard=guard)
    return TwoRobotsReport(nodes, counts, seconds, exit_codes(system.lines), system.lines), code


def lingering() -> None:
    """Wait until an earlier launch's nodes have left the graph: killed, they linger
    until their DDS lease ends (then the launch goes on regardless). Live nodes only
    (``graph_nodes``): a report left of one that has gone never leaves."""
    watcher = ros_node("judge_lab06_gone")
    expected = set(expected_nodes(ROBOTS))

    def gone() -> bool:
        return not expected & set(graph_nodes(watcher))

    try:
        ros.spin_until(gone, watcher, timeout=START_GUARD_S)
    finally:
        ros.remove(watcher)


def raced(codes: dict[str, int], lines: list[str]) -> bool:
    """A node that did not stop cleanly on the one Ctrl-C, or was escalated to. The
    nodes are the reference's (``robot_talk``, honest code the description only starts
    and names), so this is a race or hang in shutdown that honest code meets on a
    loaded machine: rclpy's own race on Ctrl-C (``probes.rclpy_raced``), Fast DDS's
    teardown hang (``autograder/judge.py``), a node stopped by a signal, and once in a
    stress run a listener that ended with exit code 1. The launch runs once more; a
    second unclean stop is the verdict, with what the node printed last."""
    return any(codes.values()) or any(ESCALATED in line for line in lines)


#: ``ros2 launch``'s own lines about its processes.
STARTED = re.compile(r"^\[INFO\] \[([^\]]+)\]: process started with pid")
DIED = re.compile(r"^\[ERROR\] \[([^\]]+)\]: process has died \[pid \d+, exit code (-?\d+)")
CLEAN = re.compile(r"^\[INFO\] \[([^\]]+)\]: process has finished cleanly")


def exit_codes(lines: list[str]) -> dict[str, int]:
    """Each process's exit code, as ``ros2 launch`` printed them."""
    codes: dict[str, int] = {}
    for line in lines:
        if match := DIED.match(line):
            codes[match[1]] = int(match[2])
        elif match := CLEAN.match(line):
            codes[match[1]] = 0
    return codes


def launched(system: Program, seconds: float) -> tuple[list[str], dict[str, int]]:
    """Judge the graph the launch made, then run it for ``seconds`` on the judge's
    /clock: the live nodes, and how many messages each robot's talker published."""
    watcher = ros_node("judge_lab06_graph")
    probes = {robot: Probe(f"/{robot}/chatter", String, name="rate") for robot in ROBOTS}
    probe = probes["robot1"]

    def processes() -> list[str]:
        return [m[1] for line in list(system.lines) if (m := STARTED.match(line))]

    def started() -> int | None:
        names = processes()  # none until ros2 launch says it started them
        return started_nodes(names) if names else None

    def ended() -> bool:
        return not system.alive() or bool(exit_codes(system.lines))

    try:
        nodes = wait_for_launch(probe, started, ended, watcher, START_GUARD_S)
        codes = exit_codes(system.lines)
        died = [(name, code, _lines_of(system.lines, name)) for name, code in codes.items()]
        if not system.alive():
            system.stop("`ros2 launch`")  # it has exited: its last lines are read
        if not system.alive() and not processes():
            raise CheckFailed(
                "`ros2 launch` stopped before it started a process; it printed:\n"
                + "\n".join(system.lines[-8:])
            )
        assert_graph(probe, nodes, expected_nodes(ROBOTS), len(processes()), died)
        return nodes, run_on_clock(watcher, probes, seconds)
    finally:
        for p in probes.values():
            p.close()
        ros.remove(watcher)


def _lines_of(lines: list[str], process: str) -> list[str]:
    prefix = f"[{process}] "
    return [line[len(prefix) :] for line in lines if line.startswith(prefix)]


def talker_rates(node: RclpyNode) -> dict[str, float | None]:
    """Each robot's talker's ``rate`` parameter, asked over its parameter service: it
    paces the judge's /clock (what is judged is the messages that arrive)."""
    rates: dict[str, float | None] = {}
    for robot in ROBOTS:
        client = node.create_client(GetParameters, f"/{robot}/talker/get_parameters")
        try:
            if not ros.spin_until(client.service_is_ready, node, timeout=START_GUARD_S):
                raise TimedOut(f"/{robot}/talker's parameter service did not appear")
            future = client.call_async(GetParameters.Request(names=["rate"]))
            if not ros.spin_until(future.done, node, timeout=START_GUARD_S):
                raise TimedOut(f"/{robot}/talker did not say its rate")
            values = future.result().values
            is_double = values and values[0].type == ParameterType.PARAMETER_DOUBLE
            rates[robot] = values[0].double_value if is_double else None
        finally:
            node.destroy_client(client)
    return rates


def run_on_clock(node: RclpyNode, probes: dict[str, Probe], seconds: float) -> dict[str, int]:
    """Publish /clock in steps up to ``seconds``, each once every talker published what
    its rate makes due (sent again meanwhile: a /clock message to a best-effort
    subscription can be lost); the messages each probe received."""
    clock = clock_publisher(node)
    if not ros.spin_until(lambda: clock.get_subscription_count() >= 4, node, timeout=START_GUARD_S):
        raise CheckFailed(
            "the launched nodes do not all listen to /clock although the check adds "
            "SetParameter('use_sim_time', True) first: did the description change "
            "use_sim_time?"
        )
    rates = talker_rates(node)
    listening = [node, *(probe.node for probe in probes.values())]
    for k in range(1, round(seconds / CLOCK_STEP_S) + 1):
        t = k * CLOCK_STEP_S
        clock.publish(clock_message(t))

        def arrived(t: float = t) -> bool:
            return all(
                len(probes[robot].received.messages) >= int(t * rate + 1e-9)
                for robot, rate in rates.items()
                if rate
            )

        deadline = time.monotonic() + START_GUARD_S
        while not ros.spin_until(arrived, *listening, timeout=CLOCK_RETRY_S):
            if time.monotonic() > deadline:
                raise TimedOut(f"the talkers did not publish on /clock's t = {t:.2f} s")
            clock.publish(clock_message(t))
    return {robot: len(p.received.messages) for robot, p in probes.items()}


# -- as a program: the builds, run as the student where the student's code runs -------

#: The launch file ``reference`` writes: the kernel's description, on simulated time.
JUDGED_LAUNCH = "two_robots.launch.py"


def pickled_description() -> LaunchDescription:
    """What the student's ``generate_launch_description()`` returned, pickled by their
    kernel into the file ``ROSBOOK_LAB06_DESCRIPTION`` names, after
    ``SetParameter('use_sim_time', True)`` (loaded by ``ros2 launch``, as the student)."""
    import pickle

    with open(os.environ["ROSBOOK_LAB06_DESCRIPTION"], "rb") as f:
        description = pickle.load(f)  # noqa: S301 - the student's own, loaded as the student
    assert_description(description)
    return LaunchDescription([SetParameter("use_sim_time", True), *description.entities])


#: Starts the one line a ``python -m rosbook.labs.lab06`` run reports (JSON follows).
REPORT = "rosbook-lab06-report: "


def main(argv: list[str] | None = None) -> int:
    """``python -I -m rosbook.labs.lab06 manifest|reference FOLDER``, given a JSON object
    on stdin: ``manifest`` builds ``robot_talk`` in ``FOLDER/ws`` from its
    ``package_xml`` and ``setup_py`` and reports what the build shows (``BuildFacts``);
    ``reference`` builds the reference package in ``FOLDER/ws`` (unless the grader
    shared one: ``shared_reference``), reports the workspace and writes
    ``FOLDER/two_robots.launch.py``. The judge runs these as the student (``setup.py``
    is the student's code); the report repeats the ``nonce`` it was given, which the
    student's code never sees."""
    what, folder = sys.argv[1:] if argv is None else argv
    request = json.load(sys.stdin)
    root = Path(folder)
    if what == "reference":
        workspace = shared_reference() or build_reference(root / "ws")
        (root / JUDGED_LAUNCH).write_text(
            "from rosbook.labs import lab06\n\n\ndef generate_launch_description():\n"
            "    return lab06.pickled_description()\n"
        )
        report: dict[str, object] = {"workspace": str(workspace.root)}
    else:
        built = build_package(request["package_xml"], request["setup_py"], root / "ws")
        assert isinstance(built, BuiltPackage)  # built here, not judged
        report = {"facts": asdict(built.facts)}
    print(REPORT + json.dumps({**report, "nonce": request["nonce"]}), flush=True)
    return 0


deferrable(globals())

if __name__ == "__main__":
    raise SystemExit(main())
