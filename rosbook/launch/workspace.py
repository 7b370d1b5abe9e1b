"""Colcon workspaces and ``ament_python`` packages, for real: scaffold, build, source, find.

A ROS 2 workspace is a folder with ``src/`` (packages) that ``colcon build`` turns into
``build/``, ``install/`` and ``log/``. This module runs the real ``colcon`` (installed
from PyPI into the project's venv) and sources the real ``install/setup.bash`` in bash,
so the book and the labs show what a ROS 2 install does. Two things differ:

* there is no ``/opt/ros/jazzy``: the project's venv plays that part. It holds an ament
  index (``share/ament_index``) of the ROS packages installed as wheels, and the tools
  here always search it last, as if ``/opt/ros/jazzy/setup.bash`` had been sourced first;
* ``ros2 pkg create`` is provided here (``create_package``) and writes the same files as
  the real command for ``--build-type ament_python``.

Executables are found as ``ros2 run`` finds them: a package is a prefix on
``AMENT_PREFIX_PATH`` holding ``share/ament_index/resource_index/packages/<pkg>``, and
its executables are the files in ``<prefix>/lib/<pkg>/``.
"""

from __future__ import annotations

import getpass
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from rosbook.launch.licenses import LICENSES

#: The underlay every workspace here builds on: the venv's own ament index.
BASE_PREFIX = Path(sys.prefix)

PACKAGE_INDEX = Path("share") / "ament_index" / "resource_index" / "packages"


class PackageNotFoundError(LookupError):
    """No prefix on ``AMENT_PREFIX_PATH`` (or the venv) holds the package."""


class ExecutableNotFoundError(LookupError):
    """The package exists but has no executable of that name in ``lib/<pkg>/``."""


# -- finding packages and executables (what `ros2 pkg` and `ros2 run` do) -------------


