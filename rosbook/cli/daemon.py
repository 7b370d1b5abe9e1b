"""The ``ros2`` graph daemon: one per user and ROS environment, like upstream's.

A cold ``ros2 node list`` pays for starting Python and rclpy, then waits until its new
participant has discovered the graph and can trust it is complete. The daemon is a
process that holds one hidden node (``_ros2cli_daemon_...``), discovering since it
started; the read-only graph verbs (``ANSWERED``) send it their arguments on a Unix
socket and print what it answers: it runs the very same verb code on its own node
(``rosbook.cli.cli_node``), so the answers are the direct path's, without the wait.
This client side imports neither rclpy nor the verbs.

- One daemon per environment (``ENVIRONMENT``: the domain, the RMW, discovery and
  transport settings, an isolated run's token): a socket named after their hash in a
  private directory (0700, owned by the user; the socket 0600; never TCP).
- The first command that finds none starts one (detached: a new session, no inherited
  stdin/stdout/stderr) and answers directly this once, as upstream does; not within
  an isolated run (``ROSBOOK_RUN_TOKEN``: tests, book builds, grading, sandboxes)
  unless it sets ``ROSBOOK_CLI_DAEMON=1`` (``make lab``'s server does; isolated runs
  never inherit it). There ``ros2 daemon start`` starts one, and the daemon, which
  carries the run's token, ends with the run (``kill_marked``).
  ``ROSBOOK_CLI_DAEMON=0`` never uses one.
- It exits after ``IDLE_S`` without a request, when its socket file is removed or
  replaced, on SIGTERM, and on ``ros2 daemon stop``.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import io
import json
import os
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rosbook.runtime.isolation import RUN_MARKER, _alive

if TYPE_CHECKING:
    from rclpy.node import Node

#: The option that makes a read-only verb ask the graph directly.
NO_DAEMON = "--no-daemon"
#: The verbs the daemon answers: they only read the graph.
ANSWERED = {
    ("node", "list"),
    ("node", "info"),
    ("topic", "list"),
    ("topic", "info"),
    ("topic", "find"),
    ("service", "list"),
    ("service", "type"),
    ("service", "info"),
    ("service", "find"),
    ("action", "list"),
    ("action", "info"),
    ("action", "type"),
}
#: What makes two ROS environments see different graphs: one daemon for each.
ENVIRONMENT = (
    "ROS_DOMAIN_ID",
    "RMW_IMPLEMENTATION",
    "ROS_AUTOMATIC_DISCOVERY_RANGE",
    "ROS_STATIC_PEERS",
    "ROS_LOCALHOST_ONLY",
    "FASTRTPS_DEFAULT_PROFILES_FILE",
    "FASTDDS_DEFAULT_PROFILES_FILE",
    "FASTDDS_BUILTIN_TRANSPORTS",
    "ROS_SECURITY_ENABLE",
    "ROS_SECURITY_KEYSTORE",
    RUN_MARKER,
)
#: ``0``: never use a daemon; ``1``: start one even within an isolated run.
SWITCH = "ROSBOOK_CLI_DAEMON"
#: The daemon exits after this many seconds without a request.
IDLE_S = 600.0
#: How often an idle daemon looks at the graph and at its socket file (seconds).
TICK_S = 0.25
#: Longest a command waits for the daemon's answer, or for it to start or stop: a
#: guard against a hang (a verb's own guards are shorter).
WAIT_S = 60.0

#: In the daemon process, its node: ``cli_node`` hands it to the verbs.
shared_node: Node | None = None


def answers(argv: list[str]) -> bool:
    """Whether the daemon answers ``ros2 ARGV``."""
    return tuple(argv[:2]) in ANSWERED


def socket_path() -> Path | None:
    """This environment's daemon socket; None when no private directory can be had."""
    key = "\0".join(f"{k}={os.environ.get(k, '')}" for k in ENVIRONMENT)
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    base = Path(runtime) if runtime and Path(runtime).is_dir() else Path(tempfile.gettempdir())
    directory = base / f"rosbook-ros2cli-{os.getuid()}"
    try:
        directory.mkdir(mode=0o700, exist_ok=True)
        info = directory.lstat()
    except OSError:
        return None
    private = stat.S_ISDIR(info.st_mode) and info.st_uid == os.getuid()
    if not private or info.st_mode & 0o077:
        return None  # someone else's, or readable by others: do not trust it
    return directory / (hashlib.sha256(key.encode()).hexdigest()[:20] + ".sock")


def request(message: dict[str, Any], timeout: float = WAIT_S) -> dict[str, Any] | None:
    """The daemon's reply to ``message``; None when no daemon listens here.

    ``TimeoutError`` when one listens but has not answered within ``timeout`` s.
    """
    path = socket_path()
    if path is None:
        return None
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as client:
        client.settimeout(timeout)
        try:
            client.connect(str(path))
        except (FileNotFoundError, ConnectionRefusedError):
            return None
        client.sendall(json.dumps(message).encode() + b"\n")
        client.shutdown(socket.SHUT_WR)
        reply = _read_all(client)
    return json.loads(reply) if reply else None


def _read_all(connection: socket.socket) -> bytes:
    """What the other end sends until it shuts its side down."""
    return b"".join(iter(lambda: connection.recv(65536), b""))


