"""rclpy from the ROS 2 wheels outside a venv: pip's user site and Debian's dist-packages.

The wheels (the pins of requirements.txt) are installed by the system's Python, not the
venv's, into a throwaway folder in one of two layouts:

- ``user site``: ``pip install --user`` with a throwaway ``HOME`` and ``PYTHONUSERBASE``
  (``~/.local/lib/pythonX.Y/site-packages``, libraries in ``~/.local/lib``);
- ``dist-packages``: what ``sudo pip install`` does on Debian and Ubuntu (and the hub
  images built on them), ``/usr/local/lib/pythonX.Y/dist-packages`` with the libraries in
  ``/usr/local/lib``, under a throwaway ``pip install --root``.

In each, a plain ``import rclpy`` fails (what the wheels' own bootstrap leaves), and a
talker and a listener (tests/wheel_nodes.py) that ``import rosbook`` first, the project on
``PYTHONPATH``, exchange a message over DDS in this run's ROS domain. Nothing of the venv
reaches them: the environment is built from scratch. Installing takes a while (pip's cache
makes it a copy of ~240 MB): the tests are slow ones.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import pytest
import rclpy

from rosbook.book.pages import ROOT
from rosbook.labs.probes import rclpy_raced
from rosbook.runtime import wheels
from rosbook.runtime.isolation import BASE_ENV, RUN_MARKER

#: The system's Python, outside any venv (Debian's, on this project's Linux machines).
SYSTEM_PYTHON = Path("/usr/bin/python3")
#: The ROS wheels the book needs, at the versions requirements.txt pins.
WHEELS = [
    line.split(";")[0].strip()
    for line in (ROOT / "requirements.txt").read_text().splitlines()
    if line.startswith(("ros-jazzy-rclpy", "ros-jazzy-common-interfaces", "ros-jazzy-rmw-"))
]
#: A wall-clock guard against a hung pip (it downloads when its cache is cold).
INSTALL_TIMEOUT_S = 900
#: A guard against hung nodes: discovery and one message take seconds.
RUN_TIMEOUT_S = 120


def system_python_version() -> tuple[int, int] | None:
    if not SYSTEM_PYTHON.exists():
        return None
    out = subprocess.run(
        [SYSTEM_PYTHON, "-c", "import sys; print(*sys.version_info[:2])"],
        capture_output=True,
        text=True,
        timeout=60,
        check=True,
    ).stdout
    major, minor = map(int, out.split())
    return major, minor


def outside_env(**layout: str) -> dict[str, str]:
    """An environment with nothing of the venv: this run's ROS isolation, the layout's
    variables and the project on PYTHONPATH (no LD_LIBRARY_PATH, no venv on PATH)."""
    ros = {key: os.environ[key] for key in [*BASE_ENV, "ROS_DOMAIN_ID", RUN_MARKER]}
    return {**ros, "PATH": "/usr/bin:/bin", "LANG": "C.UTF-8", **layout}


def pip_install(args: list[str], env: dict[str, str]) -> None:
    command = [str(SYSTEM_PYTHON), "-m", "pip", "install", "--quiet", *args, *WHEELS]
    try:
        result = subprocess.run(
            command, env=env, capture_output=True, text=True, timeout=INSTALL_TIMEOUT_S
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"timeout: {' '.join(command)} still running after {INSTALL_TIMEOUT_S} s")
    assert result.returncode == 0, result.stderr[-3000:]


class Layout(NamedTuple):
    """The wheels installed in one layout: ``user site`` or ``dist-packages``."""

    name: str
    #: The environment that runs the system's Python there, the project on PYTHONPATH.
    env: dict[str, str]
    #: Where the wheels' Python code went.
    code: Path


@pytest.fixture(scope="module", params=["user site", "dist-packages"])
def layout(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[Layout]:
    """The wheels installed by the system's Python in one layout (~240 MB, removed after)."""
    version = system_python_version()
    if version is None or not (3, 10) <= version <= (3, 13):
        pytest.skip(f"{SYSTEM_PYTHON} is missing or not Python 3.10-3.13 (the wheels' range)")
    python = f"python{version[0]}.{version[1]}"
    folder = tmp_path_factory.mktemp("layout")
    home = folder / "home"
    # pip's settings, proxies and cache (not the throwaway HOME's) kept; pip refuses to
    # install into a system Python (PEP 668) unless told to.
    cache = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "pip"
    pip_env = {
        "PIP_CACHE_DIR": str(cache),
        **{
            k: v
            for k, v in os.environ.items()
            if k.startswith("PIP_") or k.lower().endswith("_proxy")
        },
        **outside_env(HOME=str(home), PIP_BREAK_SYSTEM_PACKAGES="1"),
    }
    if request.param == "user site":
        user_base = home / ".local"
        pip_install(["--user"], {**pip_env, "PYTHONUSERBASE": str(user_base)})
        env = outside_env(HOME=str(home), PYTHONUSERBASE=str(user_base), PYTHONPATH=str(ROOT))
        yield Layout(request.param, env, user_base / "lib" / python / "site-packages")
        shutil.rmtree(folder)
        return
    root = folder / "root"
    pip_install(["--root", str(root)], pip_env)
    local = root / "usr" / "local" / "lib"
    assert (local / python / "dist-packages").is_dir() and (local / "librcl.so").exists()
    # No user site: the system's folders and dist-packages, as on Debian.
    env = outside_env(
        HOME=str(home),
        PYTHONNOUSERSITE="1",
        PYTHONPATH=f"{ROOT}:{local / python / 'dist-packages'}",
    )
    yield Layout(request.param, env, local / python / "site-packages")
    shutil.rmtree(folder)


