"""Interface packages (``.msg``, ``.srv``, ``.action``) built by the real colcon from the wheels.

An ``ament_cmake`` package whose ``CMakeLists.txt`` calls ``rosidl_generate_interfaces``
builds here as on a full install, with ``colcon build``, once its environment says what a
sourced ``/opt/ros/jazzy`` would (``environ``):

* ``AMENT_PREFIX_PATH`` ends with the venv, which is the ROS prefix (``share/<pkg>/cmake``,
  ``lib/``, ``include/`` of every wheel);
* CMake's generator is Ninja, and both ``cmake`` and ``ninja`` are the venv's (PyPI's);
* ``CMAKE_TOOLCHAIN_FILE`` is ``wheel_prefix.cmake`` beside this module: the wheels' CMake
  exports name the include folders of the machine that built them, and it points them at
  this interpreter's (``ROSBOOK_PYTHON_INCLUDE``, ``ROSBOOK_NUMPY_INCLUDE``); it also
  turns the linters' tests off (no wheel has them);
* a C and a C++ compiler, and Python's headers, come from the system: ``missing`` says
  which is absent and how to get it, in one line.

``python -m rosbook.launch.interfaces_build install`` (run by ``make``) builds the course's
own interface packages (``rosbook/ros_packages``: ``tf2_msgs``) into the venv, as the
wheels' packages are installed; ``... env`` prints the environment as ``export`` lines,
for a terminal.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import os
import re
import shlex
import shutil
import sys
import sysconfig
import tempfile
from collections.abc import Mapping
from pathlib import Path

from rosbook.launch.workspace import BASE_PREFIX, ColconRun, Workspace

#: The CMake toolchain file that mends the wheels' exports (see the module's docstring).
TOOLCHAIN = Path(__file__).with_name("wheel_prefix.cmake")

#: The course's own interface packages, built into the venv by ``make``.
COURSE_PACKAGES = Path(__file__).resolve().parent.parent / "ros_packages"

#: Hash of the course packages' sources last installed into a prefix (skips a rebuild).
INSTALLED_STAMP = Path("share") / "rosbook" / "ros_packages.sha256"

#: What each interface folder holds, and the rosidl parser of its files.
INTERFACE_KINDS = {"msg": ".msg", "srv": ".srv", "action": ".action"}

_COMPILERS = {
    "C": ("CC", ["cc", "gcc", "clang"]),
    "C++": ("CXX", ["c++", "g++", "clang++"]),
}
_INSTALL_HINT = (
    "install one, e.g. `sudo apt install build-essential` (Debian, Ubuntu) or "
    "`sudo dnf install gcc-c++` (Fedora)"
)


class BuildSetupError(RuntimeError):
    """This machine lacks something a package with interfaces needs to build (one line)."""


class InterfaceError(ValueError):
    """An interface file that does not parse: one line naming the file and the problem."""


def python_include() -> Path:
    """The folder of this interpreter's ``Python.h``."""
    return Path(sysconfig.get_paths()["include"])


def numpy_include() -> Path:
    """numpy's C headers, which the generated Python type supports include."""
    import numpy

    return Path(numpy.get_include())


def missing(env: Mapping[str, str] | None = None) -> list[str]:
    """What this machine lacks to build interfaces, one line each saying how to get it."""
    env = os.environ if env is None else env
    path = env.get("PATH")
    problems = []
    for language, (variable, names) in _COMPILERS.items():
        chosen = env.get(variable)
        candidates = [chosen.split()[0]] if chosen else names
        if not any(shutil.which(name, path=path) for name in candidates):
            looked = f"${variable}={chosen}" if chosen else ", ".join(names)
            problems.append(f"no {language} compiler found (looked for {looked}): {_INSTALL_HINT}")
    header = python_include() / "Python.h"
    if not header.is_file():
        version = f"{sys.version_info.major}.{sys.version_info.minor}"
        problems.append(
            f"Python's headers are missing ({header} does not exist): install them, e.g. "
            f"`sudo apt install python{version}-dev` (Debian, Ubuntu) or "
            f"`sudo dnf install python{version}-devel` (Fedora)"
        )
    for tool in ("cmake", "ninja"):
        if not (Path(sys.executable).parent / tool).exists():
            problems.append(
                f"{tool} is not in the venv: it comes with requirements.txt; run "
                "`make .venv/.installed`"
            )
    return problems


