"""A small launcher for descriptions shaped like a ROS 2 launch file.

There is no ``launch`` / ``launch_ros`` wheel, so this module provides the part of them a
first launch file uses, under the same names and fields::

    from rosbook.launch.launcher import LaunchDescription, Node

    def generate_launch_description():
        return LaunchDescription([
            Node(package='robot_talk', executable='talker', name='talker',
                 namespace='robot1', parameters=[{'rate': 2.0}],
                 remappings=[('chatter', 'news')], output='screen'),
        ])

``launch(description)`` starts every node as a process of its own with the
``--ros-args`` the real ``launch_ros`` passes (``-r __node:=``, ``-r __ns:=``,
``-p name:=value``, ``-r from:=to``), merges their output with each line prefixed by the
process name (``[talker-1] ...``), and stops them all with one Ctrl-C: SIGINT to each,
then SIGTERM, then SIGKILL after ``sigterm_timeout`` / ``sigkill_timeout`` seconds
(a second Ctrl-C meanwhile is ignored, as in launch; ``timeout -s INT`` sends two at
once). A node with ``on_exit=Shutdown()`` stops the whole
system when it exits, as in launch.

Not provided: substitutions and launch arguments, event handlers other than
``on_exit=Shutdown()``, included launch files, groups, composable nodes, respawn,
XML/YAML launch files and log files under ``~/.ros/log``.
"""

from __future__ import annotations

import atexit
import ctypes
import json
import os
import queue
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from rosbook.launch.workspace import executable_path
from rosbook.runtime.graph import absolute_name

#: prctl(2) option: the signal a process gets when its parent dies (Linux).
_PR_SET_PDEATHSIG = 1


def _die_with_launcher() -> None:
    """In a launched child, before exec: SIGTERM when the launcher dies, however it dies.

    Each node runs in a session of its own (our Ctrl-C reaches it once, from us), so a
    launcher killed with SIGKILL would otherwise leave its nodes running.
    """
    ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


@dataclass(frozen=True)
class Shutdown:
    """Action: shut the whole launch down (used as ``Node(on_exit=Shutdown())``)."""

    reason: str = "shutdown"


@dataclass(frozen=True)
class SetParameter:
    """Action: set a parameter on every node that comes after it in the description."""

    name: str
    value: Any


@dataclass(kw_only=True)
class Node:
    """A ROS node to run as its own process (``launch_ros.actions.Node``'s fields)."""

    package: str
    executable: str
    name: str | None = None
    namespace: str | None = None
    parameters: Sequence[Mapping[str, Any] | str | os.PathLike[str]] = ()
    remappings: Sequence[tuple[str, str]] = ()
    arguments: Sequence[str] = ()
    ros_arguments: Sequence[str] = ()
    exec_name: str | None = None
    output: str = "log"
    on_exit: Shutdown | None = None
    additional_env: Mapping[str, str] | None = None
    sigterm_timeout: float = 5.0
    sigkill_timeout: float = 5.0

    def command(
        self, executable: str | os.PathLike[str], global_parameters: Mapping[str, Any] = {}
    ) -> list[str]:
        """The command line launch_ros builds for this node."""
        ros_args: list[str] = []
        if self.name:
            ros_args += ["-r", f"__node:={self.name}"]
        if self.namespace:
            ros_args += ["-r", f"__ns:={absolute_name(self.namespace)}"]
        for name, value in global_parameters.items():
            ros_args += ["-p", f"{name}:={yaml_value(value)}"]
        for entry in self.parameters:
            if isinstance(entry, Mapping):
                for name, value in _flatten(entry).items():
                    ros_args += ["-p", f"{name}:={yaml_value(value)}"]
            else:
                ros_args += ["--params-file", str(entry)]
        for source, target in self.remappings:
            ros_args += ["-r", f"{source}:={target}"]
        ros_args += list(self.ros_arguments)
        argv = [str(executable), *self.arguments]
        return [*argv, "--ros-args", *ros_args] if ros_args else argv


@dataclass
class LaunchDescription:
    """What ``generate_launch_description()`` returns: actions, in order."""

    entities: list[Node | SetParameter] = field(default_factory=list)

    def add_action(self, action: Node | SetParameter) -> None:
        self.entities.append(action)


class LaunchError(RuntimeError):
    """The description cannot be launched (unknown package or executable, bad entity)."""


