"""Interface packages built by the real colcon from the wheels, used across processes."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from catkin_pkg.package import parse_package

from rosbook.launch import interfaces_build
from rosbook.launch.interfaces_build import BuildSetupError, InterfaceError
from rosbook.launch.workspace import Workspace, create_package

FIXTURES = Path(__file__).parent / "fixtures" / "interfaces"
ROS2 = [sys.executable, "-m", "rosbook.cli"]


@pytest.fixture(scope="module")
def built(tmp_path_factory: pytest.TempPathFactory) -> Workspace:
    """The tutorial's interface package (Num, Sphere, AddThreeInts, Countdown), built once."""
    ws = Workspace(tmp_path_factory.mktemp("ws"))
    shutil.copytree(FIXTURES / "tutorial_interfaces", ws.src / "tutorial_interfaces")
    run = interfaces_build.build(ws)
    assert run.ok, run.output
    return ws


def test_pkg_create_ament_cmake_writes_upstreams_layout(tmp_path: Path) -> None:
    lines: list[str] = []
    root = create_package(
        "demo_interfaces", tmp_path, build_type="ament_cmake", license="Apache-2.0",
        log=lines.append,
    )  # fmt: skip
    files = sorted(str(p.relative_to(root)) for p in root.rglob("*"))
    assert files == ["CMakeLists.txt", "LICENSE", "include", "include/demo_interfaces",
                     "package.xml", "src"]  # fmt: skip
    manifest = parse_package(str(root / "package.xml"))
    assert manifest.get_build_type() == "ament_cmake"
    assert [d.name for d in manifest.buildtool_depends] == ["ament_cmake"]
    assert [d.name for d in manifest.test_depends] == ["ament_lint_auto", "ament_lint_common"]
    cmake = (root / "CMakeLists.txt").read_text()
    assert cmake.startswith("cmake_minimum_required(VERSION 3.8)\nproject(demo_interfaces)\n")
    assert "find_package(ament_cmake REQUIRED)" in cmake and cmake.endswith("ament_package()\n")
    assert "creating source and include folder" in lines
    assert f"creating folder {tmp_path}/demo_interfaces/include/demo_interfaces" in lines


def test_an_empty_ament_cmake_package_builds_with_its_linters_off(tmp_path: Path) -> None:
    # The template's BUILD_TESTING block asks for ament_lint_auto, which has no wheel.
    ws = Workspace(tmp_path)
    create_package("empty_pkg", ws.src, build_type="ament_cmake", log=None)
    run = interfaces_build.build(ws)
    assert run.ok, run.output
    assert (ws.install / "empty_pkg" / "share" / "empty_pkg" / "package.xml").is_file()


def test_interface_types_cross_two_processes(built: Workspace) -> None:
    env = built.environ()
    script = str(FIXTURES / "nodes.py")
    server = subprocess.Popen(
        [sys.executable, script, "serve"], env=env, stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        asked = subprocess.run(
            [sys.executable, script, "ask"], env=env, capture_output=True, text=True,
            timeout=300,  # only a hang guard
        )  # fmt: skip
    finally:
        server.terminate()
        try:
            served, _ = server.communicate(timeout=60)
        except subprocess.TimeoutExpired:  # Fast DDS's rare teardown hang (book/computation_
            server.kill()  # graph.md): how the server ends is not what this test checks
            served, _ = server.communicate()
    assert asked.returncode == 0, asked.stdout + asked.stderr + served
    lines = asked.stdout.splitlines()
    assert lines[0] == "sum: 6" and lines[2:] == ["result: [3, 2, 1, 0]", "sphere: 7.0 at x=1.0"]
    # feedback is a topic: rclpy drops what arrives after the result, so some may be missing
    feedback = [int(n) for n in lines[1].removeprefix("feedback: [").rstrip("]").split(", ")]
    assert feedback and feedback == sorted(feedback, reverse=True) and set(feedback) <= {3, 2, 1, 0}


def test_ros2_interface_shows_the_new_types(built: Workspace) -> None:
    env = built.environ()

    def show(name: str) -> str:
        done = subprocess.run([*ROS2, "interface", "show", name], env=env, capture_output=True,
                              text=True, check=True)  # fmt: skip
        return done.stdout

    assert show("tutorial_interfaces/msg/Sphere") == (
        "geometry_msgs/Point center\n\tfloat64 x\n\tfloat64 y\n\tfloat64 z\nfloat64 radius\n"
    )
    assert show("tutorial_interfaces/action/Countdown") == (
        "# Goal: the number to count down from\nint32 start\n---\n"
        "# Result: every number counted, from start down to 0\nint32[] sequence\n---\n"
        "# Feedback: the number just counted\nint32 current\n"
    )


def test_a_broken_msg_is_one_line_naming_the_file_and_the_problem(tmp_path: Path) -> None:
    ws = Workspace(tmp_path)
    package = ws.src / "tutorial_interfaces"
    shutil.copytree(FIXTURES / "tutorial_interfaces", package)
    (package / "msg" / "Num.msg").write_text("int64 num\nfloat99 bad\n")
    with pytest.raises(InterfaceError) as raised:
        interfaces_build.build(ws)
    message = str(raised.value)
    assert "\n" not in message
    assert message.startswith("tutorial_interfaces/msg/Num.msg:2: 'float99' is an invalid"), message
    assert not (ws.root / "build").exists()  # refused before colcon ran


def test_a_badly_named_interface_file_is_refused(tmp_path: Path) -> None:
    package = tmp_path / "pkg"
    (package / "srv").mkdir(parents=True)
    (package / "srv" / "add_ints.srv").write_text("int64 a\n---\nint64 sum\n")
    with pytest.raises(InterfaceError, match=r"^pkg/srv/add_ints.srv: the type name 'add_ints'"):
        interfaces_build.check_interfaces(package)


def test_a_missing_compiler_is_named_with_how_to_get_it(tmp_path: Path) -> None:
    env = {"PATH": str(tmp_path), "CC": "no-such-cc"}  # nothing on PATH
    with pytest.raises(BuildSetupError) as raised:
        interfaces_build.environ(env)
    assert str(raised.value) == (
        "no C compiler found (looked for $CC=no-such-cc): install one, e.g. `sudo apt install "
        "build-essential` (Debian, Ubuntu) or `sudo dnf install gcc-c++` (Fedora)"
    )
    assert "no C++ compiler found (looked for c++, g++, clang++)" in "\n".join(
        interfaces_build.missing(env)
    )


def test_the_course_tf2_msgs_is_installed_in_the_venv() -> None:
    # make builds rosbook/ros_packages into the venv, as the wheels' packages are installed
    done = subprocess.run(
        [*ROS2, "interface", "show", "tf2_msgs/msg/TFMessage"], capture_output=True, text=True,
        check=True,
    )  # fmt: skip
    assert done.stdout.startswith("geometry_msgs/TransformStamped[] transforms\n")
    assert "up to date" in interfaces_build.install_course_packages()