def python_error(env: dict[str, str], code: str) -> str:
    """What the system's Python prints when ``code`` fails there."""
    result = subprocess.run(
        [SYSTEM_PYTHON, "-c", code], env=env, capture_output=True, text=True, timeout=RUN_TIMEOUT_S
    )
    assert result.returncode != 0, f"{code!r} ran"
    return result.stderr


@pytest.mark.slow
def test_without_rosbook_rclpy_does_not_import_there(layout: Layout) -> None:
    env = layout.env
    if layout.name == "dist-packages":
        # The wheels' Python code is data of theirs, put in <data>/lib/pythonX.Y/
        # site-packages: Debian's Python does not look there.
        error = python_error(env, "from rclpy.node import Node")
        assert "No module named 'rclpy.node'" in error, error
        env = {**env, "PYTHONPATH": f"{env['PYTHONPATH']}:{layout.code}"}
    error = python_error(env, "from rclpy.node import Node")
    assert "librcl_action.so: cannot open shared object file" in error, error


@pytest.mark.slow
def test_a_talker_and_a_listener_talk_there_after_import_rosbook(layout: Layout) -> None:
    nodes = [str(SYSTEM_PYTHON), str(Path(__file__).with_name("wheel_nodes.py"))]
    run = {"env": layout.env, "stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True}
    with subprocess.Popen([*nodes, "listener"], **run) as listener:
        with subprocess.Popen([*nodes, "talker"], **run) as talker:
            try:
                out, err = listener.communicate(timeout=RUN_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                listener.kill()
                out, err = listener.communicate()
                err = f"timeout: nothing heard in {RUN_TIMEOUT_S} s\n{err}"
            finally:
                talker.terminate()
                talker_out, talker_err = talker.communicate(timeout=RUN_TIMEOUT_S)
    assert listener.returncode == 0, err + talker_err
    assert out.strip() == "heard: hello from outside a venv", out + err
    # how the talker ends on SIGTERM is not what this test checks, only that it raised
    # nothing but rclpy's own race (its handler shut the context while spin() waited)
    assert talker.returncode in (0, -15) or rclpy_raced(talker_err), talker_err


@pytest.mark.slow
def test_processes_started_after_import_rosbook_import_rclpy_there(layout: Layout) -> None:
    """A node a notebook or ``ros2 launch`` starts need not import rosbook itself."""
    child = "from rclpy.node import Node; from std_msgs.msg import String; print('imported')"
    parent = f"import rosbook, subprocess, sys; subprocess.run([sys.executable, '-c', {child!r}])"
    result = subprocess.run(
        [SYSTEM_PYTHON, "-c", parent],
        env=layout.env,
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT_S,
    )
    assert result.stdout == "imported\n", result.stderr


def test_in_the_venv_there_is_nothing_to_preload() -> None:
    """The wheels' bootstrap found the libraries here: ``import rosbook`` leaves it be."""
    assert not wheels.preload()


def test_the_libraries_of_rclpy_are_read_from_its_extension_module() -> None:
    extension = next(Path(rclpy.__file__).parent.glob("_rclpy_pybind11*.so"))
    needed = wheels.needed(extension)
    ros = [name for name in needed if name.startswith(("librcl", "librmw", "libfastrtps"))]
    found = {path.name for folder in wheels.installed_dirs()[0] for path in folder.glob("*.so*")}
    assert wheels.PROBE in ros and set(ros) <= found, set(ros) - found
