"""Scaffold an ament_python package, build it with the real colcon, find and run it."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from catkin_pkg.package import parse_package

from rosbook.launch import workspace
from rosbook.launch.workspace import (
    ColconRun,
    ExecutableNotFoundError,
    PackageNotFoundError,
    Workspace,
    create_package,
    executable_path,
    sh,
    sourced_environ,
)

ROS2 = [sys.executable, "-m", "rosbook.cli"]


@dataclass
class Scaffolded:
    workspace: Workspace
    scaffold_output: str
    build: ColconRun


@pytest.fixture(scope="module")
def scaffolded(tmp_path_factory: pytest.TempPathFactory) -> Scaffolded:
    """`ros2 pkg create --build-type ament_python --dependencies rclpy --node-name hello`,
    then `colcon build --symlink-install`: one build for the whole module."""
    ws = Workspace(tmp_path_factory.mktemp("ws"))
    done = subprocess.run(
        [
            *ROS2,
            "pkg",
            "create",
            "demo_pkg",
            "--build-type",
            "ament_python",
            "--dependencies",
            "rclpy",
            "--node-name",
            "hello",
            "--maintainer-email",
            "me@example.com",
        ],
        cwd=ws.src,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    return Scaffolded(ws, done.stdout, ws.build())


@pytest.fixture(scope="module")
def built(scaffolded: Scaffolded) -> Workspace:
    return scaffolded.workspace


def test_pkg_create_writes_the_ament_python_layout(scaffolded: Scaffolded) -> None:
    root = scaffolded.workspace.src / "demo_pkg"
    files = sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())
    assert files == [
        "demo_pkg/__init__.py",
        "demo_pkg/hello.py",
        "package.xml",
        "resource/demo_pkg",
        "setup.cfg",
        "setup.py",
        "test/test_copyright.py",
        "test/test_flake8.py",
        "test/test_pep257.py",
    ]
    manifest = parse_package(str(root / "package.xml"))  # valid format 3, or this raises
    assert (manifest.name, manifest.version, manifest.package_format) == ("demo_pkg", "0.0.0", 3)
    assert [d.name for d in manifest.exec_depends] == ["rclpy"]
    assert manifest.get_build_type() == "ament_python"
    setup_py = (root / "setup.py").read_text()
    assert "'hello = demo_pkg.hello:main'," in setup_py
    assert "install_scripts=$base/lib/demo_pkg" in (root / "setup.cfg").read_text()
    assert "creating ./demo_pkg/package.xml" in scaffolded.scaffold_output


def test_pkg_create_refuses_bad_names_other_build_types_and_existing_folders(
    tmp_path: Path,
) -> None:
    with pytest.raises(ValueError, match="not valid"):
        create_package("Demo-Pkg", tmp_path, log=None)
    with pytest.raises(ValueError, match="'cmake' is not available"):
        create_package("demo", tmp_path, build_type="cmake", log=None)
    with pytest.raises(ValueError, match="C\\+\\+ node"):
        create_package("demo", tmp_path, build_type="ament_cmake", node_name="n", log=None)
    create_package("demo", tmp_path, log=None)
    with pytest.raises(FileExistsError, match="already exists"):
        create_package("demo", tmp_path, log=None)


def test_colcon_build_installs_the_package_into_the_ament_index(scaffolded: Scaffolded) -> None:
    built, run = scaffolded.workspace, scaffolded.build
    assert run.ok, run.output
    assert "Starting >>> demo_pkg" in run.output and "Finished <<< demo_pkg" in run.output
    assert {p.name for p in built.root.iterdir()} >= {"src", "build", "install", "log"}
    env = built.environ()
    assert env["AMENT_PREFIX_PATH"].split(os.pathsep)[0] == str(built.install / "demo_pkg")
    assert workspace.packages(env)["demo_pkg"] == built.install / "demo_pkg"
    assert workspace.executables("demo_pkg", env) == ["hello"]
    assert "demo_pkg" not in workspace.packages({})  # not sourced: not found


def test_ros2_run_starts_the_entry_point_after_sourcing(built: Workspace) -> None:
    env = built.environ()
    done = subprocess.run(
        [*ROS2, "run", "demo_pkg", "hello"], env=env, capture_output=True, text=True, timeout=60
    )
    assert (done.returncode, done.stdout) == (0, "Hi from demo_pkg.\n"), done.stderr
    exes = subprocess.run(
        [*ROS2, "pkg", "executables", "demo_pkg"], env=env, capture_output=True, text=True
    )
    assert exes.stdout == "demo_pkg hello\n"


def test_ros2_run_names_the_missing_package_or_executable(built: Workspace) -> None:
    # upstream's words (ros2run/command/run.py), which scripts and students grep for
    env = built.environ()
    missing_exe = subprocess.run(
        [*ROS2, "run", "demo_pkg", "talker"], env=env, capture_output=True, text=True
    )
    assert (missing_exe.returncode, missing_exe.stderr) == (1, "No executable found\n")
    unsourced = subprocess.run(
        [*ROS2, "run", "demo_pkg", "hello"],
        env={k: v for k, v in env.items() if k != "AMENT_PREFIX_PATH"},
        capture_output=True,
        text=True,
    )
    assert (unsourced.returncode, unsourced.stderr) == (1, "Package 'demo_pkg' not found\n")


def test_symlink_install_runs_edited_code_without_rebuilding(built: Workspace) -> None:
    node = built.src / "demo_pkg" / "demo_pkg" / "hello.py"
    original = node.read_text()
    node.write_text(original.replace("Hi from", "Edited:"))
    try:
        path = executable_path("demo_pkg", "hello", built.environ())
        done = subprocess.run([str(path)], env=built.environ(), capture_output=True, text=True)
        assert done.stdout == "Edited: demo_pkg.\n"
    finally:
        node.write_text(original)


def make_prefix(root: Path, package: str, executable: str, text: str) -> Path:
    """An install prefix as colcon leaves it: index marker and lib/<pkg>/<exe>."""
    (root / "share/ament_index/resource_index/packages").mkdir(parents=True)
    (root / "share/ament_index/resource_index/packages" / package).touch()
    exe = root / "lib" / package / executable
    exe.parent.mkdir(parents=True)
    exe.write_text(f"#!/bin/sh\necho {text}\n")
    exe.chmod(0o755)
    return root


def test_first_prefix_on_ament_prefix_path_wins_overlay_over_underlay(tmp_path: Path) -> None:
    underlay = make_prefix(tmp_path / "underlay", "greeter", "greet", "underlay")
    overlay = make_prefix(tmp_path / "overlay", "greeter", "greet", "overlay")
    env = {"AMENT_PREFIX_PATH": f"{overlay}{os.pathsep}{underlay}"}
    assert executable_path("greeter", "greet", env).parent.parent.parent == overlay
    env = {"AMENT_PREFIX_PATH": f"{underlay}{os.pathsep}{overlay}"}
    assert executable_path("greeter", "greet", env).parent.parent.parent == underlay
    with pytest.raises(PackageNotFoundError):
        executable_path("greeter", "greet", {})
    with pytest.raises(ExecutableNotFoundError, match="it has: greet"):
        executable_path("greeter", "wave", env)


def test_the_venv_is_the_underlay_with_the_ros_packages() -> None:
    assert {"rclpy", "std_msgs"} <= set(workspace.packages({}))


def test_sourcing_runs_the_scripts_in_bash_in_order(tmp_path: Path) -> None:
    for name in ("a", "b"):
        folder = tmp_path / name
        folder.mkdir()
        (folder / "setup.bash").write_text(f'export ORDER="${{ORDER}}{name}"\n')
    env = sourced_environ(tmp_path / "a", tmp_path / "b", base={"PATH": os.environ["PATH"]})
    assert env["ORDER"] == "ab"
    with pytest.raises(RuntimeError, match="sourcing"):
        sourced_environ(tmp_path / "missing", base={"PATH": os.environ["PATH"]})


def test_ros2_pkg_list_and_prefix_read_the_ament_index(built: Workspace) -> None:
    env = built.environ()
    listed = subprocess.run([*ROS2, "pkg", "list"], env=env, capture_output=True, text=True)
    names = listed.stdout.split()
    assert {"demo_pkg", "rclpy", "std_msgs"} <= set(names) and names == sorted(names)
    prefix = subprocess.run(
        [*ROS2, "pkg", "prefix", "demo_pkg"], env=env, capture_output=True, text=True
    )
    assert prefix.stdout.strip() == str(built.install / "demo_pkg")


def test_sh_presses_ctrl_c_once_the_output_showed_what_it_should(tmp_path: Path) -> None:
    """A program that runs until Ctrl-C is stopped after its third line, not after a time."""
    loop = "trap 'echo interrupted; exit 130' INT; for i in $(seq 1000); do echo tick $i; "
    loop += "sleep 0.05; done"
    done = sh(loop, cwd=tmp_path, ctrl_c_after=r"^tick \d", times=3, echo=False)
    assert "tick 3\n" in done.stdout and "tick 1000" not in done.stdout, done.stdout
    assert done.stdout.rstrip().endswith("interrupted") and done.returncode == 130


def test_sh_runs_a_launch_whose_ctrl_c_had_to_escalate_once_more(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Fast DDS's teardown hang (a node killed after Ctrl-C, honest code) gets one more
    run; what the cell prints is that run's."""
    from rosbook.launch.launcher import ESCALATED

    stuck = f"[WARNING] [talker-1]: {ESCALATED}"
    command = f"if [ -e ran ]; then echo second; else touch ran; echo '{stuck}'; fi; echo up"
    done = sh(command, cwd=tmp_path, ctrl_c_after="never")
    assert done.stdout == "second\nup\n"
    assert capsys.readouterr().out == f"$ {command}\nsecond\nup\n"
    (tmp_path / "ran").unlink()
    assert sh(command, cwd=tmp_path, echo=False).stdout == f"{stuck}\nup\n"  # no Ctrl-C: once


def test_sh_waits_for_every_pattern_and_says_timeout_when_one_never_comes(tmp_path: Path) -> None:
    with pytest.raises(subprocess.TimeoutExpired) as caught:
        sh("echo ready; sleep 60", cwd=tmp_path, ctrl_c_after=["ready", "never"], timeout=2)
    assert "timeout: 1 of 1 lines matching 'ready', 0 of 1 lines matching 'never'" in str(
        caught.value.output
    )


def test_sh_shows_a_commands_output_without_terminal_colours(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """CMake colours its warnings in a terminal: a page would show them as yellow on
    white (too little contrast to read), so what ``sh`` prints has no colour codes."""
    from rosbook.launch.workspace import sh

    done = sh("printf '\\033[33mCMake Warning\\033[0m: old\\n'", cwd=tmp_path)
    assert "\x1b[33m" in done.stdout  # the command's own output keeps them
    assert capsys.readouterr().out.splitlines()[-1] == "CMake Warning: old"