def yaml_value(value: Any) -> str:
    """A parameter value as YAML text for ``-p name:=value`` (rcl parses it as YAML)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(yaml_value(v) for v in value) + "]"
    raise LaunchError(f"parameter value {value!r} ({type(value).__name__}) is not supported")


def _flatten(params: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for key, value in params.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            flat.update(_flatten(value, name + "."))
        else:
            flat[name] = value
    return flat


@dataclass
class Process:
    """One launched node process."""

    node: Node
    name: str
    cmd: list[str]
    popen: subprocess.Popen[bytes]
    lines: list[str] = field(default_factory=list)
    reported: bool = False

    @property
    def pid(self) -> int:
        return self.popen.pid

    @property
    def returncode(self) -> int | None:
        return self.popen.poll()

    def alive(self) -> bool:
        return self.popen.poll() is None


#: Launches not shut down yet: stopped when the interpreter exits.
_running: set[Launch] = set()


@atexit.register
def _stop_all_at_exit() -> None:
    for system in list(_running):
        system.shutdown(sigterm_timeout=1.0, sigkill_timeout=1.0)


class Launch:
    """A running launch: its processes and their merged, prefixed output.

    Output is read by background threads into a queue; ``pump`` (and ``wait``,
    ``shutdown``) take the lines from it in the caller's thread, record them in
    ``output`` and pass them to ``echo``, so a notebook cell shows them where it runs.
    """

    def __init__(
        self,
        description: LaunchDescription,
        *,
        env: Mapping[str, str] | None = None,
        echo: Callable[[str], None] | None = print,
    ) -> None:
        self.description = description
        self.env = dict(os.environ if env is None else env)
        self.echo = echo
        self.output: list[str] = []
        self.processes: list[Process] = []
        self.shutting_down: str | None = None
        self._queue: queue.Queue[tuple[Process | None, str]] = queue.Queue()
        self._readers: list[threading.Thread] = []
        self._plan = self._resolve()

    # -- starting ----------------------------------------------------------------
    def _resolve(self) -> list[tuple[Node, list[str]]]:
        """Every node's command line, checked before anything starts."""
        plan: list[tuple[Node, list[str]]] = []
        global_parameters: dict[str, Any] = {}
        entities = getattr(self.description, "entities", None)
        if entities is None:
            raise LaunchError(
                f"expected a LaunchDescription, got {type(self.description).__name__}: "
                "generate_launch_description() must return LaunchDescription([...])"
            )
        for entity in entities:
            if isinstance(entity, SetParameter):
                global_parameters[entity.name] = entity.value
            elif isinstance(entity, Node):
                try:
                    path = executable_path(entity.package, entity.executable, self.env)
                except LookupError as error:
                    raise LaunchError(str(error)) from None
                plan.append((entity, entity.command(path, global_parameters)))
            else:
                raise LaunchError(
                    f"cannot launch {entity!r}: this launcher knows Node and SetParameter"
                )
        return plan

    def start(self) -> Launch:
        """Start every node, in order."""
        for node, cmd in self._plan:
            label = node.exec_name or Path(cmd[0]).name
            name = f"{label}-{len(self.processes) + 1}"
            env = dict(self.env)
            env.setdefault("PYTHONUNBUFFERED", "1")  # as launch does
            env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "1")  # log lines, not blocks
            env.update(node.additional_env or {})
            popen = subprocess.Popen(
                cmd,
                env=env,
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                start_new_session=True,  # our Ctrl-C is forwarded once, by us
                preexec_fn=_die_with_launcher,
            )
            process = Process(node, name, cmd, popen)
            self.processes.append(process)
            self._say(f"[INFO] [{name}]: process started with pid [{popen.pid}]")
            for stream, to_screen in (
                (popen.stdout, node.output in ("screen", "both")),
                (popen.stderr, True),
            ):
                reader = threading.Thread(
                    target=self._read, args=(process, stream, to_screen), daemon=True
                )
                reader.start()
                self._readers.append(reader)
        _running.add(self)
        return self

    def _read(self, process: Process, stream: IO[bytes] | None, to_screen: bool) -> None:
        assert stream is not None
        for raw in iter(stream.readline, b""):
            line = raw.decode(errors="replace").rstrip("\n")
            process.lines.append(line)
            if to_screen:
                self._queue.put((process, line))
        stream.close()

    def _say(self, line: str) -> None:
        self._queue.put((None, line))

    # -- running -----------------------------------------------------------------
    def pump(self, timeout: float = 0.0) -> list[str]:
        """Handle output and exits for up to ``timeout`` seconds; return the new lines."""
        new: list[str] = []
        deadline = time.monotonic() + timeout
        while True:
            self._check_exits()
            remaining = deadline - time.monotonic()
            try:
                if remaining > 0:
                    process, line = self._queue.get(timeout=min(0.05, remaining))
                else:
                    process, line = self._queue.get_nowait()
            except queue.Empty:
                if remaining <= 0:
                    break
                continue
            text = f"[{process.name}] {line}" if process is not None else line
            self.output.append(text)
            new.append(text)
            if self.echo is not None:
                self.echo(text)
        return new

    def _check_exits(self) -> None:
        for process in self.processes:
            code = process.returncode
            if code is None or process.reported:
                continue
            process.reported = True
            if code == 0:
                self._say(
                    f"[INFO] [{process.name}]: process has finished cleanly [pid {process.pid}]"
                )
            else:
                self._say(
                    f"[ERROR] [{process.name}]: process has died [pid {process.pid}, exit code "
                    f"{code}, cmd '{' '.join(process.cmd)}']."
                )
            if isinstance(process.node.on_exit, Shutdown) and self.shutting_down is None:
                self._begin_shutdown(
                    f"{process.name} exited and its on_exit is Shutdown "
                    f"({process.node.on_exit.reason})"
                )

    def running(self) -> list[Process]:
        return [p for p in self.processes if p.alive()]

    def wait(self, timeout: float | None = None) -> bool:
        """Pump until every process has exited; whether they did within ``timeout``."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.running():
            if deadline is not None and time.monotonic() >= deadline:
                return False
            self.pump(0.1)
        self._drain()
        return True

    def spin(self) -> int:
        """Run in the foreground until every process exits or Ctrl-C; the exit status."""
        try:
            self.wait()
        except KeyboardInterrupt:
            self._say("[WARNING] [launch]: user interrupted with ctrl-c (SIGINT)")
            while True:
                try:
                    self.shutdown()
                    break
                except KeyboardInterrupt:  # as launch does: SIGTERM, SIGKILL come in time
                    self._say(
                        "[WARNING] [launch]: user interrupted with ctrl-c (SIGINT) again, "
                        "ignoring..."
                    )
        self._drain()
        return 0 if all(p.returncode == 0 for p in self.processes) else 1

    # -- stopping ----------------------------------------------------------------
    def _begin_shutdown(self, reason: str) -> None:
        self.shutting_down = reason
        self._say(f"[INFO] [launch]: shutting down: {reason}")
        for process in self.running():
            self._signal(process, signal.SIGINT)

    def _signal(self, process: Process, sig: signal.Signals) -> None:
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            pass

    def shutdown(
        self, sigterm_timeout: float | None = None, sigkill_timeout: float | None = None
    ) -> dict[str, int]:
        """Ctrl-C every process, escalate to SIGTERM then SIGKILL; exit code by name."""
        if self.shutting_down is None:
            self._begin_shutdown("stop requested (Ctrl-C)")
        for sig, attr, override in (
            (signal.SIGTERM, "sigterm_timeout", sigterm_timeout),
            (signal.SIGKILL, "sigkill_timeout", sigkill_timeout),
        ):
            waits = [
                override if override is not None else getattr(p.node, attr) for p in self.processes
            ]
            deadline = time.monotonic() + max(waits, default=0.0)
            while self.running() and time.monotonic() < deadline:
                self.pump(0.05)
            for process in self.running():
                self._say(f"[WARNING] [{process.name}]: still running: sending {sig.name}")
                self._signal(process, sig)
        for process in self.processes:
            process.popen.wait()
            self._signal(process, signal.SIGKILL)  # anything it started in its group
        self._drain()
        _running.discard(self)
        return {p.name: p.popen.returncode for p in self.processes}

    def _drain(self) -> None:
        for reader in self._readers:
            reader.join(timeout=1.0)
        self._check_exits()
        self.pump(0.0)

    # -- reading -------------------------------------------------------------------
    def process(self, name: str) -> Process:
        """The process named ``name`` (``talker-1``) or whose node is named ``name``."""
        for process in self.processes:
            if name in (process.name, process.node.name):
                return process
        raise KeyError(f"no process {name!r}: {[p.name for p in self.processes]}")

    def __enter__(self) -> Launch:
        return self

    def __exit__(self, *exc: object) -> None:
        self.shutdown()


def launch(
    description: LaunchDescription,
    *,
    env: Mapping[str, str] | None = None,
    echo: Callable[[str], None] | None = print,
) -> Launch:
    """Start ``description``; use as ``with launch(ld) as system: ...`` (stops on exit)."""
    return Launch(description, env=env, echo=echo).start()


def load_launch_file(path: str | os.PathLike[str]) -> LaunchDescription:
    """Run a Python launch file and return its ``generate_launch_description()``."""
    source = Path(path)
    namespace: dict[str, Any] = {"__file__": str(source), "__name__": "__launch_file__"}
    exec(compile(source.read_text(), str(source), "exec"), namespace)  # noqa: S102
    generate = namespace.get("generate_launch_description")
    if not callable(generate):
        raise LaunchError(f"{source} has no function generate_launch_description()")
    return generate()


def node_names(description: LaunchDescription) -> Iterable[str]:
    """Fully qualified names the description's nodes will have (when it names them)."""
    for entity in description.entities:
        if isinstance(entity, Node) and entity.name:
            namespace = absolute_name(entity.namespace or "/").rstrip("/")
            yield f"{namespace}/{entity.name}"