def environ(base: Mapping[str, str] | None = None) -> dict[str, str]:
    """``base`` (default: this process's environment) as ``colcon build`` needs it here.

    Raises ``BuildSetupError`` naming what is missing (a compiler, Python's headers).
    """
    env = dict(os.environ if base is None else base)
    problems = missing(env)
    if problems:
        raise BuildSetupError(problems[0])
    prefixes = [p for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    if str(BASE_PREFIX) not in prefixes:
        prefixes.append(str(BASE_PREFIX))
    env["AMENT_PREFIX_PATH"] = os.pathsep.join(prefixes)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["CMAKE_GENERATOR"] = "Ninja"
    env["CMAKE_TOOLCHAIN_FILE"] = str(TOOLCHAIN)
    env["ROSBOOK_PYTHON_INCLUDE"] = str(python_include())
    env["ROSBOOK_NUMPY_INCLUDE"] = str(numpy_include())
    return env


def check_interfaces(package: str | os.PathLike[str]) -> list[Path]:
    """Parse every ``msg/*.msg``, ``srv/*.srv`` and ``action/*.action`` of a package with
    rosidl's own parser; the files, or ``InterfaceError`` for the first that does not parse.
    """
    from rosidl_adapter import parser

    readers = {
        "msg": parser.parse_message_string,
        "srv": parser.parse_service_string,
        "action": parser.parse_action_string,
    }
    root = Path(package)
    files = []
    for folder, suffix in INTERFACE_KINDS.items():
        for path in sorted((root / folder).glob(f"*{suffix}")):
            files.append(path)
            shown = f"{root.name}/{folder}/{path.name}"
            if not re.fullmatch(r"[A-Z][A-Za-z0-9]*", path.stem):
                raise InterfaceError(
                    f"{shown}: the type name '{path.stem}' is not valid: it must start with "
                    "an upper-case letter and hold only letters and digits (CamelCase)"
                )
            text = path.read_text()
            said = io.StringIO()
            try:
                with contextlib.redirect_stderr(said):
                    readers[folder](root.name, path.stem, text)
            except Exception as error:  # rosidl raises several kinds, all a bad file
                raise InterfaceError(f"{shown}{_where(text, said.getvalue())}: {error}") from None
    return files


def _where(text: str, said: str) -> str:
    """``:N`` for the line rosidl names in what it printed ("Error processing 'LINE' of")."""
    found = re.search(r"Error processing '(.*)' of '", said)
    if found:
        for number, line in enumerate(text.splitlines(), 1):
            if line.strip() == found.group(1).strip():
                return f":{number}"
    return ""


def failure(run: ColconRun) -> str:
    """One line for a failed ``colcon build``: the first error CMake or the compiler gave."""
    lines = run.output.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("CMake Error") or ": error:" in line:
            block = [line.strip()]
            for more in lines[i + 1 :]:
                if not more.strip() and len(block) > 1:
                    break
                if more.strip():
                    block.append(more.strip())
            return " ".join(block)
    return f"colcon build failed (exit code {run.returncode})"


def build(workspace: Workspace, *args: str, env: Mapping[str, str] | None = None) -> ColconRun:
    """Check every package's interface files, then ``colcon build ARGS`` in ``environ``.

    A file that does not parse raises ``InterfaceError`` before colcon starts; a machine
    that cannot build raises ``BuildSetupError``.
    """
    build_env = environ(env)
    for manifest in sorted(workspace.src.rglob("package.xml")):
        check_interfaces(manifest.parent)
    return workspace.colcon("build", *args, env=build_env)


def sources_hash(root: Path = COURSE_PACKAGES) -> str:
    """SHA-256 of the course packages' files (paths and contents)."""
    digest = hashlib.sha256()
    for path in sorted(p for p in root.rglob("*") if p.is_file()):
        digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def install_course_packages(prefix: Path = BASE_PREFIX, *, force: bool = False) -> str:
    """Build ``rosbook/ros_packages`` into ``prefix`` (the venv: where the wheels put
    their packages); nothing when the same sources are installed there. What happened."""
    stamp = prefix / INSTALLED_STAMP
    wanted = sources_hash()
    if not force and stamp.is_file() and stamp.read_text() == wanted:
        return f"the course's interface packages are up to date in {prefix}"
    with tempfile.TemporaryDirectory(prefix="rosbook_packages_") as scratch:
        workspace = Workspace(scratch)
        for package in sorted(p for p in COURSE_PACKAGES.iterdir() if p.is_dir()):
            shutil.copytree(package, workspace.src / package.name)
        run = build(workspace, "--merge-install", "--install-base", str(prefix))
    if not run.ok:
        raise BuildSetupError(f"building the course's interface packages failed: {failure(run)}")
    stamp.parent.mkdir(parents=True, exist_ok=True)
    stamp.write_text(wanted)
    return f"built the course's interface packages into {prefix} in {run.seconds:.0f} s"


def main(argv: list[str] | None = None) -> int:
    """``install``: the course's packages into the venv; ``env``: ``export`` lines."""
    parser = argparse.ArgumentParser(prog="python -m rosbook.launch.interfaces_build")
    parser.add_argument("command", choices=["install", "env"])
    args = parser.parse_args(argv)
    try:
        if args.command == "install":
            print(install_course_packages())
        else:
            env = environ()
            for name in (
                "AMENT_PREFIX_PATH",
                "CMAKE_GENERATOR",
                "CMAKE_TOOLCHAIN_FILE",
                "ROSBOOK_PYTHON_INCLUDE",
                "ROSBOOK_NUMPY_INCLUDE",
            ):
                print(f"export {name}={shlex.quote(env[name])}")
    except (BuildSetupError, InterfaceError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
