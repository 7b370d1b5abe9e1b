"""Checks for lab 6: a student's package manifest built with colcon, and a launch of two robots.

The package is ``robot_talk``: a talker whose rate is a parameter and a listener, laid
out by ``write_layout``. ``build_package`` builds it with the student's ``package.xml``
and ``setup.py`` in a scratch workspace, for real; ``check_two_robots`` launches the
student's description against a reference build and inspects the ROS graph on
simulated time. Failures are ``CheckFailed`` errors (``AssertionError``s) naming the mistake.

The grader's judge makes the same checks outside the student's kernel: it runs the
builds as the student with ``python -I -m rosbook.labs.lab06`` (``main``), and the
launch with ``ros2 launch`` on the description the kernel returned
(``pickled_description``), and judges what it sees with the functions here.
"""

from __future__ import annotations

import atexit
import os
import re
import shutil
from collections import Counter
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from functools import cache
from importlib.resources import files
from pathlib import Path

from rclpy.node import Node as RclpyNode
from rclpy.topic_endpoint_info import TopicEndpointInfo
from std_msgs.msg import String

from rosbook.labs.deferral import deferrable
from rosbook.labs.probes import CheckFailed, Probe
from rosbook.launch.launcher import (
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
class BuiltPackage:
    """A scratch workspace with ``robot_talk`` in it, after ``colcon build``."""

    workspace: Workspace
    build: ColconRun
    env: dict[str, str] = field(default_factory=dict)

    @property
    def source(self) -> Path:
        return self.workspace.src / PACKAGE


_builds: dict[tuple[str, str], BuiltPackage] = {}


def _scratch(prefix: str) -> Workspace:
    """A scratch workspace that is deleted when this process exits (graders make many)."""
    ws = Workspace.scratch(prefix)
    atexit.register(ws.remove)
    return ws


def build_package(package_xml: str, setup_py: str, root: str | Path | None = None) -> BuiltPackage:
    """Lay out ``robot_talk`` with these manifests in a workspace (``root``, else a
    scratch one); colcon-build it.

    The same two texts are built once per process (a check after a try-it cell reuses
    the build).
    """
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


def _tail(text: str, lines: int = 12) -> str:
    return "\n".join(text.strip().splitlines()[-lines:])


def assert_built(built: BuiltPackage) -> None:
    """colcon succeeded and the package is in the ament index under its name."""
    run = built.build
    if not run.ok:
        hint = ""
        if "resource/" in run.output and "can't copy" in run.output:
            hint = (
                " setup.py installs 'resource/' + package_name as the package marker: "
                f"package_name in setup.py must be '{PACKAGE}', the name in package.xml."
            )
        elif "SyntaxError" in run.output or "Traceback" in run.output:
            hint = " setup.py does not run: look at the Python error above."
        raise CheckFailed(
            f"colcon build failed (exit code {run.returncode}).{hint}\n"
            f"colcon printed:\n{_tail(run.output)}"
        )
    manifest = _parse_manifest(built)
    if manifest.name != PACKAGE:
        raise CheckFailed(
            f"package.xml names the package '{manifest.name}'; the folder and the task "
            f"call it '{PACKAGE}'"
        )
    if PACKAGE not in packages(built.env):
        raise CheckFailed(
            f"colcon built the folder, but '{PACKAGE}' is not in the ament index, so "
            "`ros2 run` cannot find it. setup.py's data_files must install "
            f"('share/ament_index/resource_index/packages', ['resource/{PACKAGE}'])."
        )


def _parse_manifest(built: BuiltPackage):  # -> catkin_pkg.package.Package
    from catkin_pkg.package import InvalidPackage, parse_package

    try:
        return parse_package(str(built.source / "package.xml"))
    except InvalidPackage as error:
        raise CheckFailed(
            f"package.xml is not a valid manifest: {str(error).splitlines()[-1]}. colcon "
            "then builds the folder as a plain Python package, outside the ament index, "
            "so `ros2 run` and `ros2 launch` cannot find it."
        ) from None
    except Exception as error:  # not XML at all
        raise CheckFailed(f"package.xml cannot be read as XML: {error}") from None


def setup_py_version(built: BuiltPackage) -> str | None:
    """The version setup.py gave, read back from the build's egg-info."""
    for info in (built.workspace.root / "build" / PACKAGE).glob("*.egg-info/PKG-INFO"):
        match = re.search(r"^Version: (.+)$", info.read_text(), re.MULTILINE)
        if match:
            return match.group(1).strip()
    return None


def assert_versions_agree(built: BuiltPackage, expected: str = VERSION) -> None:
    """package.xml and setup.py state the same version, the one the task asks for."""
    xml_version = _parse_manifest(built).version
    py_version = setup_py_version(built)
    if py_version != xml_version:
        raise CheckFailed(
            f"package.xml says version {xml_version} but setup.py says {py_version}: "
            "colcon builds it anyway, without a word, but the two must agree (tools and "
            "the package index read package.xml, Python reads setup.py)"
        )
    if xml_version != expected:
        raise CheckFailed(f"the version is {xml_version}; the task asks for {expected}")


def assert_dependencies(built: BuiltPackage, needed: Iterable[str] = DEPENDENCIES) -> None:
    """package.xml declares every package the nodes import, for run time."""
    manifest = _parse_manifest(built)
    declared = {dep.name for dep in manifest.exec_depends}
    missing = [name for name in needed if name not in declared]
    if missing:
        tags = " ".join(f"<depend>{name}</depend>" for name in missing)
        raise CheckFailed(
            f"package.xml does not declare {', '.join(missing)} as a run-time dependency "
            f"(the nodes import them): add {tags}"
        )


def assert_executables(built: BuiltPackage, expected: dict[str, str] = EXECUTABLES) -> None:
    """Every node is an executable of the package (an entry point in setup.py)."""
    have = executables(PACKAGE, built.env)
    missing = [name for name in expected if name not in have]
    if missing:
        entries = ", ".join(f"'{name} = {expected[name]}'" for name in missing)
        raise CheckFailed(
            f"`ros2 run {PACKAGE} {missing[0]}` finds no executable '{missing[0]}': the "
            f"package's executables are {have or 'none'}. The entry point is not "
            f"registered: add {entries} to entry_points={{'console_scripts': [...]}} in "
            "setup.py"
        )


def assert_installed(built: BuiltPackage, relative: str = f"launch/{LAUNCH_FILE}") -> None:
    """A data file was installed into ``share/robot_talk/``."""
    share = built.workspace.install / PACKAGE / "share" / PACKAGE
    if not (share / relative).exists():
        folder = relative.split("/")[0]
        raise CheckFailed(
            f"{relative} was not installed into share/{PACKAGE}/{folder}/, so "
            f"`ros2 launch {PACKAGE} {Path(relative).name}` cannot find it: add "
            f"(os.path.join('share', package_name, '{folder}'), glob('{folder}/*')) "
            "to data_files in setup.py"
        )


def assert_runs(
    built: BuiltPackage, executable: str, topic: str = "/chatter", publishes: bool = True
) -> list[str]:
    """``ros2 run robot_talk EXECUTABLE`` starts a node that uses ``topic``; Ctrl-C stops it."""
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


#: The checks made before ``ros2 run robot_talk talker`` in the test cell; the rest
#: come after it, and ``ros2 run robot_talk listener`` last.
CHECKED_BEFORE_RUN = ("built", "versions", "talker")


def first_manifest_failure(
    built: BuiltPackage,
    expected_executables: dict[str, str] = EXECUTABLES,
    dependencies: Iterable[str] = DEPENDENCIES,
    installed: str = f"launch/{LAUNCH_FILE}",
) -> tuple[str, str] | None:
    """``(check, message)`` of the first of the test cell's checks of the built package
    (all but the runs) that fails, in the cell's order; None if all hold."""
    talker = {"talker": expected_executables["talker"]}
    for name, check in (
        ("built", assert_built),
        ("versions", assert_versions_agree),
        ("talker", lambda b: assert_executables(b, talker)),
        ("executables", lambda b: assert_executables(b, expected_executables)),
        ("dependencies", lambda b: assert_dependencies(b, dependencies)),
        ("installed", lambda b: assert_installed(b, installed)),
    ):
        try:
            check(built)
        except CheckFailed as error:
            return name, str(error)
    return None


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
#: all the run's submissions (``autograder.judge_lab06.share``).
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
    generate: Callable[[], LaunchDescription], seconds: float = 2.0
) -> TwoRobotsReport:
    """Launch ``generate()``, check the graph, drive /clock for ``seconds``, stop it."""
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


# -- as a program: the builds, run as the student where the student's code runs -------

#: The launch file ``reference`` writes: the kernel's description, on simulated time.
JUDGED_LAUNCH = "two_robots.launch.py"


def pickled_description() -> LaunchDescription:
    """What the student's ``generate_launch_description()`` returned, pickled by their
    kernel into the file ``ROSBOOK_LAB06_DESCRIPTION`` names, after
    ``SetParameter('use_sim_time', True)`` (loaded by ``ros2 launch``, as the student)."""
    import os
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
    ``package_xml`` and ``setup_py`` and reports the first failing check (``expected``:
    ``first_manifest_failure``'s keywords); ``reference`` builds the reference package
    in ``FOLDER/ws`` (unless the grader shared one: ``shared_reference``), reports the
    workspace and writes ``FOLDER/two_robots.launch.py``. A grader runs these as
    the student (``setup.py`` is the student's code); the report repeats the ``nonce``
    it was given, which the student's code never sees."""
    import json
    import sys

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
        report = {"failure": first_manifest_failure(built, **request["expected"])}
    print(REPORT + json.dumps({**report, "nonce": request["nonce"]}), flush=True)
    return 0


deferrable(globals())

if __name__ == "__main__":
    raise SystemExit(main())