def ask(argv: list[str]) -> int | None:
    """Answer ``ros2 ARGV`` through the daemon: its exit code, or None to answer directly
    (not a daemon verb, ``--no-daemon``, or no daemon: then one is started if allowed)."""
    switch = os.environ.get(SWITCH, "")
    if not answers(argv) or NO_DAEMON in argv or switch == "0":
        return None
    try:
        reply = request({"argv": argv})
    except TimeoutError:
        print(
            f"ros2: timeout: the daemon did not answer within {WAIT_S:g} s; asking directly",
            file=sys.stderr,
        )
        return None
    except OSError:
        return None
    if reply is None:
        if switch == "1" or RUN_MARKER not in os.environ:
            spawn()
        return None
    sys.stdout.write(reply["stdout"])
    sys.stderr.write(reply["stderr"])
    return int(reply["code"])


def spawn() -> None:
    """Start this environment's daemon, detached from this command's session and pipes."""
    path = socket_path()
    if path is not None:
        subprocess.Popen(
            [sys.executable, "-m", "rosbook.cli.daemon", str(path)],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
            close_fds=True,
        )


def status() -> int | None:
    """The pid of this environment's daemon, None when none runs."""
    try:
        reply = request({"op": "status"})
    except OSError:
        return None
    return None if reply is None else int(reply["pid"])


def wait_until(condition: Any, timeout: float = WAIT_S) -> bool:
    """Poll ``condition()`` (a process appearing or ending) until it holds or ``timeout``."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def stop() -> bool:
    """Stop this environment's daemon and wait until its process has ended; whether one ran."""
    try:
        reply = request({"op": "stop"})
    except OSError:
        return False
    if reply is None:
        return False
    pid = int(reply["pid"])
    if not wait_until(lambda: not _alive(pid)):
        raise TimeoutError(f"timeout: the daemon (pid {pid}) still runs after {WAIT_S:g} s")
    return True


# -- the daemon process ------------------------------------------------------------
def _run(parser: Any, argv: list[str]) -> dict[str, Any]:
    """Run one verb as the command would, capturing what it prints."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            args = parser.parse_args(argv)
            code = int(args.func(args) or 0)
        except SystemExit as done:  # argparse: -h, a wrong argument
            code = done.code if isinstance(done.code, int) else int(done.code is not None)
        except Exception:  # noqa: BLE001 (the command's own traceback, as if run directly)
            traceback.print_exc()
            code = 1
    return {"stdout": out.getvalue(), "stderr": err.getvalue(), "code": code}


def serve(path: Path) -> int:
    """The daemon: answer requests on ``path`` until idle, stopped or its socket is gone."""
    global shared_node
    lock_path = f"{path}.lock"
    lock = os.fdopen(os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o600), "r+")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return 0  # another daemon serves this environment
    _sweep(path.parent)
    from rosbook.cli import build_parser, private_node
    from rosbook.runtime import graph

    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    with private_node(f"_ros2cli_daemon_{domain}_{os.getpid()}") as node:
        shared_node = node
        return _serve(path, lock_path, graph.keep_watching(node), build_parser())


def _sweep(directory: Path) -> None:
    """Remove what daemons that were killed (with their isolated run) left: a socket and
    a lock file that no process holds."""
    for lock_path in directory.glob("*.sock.lock"):
        socket_file = Path(str(lock_path).removesuffix(".lock"))
        if not socket_file.exists():  # a daemon starting now (it binds after its lock)
            continue
        try:
            with open(lock_path, "r+") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
                socket_file.unlink(missing_ok=True)
                lock_path.unlink()
        except OSError:  # held (BlockingIOError): its daemon runs; or gone already
            continue


def _serve(path: Path, lock: str, look: Any, parser: Any) -> int:
    """``serve``'s loop: ``look()`` while idle, ``parser`` for the requests."""
    assert shared_node is not None
    stopping: list[int] = []
    signal.signal(signal.SIGTERM, lambda *_: stopping.append(1))
    with contextlib.suppress(FileNotFoundError):
        path.unlink()
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    umask = os.umask(0o177)
    try:
        server.bind(str(path))  # 0600
    finally:
        os.umask(umask)
    server.listen(16)
    server.settimeout(TICK_S)
    inode = path.stat().st_ino
    last = time.monotonic()
    try:
        while not stopping and time.monotonic() - last < IDLE_S:
            try:
                if path.stat().st_ino != inode:
                    break  # replaced
            except FileNotFoundError:
                break  # removed
            try:
                connection, _ = server.accept()
            except TimeoutError:
                look()
                continue
            with connection:
                connection.settimeout(WAIT_S)
                try:
                    message = json.loads(_read_all(connection))
                except (OSError, ValueError):
                    continue
                if message.get("op") == "stop":
                    stopping.append(1)
                    reply: dict[str, Any] = {"pid": os.getpid()}
                elif message.get("op") == "status":
                    reply = {"pid": os.getpid(), "node": shared_node.get_fully_qualified_name()}
                else:
                    reply = _run(parser, [str(a) for a in message.get("argv", [])])
                with contextlib.suppress(OSError):
                    connection.sendall(json.dumps(reply).encode())
            last = time.monotonic()
    finally:
        with contextlib.suppress(OSError):
            if path.stat().st_ino == inode:
                path.unlink()
        with contextlib.suppress(OSError):
            os.unlink(lock)  # held still: a daemon starting now makes a new one
        server.close()
    return 0


if __name__ == "__main__":
    from rosbook.cli.daemon import serve as serve_here  # the package's module, not __main__

    sys.exit(serve_here(Path(sys.argv[1])))