def ament_prefixes(env: Mapping[str, str] | None = None) -> list[Path]:
    """Install prefixes to search, first match wins: ``AMENT_PREFIX_PATH``, then the venv."""
    env = os.environ if env is None else env
    prefixes = [Path(p) for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    if (BASE_PREFIX / PACKAGE_INDEX).is_dir() and BASE_PREFIX not in prefixes:
        prefixes.append(BASE_PREFIX)
    return prefixes


def not_in_index(package: str, env: Mapping[str, str] | None = None) -> str:
    """What ament_index_python says of a package it cannot find (its exact words)."""
    searched = [str(prefix) for prefix in ament_prefixes(env)]
    return f"package '{package}' not found, searching: {searched}"


def packages(env: Mapping[str, str] | None = None) -> dict[str, Path]:
    """Every package in the ament index, by name, with the prefix that provides it."""
    found: dict[str, Path] = {}
    for prefix in ament_prefixes(env):
        index = prefix / PACKAGE_INDEX
        if index.is_dir():
            for marker in sorted(index.iterdir()):
                found.setdefault(marker.name, prefix)
    return found


def package_prefix(package: str, env: Mapping[str, str] | None = None) -> Path:
    """The install prefix of ``package`` (the first on the search path that has it)."""
    for prefix in ament_prefixes(env):
        if (prefix / PACKAGE_INDEX / package).is_file():
            return prefix
    searched = ", ".join(str(p) for p in ament_prefixes(env)) or "nothing"
    raise PackageNotFoundError(
        f"Package '{package}' not found (searched {searched}). Was it built with colcon, "
        "and was the workspace's install/setup.bash sourced (AMENT_PREFIX_PATH)? A package "
        "whose package.xml does not parse is built as a plain Python package and is not "
        "in the ament index."
    )


def executables(package: str, env: Mapping[str, str] | None = None) -> list[str]:
    """Names of the executables of ``package`` (files in ``<prefix>/lib/<package>``)."""
    folder = package_prefix(package, env) / "lib" / package
    if not folder.is_dir():
        return []
    return sorted(p.name for p in folder.iterdir() if p.is_file() and os.access(p, os.X_OK))


def executable_path(package: str, executable: str, env: Mapping[str, str] | None = None) -> Path:
    """The file ``ros2 run package executable`` would start."""
    prefix = package_prefix(package, env)
    path = prefix / "lib" / package / executable
    if path.is_file() and os.access(path, os.X_OK):
        return path
    have = executables(package, env)
    raise ExecutableNotFoundError(
        f"No executable '{executable}' found in package '{package}' "
        f"({prefix / 'lib' / package}); it has: {', '.join(have) or 'none'}. "
        "An executable of an ament_python package is an entry point in setup.py: "
        f"entry_points={{'console_scripts': ['{executable} = {package}.<module>:main']}}, "
        "and setup.cfg must install scripts into $base/lib/<package>; rebuild after "
        "changing either."
    )


# -- `ros2 pkg create --build-type ament_python` ---------------------------------------


def _maintainer_defaults() -> tuple[str, str]:
    """Name and e-mail as the real command picks them: git config, else the login name."""

    def git(key: str) -> str:
        if shutil.which("git") is None:
            return ""
        done = subprocess.run(
            ["git", "config", "--global", key], capture_output=True, text=True, check=False
        )
        return done.stdout.strip()

    name = git("user.name") or getpass.getuser()
    return name, git("user.email") or f"{name}@todo.todo"


def _package_xml(
    name: str,
    version: str,
    description: str,
    maintainer: str,
    email: str,
    license: str,
    dependencies: Sequence[str],
    build_type: str = "ament_python",
) -> str:
    """``package.xml`` as upstream's template writes it for ``build_type``."""
    buildtool = BUILDTOOL_DEPENDS.get(build_type, [])
    tools = "".join(f"  <buildtool_depend>{dep}</buildtool_depend>\n" for dep in buildtool)
    depends = "".join(f"  <depend>{dep}</depend>\n" for dep in dependencies)
    tests = "".join(f"  <test_depend>{dep}</test_depend>\n" for dep in TEST_DEPENDS[build_type])
    return (
        '<?xml version="1.0"?>\n'
        '<?xml-model href="http://download.ros.org/schema/package_format3.xsd" '
        'schematypens="http://www.w3.org/2001/XMLSchema"?>\n'
        '<package format="3">\n'
        f"  <name>{name}</name>\n"
        f"  <version>{version}</version>\n"
        f"  <description>{description}</description>\n"
        f'  <maintainer email="{email}">{maintainer}</maintainer>\n'
        f"  <license>{license}</license>\n"
        "\n"
        f"{tools}{chr(10) if tools else ''}"
        f"{depends}{chr(10) if depends else ''}"
        f"{tests}\n"
        "  <export>\n"
        f"    <build_type>{build_type}</build_type>\n"
        "  </export>\n"
        "</package>\n"
    )


def _cmakelists(name: str, dependencies: Sequence[str]) -> str:
    """``CMakeLists.txt`` as upstream's ``ament_cmake`` template writes it (no C++ node)."""
    finds = (
        "".join(f"find_package({dep} REQUIRED)\n" for dep in dependencies)
        if dependencies
        else "# uncomment the following section in order to fill in\n"
        "# further dependencies manually.\n# find_package(<dependency> REQUIRED)\n"
    )
    return (
        "cmake_minimum_required(VERSION 3.8)\n"
        f"project({name})\n"
        "\n"
        'if(CMAKE_COMPILER_IS_GNUCXX OR CMAKE_CXX_COMPILER_ID MATCHES "Clang")\n'
        "  add_compile_options(-Wall -Wextra -Wpedantic)\n"
        "endif()\n"
        "\n"
        "# find dependencies\n"
        "find_package(ament_cmake REQUIRED)\n"
        f"{finds}"
        "\n"
        "if(BUILD_TESTING)\n"
        "  find_package(ament_lint_auto REQUIRED)\n"
        "  # the following line skips the linter which checks for copyrights\n"
        "  # comment the line when a copyright and license is added to all source files\n"
        "  set(ament_cmake_copyright_FOUND TRUE)\n"
        "  # the following line skips cpplint (only works in a git repo)\n"
        "  # comment the line when this package is in a git repo and when\n"
        "  # a copyright and license is added to all source files\n"
        "  set(ament_cmake_cpplint_FOUND TRUE)\n"
        "  ament_lint_auto_find_test_dependencies()\n"
        "endif()\n"
        "\n"
        "ament_package()\n"
    )


def _setup_py(
    name: str,
    version: str,
    description: str,
    maintainer: str,
    email: str,
    license: str,
    node_name: str | None,
) -> str:
    scripts = f"\n            '{node_name} = {name}.{node_name}:main'," if node_name else ""
    return (
        "from setuptools import find_packages, setup\n"
        "\n"
        f"package_name = '{name}'\n"
        "\n"
        "setup(\n"
        "    name=package_name,\n"
        f"    version='{version}',\n"
        "    packages=find_packages(exclude=['test']),\n"
        "    data_files=[\n"
        "        ('share/ament_index/resource_index/packages',\n"
        "            ['resource/' + package_name]),\n"
        "        ('share/' + package_name, ['package.xml']),\n"
        "    ],\n"
        "    install_requires=['setuptools'],\n"
        "    zip_safe=True,\n"
        f"    maintainer='{maintainer}',\n"
        f"    maintainer_email='{email}',\n"
        f"    description='{description}',\n"
        f"    license='{license}',\n"
        "    tests_require=['pytest'],\n"
        "    entry_points={\n"
        f"        'console_scripts': [{scripts}\n"
        "        ],\n"
        "    },\n"
        ")\n"
    )


def _setup_cfg(name: str) -> str:
    return f"[develop]\nscript_dir=$base/lib/{name}\n[install]\ninstall_scripts=$base/lib/{name}\n"


_TEST_FILES = {
    "test_copyright.py": (
        "from ament_copyright.main import main\nimport pytest\n\n\n"
        "# Remove the `skip` decorator once the source file(s) have a copyright header\n"
        "@pytest.mark.skip(reason='No copyright header has been placed in the generated "
        "source file.')\n@pytest.mark.copyright\n@pytest.mark.linter\n"
        "def test_copyright():\n    rc = main(argv=['.', 'test'])\n"
        "    assert rc == 0, 'Found errors'\n"
    ),
    "test_flake8.py": (
        "from ament_flake8.main import main_with_errors\nimport pytest\n\n\n"
        "@pytest.mark.flake8\n@pytest.mark.linter\ndef test_flake8():\n"
        "    rc, errors = main_with_errors(argv=[])\n"
        "    assert rc == 0, \\\n"
        "        'Found %d code style errors / warnings:\\n' % len(errors) + \\\n"
        "        '\\n'.join(errors)\n"
    ),
    "test_pep257.py": (
        "from ament_pep257.main import main\nimport pytest\n\n\n"
        "@pytest.mark.linter\n@pytest.mark.pep257\ndef test_pep257():\n"
        "    rc = main(argv=['.', 'test'])\n"
        "    assert rc == 0, 'Found code style errors / warnings'\n"
    ),
}

_NAME_RE = re.compile(r"^[a-z][a-z0-9_]*$")

#: The build types ``create_package`` writes, with upstream's test dependencies for each.
TEST_DEPENDS = {
    "ament_python": ["ament_copyright", "ament_flake8", "ament_pep257", "python3-pytest"],
    "ament_cmake": ["ament_lint_auto", "ament_lint_common"],
}
BUILDTOOL_DEPENDS = {"ament_cmake": ["ament_cmake"]}


def create_package(
    name: str,
    destination: str | os.PathLike[str] = ".",
    *,
    build_type: str = "ament_python",
    dependencies: Iterable[str] = (),
    node_name: str | None = None,
    version: str = "0.0.0",
    description: str = "TODO: Package description",
    license: str = "TODO: License declaration",
    maintainer_name: str | None = None,
    maintainer_email: str | None = None,
    log: Callable[[str], None] | None = print,
) -> Path:
    """Scaffold ``destination/name`` as ``ros2 pkg create --build-type BUILD_TYPE`` does.

    Writes ``package.xml`` (format 3) and, for ``ament_python``, ``setup.py``,
    ``setup.cfg``, the package marker ``resource/<name>``, the module folder with
    ``__init__.py`` (and ``<node_name>.py`` with a ``main()`` registered as an entry point,
    when ``node_name`` is given) and the linter tests in ``test/``; for ``ament_cmake``,
    ``CMakeLists.txt`` and the empty ``src/`` and ``include/<name>/``. ``log`` receives the
    lines the real command prints.
    """
    if build_type not in TEST_DEPENDS:
        raise ValueError(
            f"build type {build_type!r} is not available here: this book builds "
            f"{' and '.join(TEST_DEPENDS)} packages"
        )
    if build_type == "ament_cmake" and node_name:
        raise ValueError(
            "--node-name with --build-type ament_cmake writes a C++ node: this book's nodes "
            "are Python, in ament_python packages (an ament_cmake package here holds interfaces)"
        )
    if not _NAME_RE.match(name):
        raise ValueError(
            f"package name {name!r} is not valid: lower case letters, digits and "
            "underscores, starting with a letter (REP 144)"
        )
    say = log or (lambda _line: None)
    default_name, default_email = _maintainer_defaults()
    maintainer = maintainer_name or default_name
    email = maintainer_email or default_email
    deps = list(dependencies)
    root = Path(destination) / name
    shown = os.path.join(destination, name)  # upstream prints the paths as joined
    if root.exists():
        raise FileExistsError(
            f"\nAborted!\nThe directory already exists: {shown}\nEither remove the "
            "directory or choose a different destination directory or package name"
        )

    say("going to create a new package")
    for label, value in [
        ("package name", name),
        ("destination directory", str(Path(destination).resolve())),
        ("package format", "3"),
        ("version", version),
        ("description", description),
        ("maintainer", [f"{maintainer} <{email}>"]),
        ("licenses", [license]),
        ("build type", build_type),
        ("dependencies", deps),
    ]:
        say(f"{label}: {value}")
    if node_name:
        say(f"node_name: {node_name}")

    def folder(relative: str) -> None:
        (root / relative).mkdir(parents=True, exist_ok=True)
        say(f"creating folder {os.path.join(shown, relative)}".rstrip("/"))

    def write(relative: str, text: str) -> None:
        (root / relative).write_text(text)
        say(f"creating {os.path.join(shown, relative)}")

    # in upstream's order (ros2pkg.api.create), each line as upstream prints it
    folder("")
    write(
        "package.xml",
        _package_xml(name, version, description, maintainer, email, license, deps, build_type),
    )
    if build_type == "ament_cmake":
        say("creating source and include folder")
        folder("src")
        folder(f"include/{name}")
        write("CMakeLists.txt", _cmakelists(name, deps))
    else:
        say("creating source folder")
        folder(name)
        write(
            "setup.py", _setup_py(name, version, description, maintainer, email, license, node_name)
        )
        write("setup.cfg", _setup_cfg(name))
        folder("resource")
        write(f"resource/{name}", "")
        write(f"{name}/__init__.py", "")
        folder("test")
        for filename, text in _TEST_FILES.items():
            write(f"test/{filename}", text)
    if node_name:
        write(
            f"{name}/{node_name}.py",
            f"def main():\n    print('Hi from {name}.')\n\n\nif __name__ == '__main__':\n"
            "    main()\n",
        )
    if license in LICENSES:
        (root / "LICENSE").write_text(LICENSES[license])
    else:
        say(
            f"\n[WARNING]: Unknown license '{license}'.  This has been set in the package.xml, "
            "but no LICENSE file has been created.\nIt is recommended to use one of the ament "
            "license identifiers:\n" + "\n".join(LICENSES)
        )
    return root


# -- colcon and sourcing ---------------------------------------------------------------


def colcon_executable() -> str:
    """The venv's ``colcon`` (next to this interpreter), else the one on PATH."""
    beside = Path(sys.executable).parent / "colcon"
    if beside.exists():
        return str(beside)
    found = shutil.which("colcon")
    if found is None:
        raise FileNotFoundError(
            "colcon is not installed: it comes with requirements.txt "
            "(colcon-common-extensions); run `make .venv/.installed`"
        )
    return found


@dataclass
class ColconRun:
    """One run of ``colcon``: the command, what it printed (stdout and stderr) and its code."""

    args: list[str]
    output: str
    returncode: int
    seconds: float

    @property
    def ok(self) -> bool:
        return self.returncode == 0

    def __str__(self) -> str:
        return self.output


def sourced_environ(
    *install_dirs: str | os.PathLike[str],
    base: Mapping[str, str] | None = None,
    script: str = "setup.bash",
) -> dict[str, str]:
    """The environment after ``source <dir>/setup.bash`` for each dir, in order, in bash.

    This is the real thing: bash runs colcon's generated scripts and the resulting
    environment is read back.
    """
    env = dict(os.environ if base is None else base)
    commands = [f'source "{Path(d).resolve() / script}"' for d in install_dirs]
    done = subprocess.run(
        ["bash", "-c", " && ".join([*commands, "env -0"])],
        env=env,
        capture_output=True,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(
            f"sourcing {', '.join(map(str, install_dirs))} failed: "
            f"{done.stderr.decode(errors='replace').strip()}"
        )
    pairs = (item.split(b"=", 1) for item in done.stdout.split(b"\0") if b"=" in item)
    return {k.decode(): v.decode(errors="replace") for k, v in pairs}


class Workspace:
    """A colcon workspace: ``src/`` with packages, built into ``build/ install/ log/``."""

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root).resolve()
        self.src.mkdir(parents=True, exist_ok=True)

    @classmethod
    def scratch(cls, prefix: str = "ros2_ws_") -> Workspace:
        """A new, empty workspace in a temporary folder."""
        return cls(tempfile.mkdtemp(prefix=prefix))

    @property
    def src(self) -> Path:
        return self.root / "src"

    @property
    def install(self) -> Path:
        return self.root / "install"

    def create_package(self, name: str, **options: object) -> Path:
        """``ros2 pkg create`` inside ``src/`` (see ``create_package``)."""
        return create_package(name, self.src, **options)  # type: ignore[arg-type]

    def colcon(
        self, *args: str, env: Mapping[str, str] | None = None, timeout: float = 300
    ) -> ColconRun:
        """Run ``colcon ARGS`` from the workspace root; output as colcon printed it."""
        argv = [colcon_executable(), *args]
        run_env = dict(os.environ if env is None else env)
        run_env.pop("COLCON_LOG_PATH", None)
        start = time.monotonic()
        done = subprocess.run(
            argv,
            cwd=self.root,
            env=run_env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            timeout=timeout,
            check=False,
        )
        return ColconRun(["colcon", *args], done.stdout, done.returncode, time.monotonic() - start)

    def build(
        self, *args: str, symlink_install: bool = True, env: Mapping[str, str] | None = None
    ) -> ColconRun:
        """``colcon build [--symlink-install] ARGS``."""
        flags = ["--symlink-install"] if symlink_install else []
        return self.colcon("build", *flags, *args, env=env)

    def environ(self, base: Mapping[str, str] | None = None) -> dict[str, str]:
        """The environment after ``source install/setup.bash`` on top of ``base``."""
        if not (self.install / "setup.bash").exists():
            raise FileNotFoundError(f"{self.install}/setup.bash does not exist: build first")
        return sourced_environ(self.install, base=base)

    @contextmanager
    def sourced(self) -> Iterator[dict[str, str]]:
        """This process's ``os.environ`` as after sourcing the workspace, restored after."""
        saved = dict(os.environ)
        env = self.environ()
        os.environ.clear()
        os.environ.update(env)
        try:
            yield env
        finally:
            os.environ.clear()
            os.environ.update(saved)

    def remove(self) -> None:
        """Delete the workspace folder."""
        shutil.rmtree(self.root, ignore_errors=True)


def tree(root: str | os.PathLike[str], skip: Iterable[str] = ("__pycache__",)) -> str:
    """A ``tree``-style listing of ``root`` (folders first, then files, sorted)."""
    root = Path(root)
    skipped = set(skip)
    lines = [f"{root.name}/"]

    def walk(folder: Path, indent: str) -> None:
        entries = sorted(
            (p for p in folder.iterdir() if p.name not in skipped),
            key=lambda p: (not p.is_dir() or p.is_symlink(), p.name),
        )
        for i, entry in enumerate(entries):
            last = i == len(entries) - 1
            branch = "└── " if last else "├── "
            if entry.is_dir() and not entry.is_symlink():
                lines.append(f"{indent}{branch}{entry.name}/")
                walk(entry, indent + ("    " if last else "│   "))
            else:
                lines.append(f"{indent}{branch}{entry.name}")

    walk(root, "")
    return "\n".join(lines)


def sh(
    command: str,
    cwd: str | os.PathLike[str],
    *,
    env: Mapping[str, str] | None = None,
    timeout: float = 120,
    echo: bool = True,
    ctrl_c_after: str | Sequence[str] | None = None,
    times: int = 1,
) -> subprocess.CompletedProcess[str]:
    """Run ``command`` in bash, as typed in a terminal, and print ``$ command`` and its output.

    The venv's ``bin/`` (``colcon``, ``ros2``) comes first on ``PATH``, as it would in a
    terminal where the venv is active; stdout and stderr are merged as a terminal shows them.
    With ``ctrl_c_after`` (a regular expression, or several), Ctrl-C is pressed (SIGINT to
    the command's process group, as a terminal sends it) once ``times`` output lines have
    matched each: a program that runs until Ctrl-C is stopped after what it should show,
    however slow the machine. A ``ros2 launch`` whose Ctrl-C had to escalate to SIGTERM
    is run once more: nodes stopped together sometimes hang in Fast DDS's teardown
    (eProsima/Fast-DDS#6513; ``book/computation_graph.md``), and the book shows a
    usual run. ``timeout`` only guards against a hang: past it the command is killed and
    ``subprocess.TimeoutExpired`` says what was seen.
    """
    from rosbook.launch.launcher import ESCALATED  # the launcher imports this module

    done = _run_in_terminal(command, cwd, env, timeout, ctrl_c_after, times)
    if ctrl_c_after is not None and ESCALATED in done.stdout:
        done = _run_in_terminal(command, cwd, env, timeout, ctrl_c_after, times)
    if echo:  # without a terminal's colours: a page shows them as low-contrast text
        print(f"$ {command}")
        print(ANSI_ESCAPES.sub("", done.stdout), end="")
    return done


#: A terminal's colour and cursor codes (CMake colours its warnings in a terminal).
ANSI_ESCAPES = re.compile(r"\x1b\[[0-9;?]*[ -/]*[@-~]")


def _run_in_terminal(
    command: str,
    cwd: str | os.PathLike[str],
    env: Mapping[str, str] | None,
    timeout: float,
    ctrl_c_after: str | Sequence[str] | None,
    times: int,
) -> subprocess.CompletedProcess[str]:
    """One run of ``sh``'s command (as ``sh`` says), not printed."""
    run_env = dict(os.environ if env is None else env)
    run_env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{run_env.get('PATH', '')}"
    run_env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "1")  # log lines as written
    process = subprocess.Popen(
        ["bash", "-c", command],
        cwd=cwd,
        env=run_env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    patterns = [ctrl_c_after] if isinstance(ctrl_c_after, str) else list(ctrl_c_after or [])
    matched = [0] * len(patterns)
    lines: list[str] = []
    pressed = not patterns
    hung: list[bool] = []
    timer = threading.Timer(timeout, lambda: (hung.append(True), _kill_group(process)))
    timer.start()
    try:
        assert process.stdout is not None
        for line in process.stdout:
            lines.append(line)
            if pressed:
                continue
            for i, pattern in enumerate(patterns):
                matched[i] += bool(re.search(pattern, line))
            if min(matched) >= times:
                os.killpg(process.pid, signal.SIGINT)
                pressed = True
        process.wait()
    finally:
        timer.cancel()
        _kill_group(process)
    output = "".join(lines)
    if hung:
        waited = ", ".join(
            f"{n} of {times} lines matching {p!r}" for p, n in zip(patterns, matched)
        )
        waited = waited or "its end"
        raise subprocess.TimeoutExpired(command, timeout, output=f"timeout: {waited}\n{output}")
    return subprocess.CompletedProcess(["bash", "-c", command], process.returncode, output)


def _kill_group(process: subprocess.Popen[str]) -> None:
    """Kill what is left of a command's process group (nothing, once it ended)."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
