"""Launch files written for a full install run unchanged: ``launch`` and ``launch_ros``.

The launch files in ``tests/launch_tutorial/`` are the official Jazzy launch tutorials'
("Using substitutions", launch arguments, "Integrating launch files into ROS 2
packages") with robot_talk's talker and listener for turtlesim; they import only
``launch`` and ``launch_ros``, are installed by a package's ``setup.py`` and run with
``ros2 launch``, and what they launch is checked on the ROS graph.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import pytest
from std_msgs.msg import String

from rosbook.labs.lab06 import add_reference_package
from rosbook.labs.probes import Probe
from rosbook.launch.launcher import ESCALATED, Launch, LaunchError, include
from rosbook.launch.workspace import Workspace, create_package
from rosbook.runtime.params import get_parameter
from rosbook.runtime.session import Session
from tests.launchtools import alive, read_until, start_launch

pytestmark = pytest.mark.slow

TUTORIAL = Path(__file__).parent / "launch_tutorial"
DATA_FILES = """\
        ('share/' + package_name, ['package.xml']),
        (os.path.join('share', package_name, 'launch'),
            glob(os.path.join('launch', '*launch.[pxy][yma]*'))),
        (os.path.join('share', package_name, 'config'), glob('config/*.yaml')),
"""


@pytest.fixture(scope="module")
def env(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """robot_talk and launch_tutorial (the tutorials' launch files, installed as the
    "Integrating launch files" tutorial's setup.py does), one build; ``ros2`` on PATH."""
    ws = Workspace(tmp_path_factory.mktemp("ws"))
    add_reference_package(ws.src)
    root = create_package(
        "launch_tutorial",
        ws.src,
        dependencies=["robot_talk"],
        maintainer_email="a@example.com",
        log=None,
    )
    shutil.copytree(TUTORIAL, root, dirs_exist_ok=True)
    setup = (root / "setup.py").read_text()
    setup = "import os\nfrom glob import glob\n\n" + setup.replace(
        "        ('share/' + package_name, ['package.xml']),\n", DATA_FILES
    )
    (root / "setup.py").write_text(setup)
    run = ws.build()
    assert run.ok, run.output
    environ = ws.environ()
    environ["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{environ['PATH']}"
    environ["ROS_SRC"] = str(root)
    return environ


@pytest.fixture
def launched(env: dict[str, str]) -> Iterator[list[subprocess.Popen[str]]]:
    """``ros2 launch`` processes a test starts: Ctrl-C after it; none of theirs left."""
    procs: list[subprocess.Popen[str]] = []
    yield procs
    for proc in procs:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGINT)
        proc.communicate(timeout=30)


def ros2_launch(env: dict[str, str], *argv: str) -> subprocess.CompletedProcess[str]:
    """``ros2 launch ARGV`` for a command that ends by itself (``-s``, errors), as typed
    in a terminal: the sourced workspace's ``launch/`` folders are on ``sys.path``."""
    return subprocess.run(
        ["ros2", "launch", *argv],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )


def stop(proc: subprocess.Popen[str], lines: list[str], *, escalated_ok: bool = False) -> str:
    """One Ctrl-C; everything it printed (read on from ``lines``, through the same buffer);
    every process it started stopped cleanly (or, ``escalated_ok``, the launcher had to
    escalate). It is SIGKILLed if that takes 30 s."""
    assert proc.stdout is not None
    os.killpg(proc.pid, signal.SIGINT)
    watchdog = threading.Timer(30.0, os.killpg, (proc.pid, signal.SIGKILL))
    watchdog.start()
    text = "".join(lines) + proc.stdout.read()
    watchdog.cancel()
    proc.wait()
    if escalated_ok and ESCALATED in text:
        return text
    assert proc.returncode == 0, f"timeout: {text}" if proc.returncode == -9 else text
    return text


def run_and_stop(
    env: dict[str, str],
    launched: list[subprocess.Popen[str]],
    argv: Sequence[str],
    started: str,
    while_running: Callable[[], object],
) -> str:
    """``ros2 launch ARGV`` until it printed ``started`` and ``while_running()`` (the
    test's checks of the running system) returned, then ``stop``: what it printed.

    Nodes stopped together by one Ctrl-C sometimes hang in Fast DDS's participant
    teardown (eProsima/Fast-DDS#6513, about 1 launch in 150 under load) and the launcher
    escalates to SIGKILL, as upstream's does: right for the launcher, not what these
    tests are about. That run, and only that, is tried once more (as in test_launch)."""
    for attempt in range(2):
        proc = start_launch(env, *argv)
        launched.append(proc)
        lines = read_until(proc, started, [])
        while_running()
        text = stop(proc, lines, escalated_ok=attempt == 0)
        if ESCALATED not in text:
            return text
    raise AssertionError("unreachable: the second run's stop asserts a clean one")


def wait_until_spinning(session: Session, names: set[tuple[str, str]], *probes: Probe) -> Probe:
    """Wait until the nodes ``names`` are on the graph and each probe heard a message (a
    node that published spins: a Ctrl-C then stops it cleanly, not mid-import)."""
    observer = probes[0].node

    def seen() -> bool:
        graph = set(observer.get_node_names_and_namespaces())
        return names <= graph and all(p.received.messages for p in probes)

    assert session.spin_until(seen, timeout=60.0), (
        f"timeout: {names} not all on the graph or silent: "
        f"{observer.get_node_names_and_namespaces()}"
    )
    return probes[0]


def test_show_args_prints_the_arguments_as_upstream(env: dict[str, str]) -> None:
    done = ros2_launch(env, "launch_tutorial", "example_arguments.launch.py", "--show-args")
    assert done.returncode == 0, done.stderr
    assert done.stdout == (
        "Arguments (pass arguments as '<name>:=<value>'):\n"
        "\n"
        "    'rate':\n"
        "        Publishing rate of the talker in Hz\n"
        "        (default: '2.0')\n"
        "\n"
        "    'robot':\n"
        "        One of: ['robot1', 'robot2']\n"
        "        (default: 'robot1')\n"
        "\n"
        "    'with_listener':\n"
        "        no description given\n"
        "        (default: 'true')\n"
    )
    # an included file's arguments are the including file's too
    done = ros2_launch(env, "-s", "launch_tutorial", "example_main.launch.py")
    assert "    'talker_ns':\n        no description given\n        (default: 'talker1')" in (
        done.stdout
    ), done.stdout + done.stderr
    done = ros2_launch(env, "launch_tutorial", "my_script_launch.py", "-s")
    assert done.stdout.endswith("\n\n  No arguments.\n"), done.stdout + done.stderr


def test_arguments_namespaces_conditions_and_parameter_files_reach_the_graph(
    env: dict[str, str], session: Session, launched: list[subprocess.Popen[str]]
) -> None:
    source = Path(env["ROS_SRC"]) / "launch" / "example_arguments.launch.py"

    def running() -> None:
        probe = wait_until_spinning(
            session,
            {("talker", "/robot2"), ("config_talker", "/")},
            Probe("/robot2/chatter", String),
            Probe("/chatter", String),
        )
        assert get_parameter(probe.node, "/robot2/talker", "rate", timeout=30.0) == 5.0
        assert get_parameter(probe.node, "/config_talker", "rate", timeout=30.0) == 8.0  # yaml

    # path mode, as upstream: the arguments follow the file
    argv = (str(source), "rate:=5.0", "robot:=robot2", "with_listener:=false")
    text = run_and_stop(env, launched, argv, "process started", running)
    assert "[INFO] [launch.user]: Launching for robot2 in the lab" in text
    assert text.count("process started") == 2, text  # with_listener:=false: no listener
    assert "[talker-1] [INFO]" in text and "[robot2.talker]: Publishing" in text


def test_an_include_passes_its_launch_arguments_and_a_timer_runs_a_conditioned_process(
    env: dict[str, str], session: Session, launched: list[subprocess.Popen[str]]
) -> None:
    # 2 s on, the condition (new_rate == 4.0 and use_provided_rate) holds: the process runs
    text = run_and_stop(
        env,
        launched,
        ("launch_tutorial", "example_main.launch.py"),
        "rate of talker2/talker: 4.0",
        lambda: wait_until_spinning(
            session, {("talker", "/talker2")}, Probe("/talker2/chatter", String)
        ),
    )
    assert "[echo-2] rate of talker2/talker: 4.0" in text, text
    assert "[INFO] [echo-2]: process has finished cleanly" in text, text


def test_a_package_launch_file_of_the_integrating_tutorial_runs(
    env: dict[str, str], session: Session, launched: list[subprocess.Popen[str]]
) -> None:
    text = run_and_stop(
        env,
        launched,
        ("launch_tutorial", "my_script_launch.py"),
        "process started",
        lambda: wait_until_spinning(session, {("talker", "/")}, Probe("/chatter", String)),
    )
    pid = int(text.split("process started with pid [")[1].split("]")[0])
    assert not alive(pid)


def test_a_required_argument_a_bad_choice_and_a_malformed_argument_are_named(
    env: dict[str, str], tmp_path: Path
) -> None:
    required = tmp_path / "required.launch.py"
    required.write_text(
        "from launch import LaunchDescription\n"
        "from launch.actions import DeclareLaunchArgument\n\n\n"
        "def generate_launch_description():\n"
        "    return LaunchDescription([DeclareLaunchArgument('robot', description='which')])\n"
    )
    with pytest.raises(LaunchError, match="missing required argument 'robot'"):
        Launch(include(required), env=env)
    Launch(include(required, [("robot", "r1")]), env=env)  # given: fine
    arguments = Path(env["ROS_SRC"]) / "launch" / "example_arguments.launch.py"
    with pytest.raises(LaunchError, match='Argument "robot" provided value "robot3" is not valid'):
        Launch(include(arguments, [("robot", "robot3")]), env=env)
    done = ros2_launch(env, str(arguments), "robot=robot2")
    assert done.returncode == 1
    assert "malformed launch argument 'robot=robot2', expected format '<name>:=<value>'" in (
        done.stderr
    )
    broken = tmp_path / "broken.launch.py"
    broken.write_text("def generate_launch_description():\n    raise ValueError('no robot')\n")
    done = ros2_launch(env, str(broken))
    assert done.returncode == 1
    assert "[ERROR] [launch]: Caught exception in launch (see debug for traceback): no robot" in (
        done.stderr
    )


def test_groups_scope_namespaces_parameters_and_configurations(env: dict[str, str]) -> None:
    from launch import LaunchDescription
    from launch.actions import GroupAction, SetLaunchConfiguration
    from launch.conditions import UnlessCondition
    from launch.substitutions import LaunchConfiguration, PythonExpression
    from launch_ros.actions import Node, PushRosNamespace, SetParameter

    def talker(name: str, **kwargs: object) -> Node:
        return Node(package="robot_talk", executable="talker", name=name, **kwargs)

    description = LaunchDescription(
        [
            SetLaunchConfiguration("fast", "true"),
            PushRosNamespace("fleet"),
            GroupAction(
                [
                    PushRosNamespace("a"),
                    SetParameter("rate", PythonExpression(["2 * ", "3.5"])),
                    talker("t1"),
                    talker("t2", namespace="/abs"),
                    SetLaunchConfiguration("fast", "false"),
                ]
            ),
            talker("t3", condition=UnlessCondition(LaunchConfiguration("fast"))),
            talker("t4", namespace="b"),
        ]
    )
    commands = {p.cmd[p.cmd.index("-r") + 1]: p.cmd for p in Launch(description, env=env)._plan}
    assert list(commands) == ["__node:=t1", "__node:=t2", "__node:=t4"]  # fast stays true
    assert commands["__node:=t1"][-4:] == ["-r", "__ns:=/fleet/a", "-p", "rate:=7.0"]
    assert commands["__node:=t2"][-4:] == ["-r", "__ns:=/abs", "-p", "rate:=7.0"]
    assert commands["__node:=t4"][-2:] == ["-r", "__ns:=/fleet/b"]  # no rate: scoped


def test_process_events_timers_and_shutdown_run_their_actions(env: dict[str, str]) -> None:
    from launch import LaunchDescription
    from launch.actions import ExecuteProcess, LogInfo, RegisterEventHandler, Shutdown, TimerAction
    from launch.event_handlers import OnProcessExit, OnProcessStart
    from launch.substitutions import EnvironmentVariable, ThisLaunchFileDir

    first = ExecuteProcess(
        cmd=["echo", ["hello ", EnvironmentVariable("USER_NAME")]], output="screen"
    )
    later = ExecuteProcess(cmd=[["echo", " from the timer"]], shell=True, output="screen")
    sleeper = ExecuteProcess(cmd=["sleep", "600"], name="sleeper")
    description = LaunchDescription(
        [
            RegisterEventHandler(
                OnProcessStart(
                    target_action=first, on_start=lambda event, _: LogInfo(msg=event.process_name)
                )
            ),
            RegisterEventHandler(
                OnProcessExit(
                    target_action=first,
                    on_exit=[LogInfo(msg="first exited"), TimerAction(period=0.5, actions=[later])],
                )
            ),
            RegisterEventHandler(
                OnProcessExit(target_action=later, on_exit=[Shutdown(reason="all done")])
            ),
            first,
            sleeper,
        ]
    )
    system = Launch(description, env={**env, "USER_NAME": "ada"}, echo=None).start()
    assert system.wait(timeout=60.0), f"timeout: {system.output}"  # Shutdown stops the sleeper
    out = [line.split(" [pid")[0] for line in system.output]
    assert "[echo-1] hello ada" in out and "[echo-3] from the timer" in out
    order = [
        "[INFO] [launch.user]: echo-1",
        "[INFO] [launch.user]: first exited",
        "[INFO] [echo-3]: process started with pid",
        "[INFO] [launch]: shutting down: all done",
    ]
    assert [line for line in out if any(line.startswith(o) for o in order)] == [
        next(line for line in out if line.startswith(o)) for o in order
    ]
    assert system.process("sleeper-2").returncode == -signal.SIGINT
    with pytest.raises(LaunchError, match="ThisLaunchFileDir used outside of a launch file"):
        Launch(LaunchDescription([LogInfo(msg=ThisLaunchFileDir())]), env=env)


def test_the_event_handlers_tutorial_answers_each_event_and_shuts_down_when_its_node_exits(
    env: dict[str, str], session: Session, launched: list[subprocess.Popen[str]]
) -> None:
    proc = start_launch(
        {**env, "USER": "ada"},
        "launch_tutorial",
        "example_event_handlers.launch.py",
        "use_provided_rate:=True",
    )
    launched.append(proc)
    # the conditioned `param set` runs last (2 s after the rate request completed)
    lines = read_until(proc, "[INFO] [ros2-4]: process has finished cleanly", [], guard=120)
    text = "".join(lines)
    assert "[INFO] [ros2-4]: process has finished cleanly" in text, f"timeout: {text}"
    out = [line.rstrip("\n") for line in lines]
    said = [line for line in out if line.startswith("[INFO] [launch.user]: ")]
    assert said[0] == "[INFO] [launch.user]: Talker started, asking its rate", text
    answers = [s for s in said if s.startswith('[INFO] [launch.user]: Rate request says "')]
    assert any("double_value=1.0" in a for a in answers), text  # OnProcessIO, per line
    finished = said.index("[INFO] [launch.user]: Rate request finished")
    assert finished > said.index(answers[-1]), text  # the process completed after its output
    # the two `param set`s (3.0 at once, the conditioned new_rate 5.0 after the timer):
    # the parameter holds whichever finished last
    last = max(
        ("ros2-3", 3.0),
        ("ros2-4", 5.0),
        key=lambda p: text.index(f"[{p[0]}]: process has finished"),
    )
    probe = Probe("/talker1/chatter", String)
    wait_until_spinning(session, {("sim", "/talker1")}, probe)
    assert get_parameter(probe.node, "/talker1/sim", "rate", timeout=30.0) == last[1]
    # "closing the window": the node exits, and the launch shuts down by itself
    pid = int(text.split("[INFO] [talker-1]: process started with pid [")[1].split("]")[0])
    os.killpg(pid, signal.SIGINT)
    rest = "".join(read_until(proc, None, lines, guard=60)[len(out) :])
    assert proc.wait() == 0, rest
    assert "[INFO] [launch.user]: ada closed the talker" in rest, rest
    assert "[INFO] [launch]: shutting down: Window closed" in rest, rest
    assert "[INFO] [launch.user]: Launch was asked to shutdown: Window closed" in rest, rest


@pytest.mark.parametrize(
    "launch_file", ["example_formats.launch.xml", "example_formats.launch.yaml"]
)
def test_the_launch_file_formats_pages_xml_and_yaml_run_as_python_ones_do(
    env: dict[str, str],
    session: Session,
    launched: list[subprocess.Popen[str]],
    launch_file: str,
) -> None:
    def running() -> None:
        probe = wait_until_spinning(
            session,
            {
                ("talker", "/chatter/py/ns"),
                ("talker", "/chatter/xml/ns"),
                ("talker", "/chatter/yaml/ns"),
                ("sim", "/turtlesim2"),
                ("mimic", "/"),
            },
            Probe("/turtlesim2/chatter", String),
            Probe("/chatter/py/ns/chatter", String),
            Probe("/chatter/xml/ns/chatter", String),
            Probe("/chatter/yaml/ns/chatter", String),
        )
        assert get_parameter(probe.node, "/turtlesim2/sim", "rate", timeout=30.0) == 5.0
        subscribed = probe.node.get_subscriber_names_and_types_by_node("mimic", "/")
        assert ("/turtlesim2/chatter", ["std_msgs/msg/String"]) in subscribed  # remapped

    text = run_and_stop(
        env, launched, ("launch_tutorial", launch_file, "rate:=5.0"), "process started", running
    )
    assert text.count("process started") == 5, text


def test_a_lifecycle_node_is_driven_through_its_transitions_by_events(
    env: dict[str, str], session: Session
) -> None:
    from lifecycle_msgs.msg import Transition

    from launch import LaunchDescription
    from launch.actions import EmitEvent, LogInfo, RegisterEventHandler
    from launch.event_handlers import OnProcessStart
    from launch.events import matches_action
    from launch.substitutions import LocalSubstitution
    from launch_ros.actions import LifecycleNode
    from launch_ros.event_handlers import OnStateTransition
    from launch_ros.events.lifecycle import ChangeState

    talker = LifecycleNode(
        executable=sys.executable,
        arguments=[str(TUTORIAL / "scripts" / "lifecycle_talker.py")],
        name="lc_talker",
        namespace="lc",
        output="screen",
    )

    def change(transition: int) -> EmitEvent:
        return EmitEvent(
            event=ChangeState(
                lifecycle_node_matcher=matches_action(talker), transition_id=transition
            )
        )

    description = LaunchDescription(
        [
            RegisterEventHandler(
                OnProcessStart(
                    target_action=talker, on_start=[change(Transition.TRANSITION_CONFIGURE)]
                )
            ),
            RegisterEventHandler(
                OnStateTransition(
                    target_lifecycle_node=talker,
                    goal_state="inactive",
                    entities=[LogInfo(msg="inactive"), change(Transition.TRANSITION_ACTIVATE)],
                )
            ),
            RegisterEventHandler(
                OnStateTransition(
                    target_lifecycle_node=talker,
                    start_state="activating",
                    goal_state="active",
                    entities=[
                        LogInfo(msg=["active after ", LocalSubstitution("event.start_state")])
                    ],
                )
            ),
            talker,
        ]
    )
    probe = Probe("/lc/chatter", String)
    with Launch(description, env=env, echo=None).start() as system:

        def said() -> list[str]:
            return [line for line in system.output if "[launch.user]" in line]

        def active_and_heard() -> bool:
            system.pump()
            return bool(probe.received.messages) and len(said()) == 2

        assert session.spin_until(active_and_heard, timeout=90.0), f"timeout: {system.output}"
        assert said() == [
            "[INFO] [launch.user]: inactive",
            "[INFO] [launch.user]: active after activating",
        ], system.output
        assert system.ros_adapter.node.count_publishers("/lc/lc_talker/transition_event") == 1


def test_the_large_projects_tutorial_pushes_a_namespace_and_a_remap_into_an_include(
    env: dict[str, str], session: Session, launched: list[subprocess.Popen[str]]
) -> None:
    def running() -> None:
        probe = wait_until_spinning(
            session,
            {("sim", "/"), ("sim", "/robot2")},
            Probe("/chatter", String),
            Probe("/robot2/news", String),
        )
        assert get_parameter(probe.node, "/sim", "rate", timeout=30.0) == 3.0
        assert get_parameter(probe.node, "/robot2/sim", "rate", timeout=30.0) == 6.0

    text = run_and_stop(
        env, launched, ("launch_tutorial", "robots.launch.py"), "process started", running
    )
    assert text.count("process started") == 2, text
