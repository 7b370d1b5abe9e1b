"""ROS domain isolation for tests, book builds and grading runs.

Every run that talks DDS gets its own ``ROS_DOMAIN_ID`` and stays on this machine
(``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``), so parallel runs never hear each other.
A domain is reserved with an exclusive file lock, which the kernel drops when the
holder dies: no stale reservation survives a crash.

Run any command in a fresh domain::

    python -m rosbook.runtime.isolation -- jupyter-book build .
"""

from __future__ import annotations

import fcntl
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
import uuid
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import IO

#: Domain IDs 1..101 are safe for every DDS port mapping on Linux (0 is the default
#: domain a stray ``ros2`` shell would use, so it is never handed out).
DOMAIN_RANGE = range(1, 102)
LOCK_DIR = Path(tempfile.gettempdir()) / "rosbook-domains"

#: Fast DDS profile of isolated runs: quick local discovery (see the file's comment).
FASTDDS_PROFILE = Path(__file__).resolve().parent / "fastdds_local.xml"

#: Environment every isolated ROS process gets besides its domain.
BASE_ENV: dict[str, str] = {
    "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
    # Asks Fast DDS for UDP only, but under the LOCALHOST range rmw_fastrtps_cpp picks
    # its own transports (shared memory and loopback UDP; rmw_fastrtps_shared_cpp's
    # participant.cpp), so participants still make /dev/shm segments. Graded work runs
    # in a sandbox network whose /dev/shm is its own and goes with it.
    "FASTDDS_BUILTIN_TRANSPORTS": "UDPv4",
    # ROS logs go to stderr by default; nbgrader scores a test cell 0 when it writes
    # to stderr, and notebooks show stdout inline.
    "RCUTILS_LOGGING_USE_STDOUT": "1",
    # Line-buffered: a log line reaches a pipe (a notebook, a grader's log) when it
    # is written, not when a 4 KB buffer fills or the process exits.
    "RCUTILS_LOGGING_BUFFERED_STREAM": "1",
    "RCUTILS_COLORIZED_OUTPUT": "0",
    # Participants announce themselves every 0.25 s (Fast DDS's default is 3 s), so a
    # process joining a running system discovers it at once; see the file.
    "FASTRTPS_DEFAULT_PROFILES_FILE": str(FASTDDS_PROFILE),
}


#: Variables no isolated child inherits: a Jupyter kernel that sees it runs under
#: pytest stops forwarding C-level output (ROS log lines) to the notebook, so a test
#: would see other outputs than a student or the book build. ``ROSBOOK_CLI_DAEMON=1``
#: lets ``ros2`` start its graph daemon within an isolated run (``rosbook.cli.daemon``):
#: only where the run itself says so (``make lab``'s server), never inherited by a
#: test, book build or grading run from the shell that started it.
SCRUBBED = ("PYTEST_CURRENT_TEST", "ROSBOOK_CLI_DAEMON")


def child_env(base: Mapping[str, str] | None = None) -> dict[str, str]:
    """``base`` (default: this process's environment) without ``SCRUBBED`` variables."""
    return {k: v for k, v in (os.environ if base is None else base).items() if k not in SCRUBBED}


class DomainReservation:
    """A ROS domain held for as long as this object's lock file stays open."""

    def __init__(self, domain_id: int, handle: IO[str]) -> None:
        self.domain_id = domain_id
        self.token = f"{domain_id}-{os.getpid()}-{uuid.uuid4().hex[:12]}"
        self._handle: IO[str] | None = handle

    def env(self, base: Mapping[str, str] | None = None) -> dict[str, str]:
        """``base`` (default: this process's environment) isolated in this domain.

        It also carries a token unique to this reservation, by which ``kill_marked``
        finds every process started under it.
        """
        env = child_env(base)
        env.update(BASE_ENV)
        env["ROS_DOMAIN_ID"] = str(self.domain_id)
        env[RUN_MARKER] = self.token
        return env

    def release(self) -> None:
        if self._handle is not None:
            self._handle.close()
            self._handle = None

    def __enter__(self) -> DomainReservation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def reserve_domain(rng: random.Random | None = None) -> DomainReservation:
    """Reserve a ROS domain no other isolated run on this machine is using."""
    LOCK_DIR.mkdir(parents=True, exist_ok=True)
    candidates = list(DOMAIN_RANGE)
    (rng or random.Random()).shuffle(candidates)
    for domain_id in candidates:
        handle = open(LOCK_DIR / f"{domain_id}.lock", "a+")  # noqa: SIM115 (held open)
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.close()
            continue
        return DomainReservation(domain_id, handle)
    raise RuntimeError(
        f"all {len(DOMAIN_RANGE)} ROS domains are in use by other isolated runs; "
        f"see the lock files in {LOCK_DIR}"
    )


@contextmanager
def isolated_environ() -> Iterator[int]:
    """Isolate *this* process (and the children it starts) in a fresh domain.

    Must be entered before rclpy is initialised: the domain is read at init.
    """
    saved = dict(os.environ)
    with reserve_domain() as reservation:
        os.environ.clear()
        os.environ.update(reservation.env(saved))
        try:
            yield reservation.domain_id
        finally:
            os.environ.clear()
            os.environ.update(saved)


#: Every process of an isolated run inherits this variable, whatever session or
#: process group it moved to (Jupyter kernels start their own session).
RUN_MARKER = "ROSBOOK_RUN_TOKEN"


def kill_marked(
    token: str, exclude: set[int] | frozenset[int] = frozenset(), wait: float = 10.0
) -> int:
    """SIGKILL every process whose environment carries ``RUN_MARKER=token``, and wait (at
    most ``wait`` seconds) until each has died: a process dies some time after SIGKILL,
    and one still dying would count as left behind.

    ``/proc/PID/environ`` is the environment a process was started with, so a process
    that only set the token in its own ``os.environ`` (to pass it on) is not matched.
    """
    needle = f"{RUN_MARKER}={token}".encode()
    killed: list[int] = []
    for proc_dir in Path("/proc").glob("[0-9]*"):
        pid = int(proc_dir.name)
        if pid == os.getpid() or pid in exclude:
            continue
        environ = _start_environment(pid)
        if environ is not None and needle in environ.split(b"\0"):
            try:
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
            except ProcessLookupError:
                pass
    deadline = time.monotonic() + wait
    while any(_alive(pid) for pid in killed) and time.monotonic() < deadline:
        time.sleep(0.02)
    return len(killed)


#: How long an environment that reads empty is read again (seconds): see below.
EXEC_SETTLE_S = 0.2
#: ``/proc/PID/stat``'s flag of a kernel thread (which has no environment).
PF_KTHREAD = 0x00200000


def _start_environment(pid: int) -> bytes | None:
    """The environment process ``pid`` was started with (None: gone, or not ours).

    A process that is in ``execve`` has an empty one until its new stack is set up; its
    parent may already have seen it exec (``subprocess.Popen`` has returned), so an
    empty environment of a live process other than a kernel thread is read again for
    up to ``EXEC_SETTLE_S``.
    """
    deadline = time.monotonic() + EXEC_SETTLE_S
    while True:
        try:
            environ = Path(f"/proc/{pid}/environ").read_bytes()
            stat = Path(f"/proc/{pid}/stat").read_text() if not environ else ""
        except OSError:  # gone already, or not ours to read
            return None
        if environ or time.monotonic() > deadline:
            return environ
        fields = stat[stat.rindex(")") + 2 :].split()
        if fields[0] in "ZX" or int(fields[6]) & PF_KTHREAD:  # dead, or a kernel thread
            return environ
        time.sleep(0.002)


def _alive(pid: int) -> bool:
    """Whether ``pid`` still runs (a zombie has died: only its parent's reaping is left)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2] not in "ZX"


def kill_orphans() -> int:
    """SIGKILL the processes of isolated runs that nobody owns any more.

    A token is ``<domain>-<pid of the reserving process>-<random>``. When that process
    died without cleaning up (SIGKILL, power loss), what it started would talk to
    whoever reserves the domain next. A process counts as orphaned only when both
    its reserving process is gone and its domain's lock is free.
    """
    prefix = f"{RUN_MARKER}=".encode()
    killed = 0
    for proc_dir in Path("/proc").glob("[0-9]*"):
        try:
            environ = (proc_dir / "environ").read_bytes()
        except OSError:
            continue
        tokens = [item[len(prefix) :] for item in environ.split(b"\0") if item.startswith(prefix)]
        try:
            domain, owner = (int(part) for part in tokens[0].split(b"-")[:2])
        except (IndexError, ValueError):
            continue
        if Path(f"/proc/{owner}").exists() or not _domain_free(domain):
            continue
        try:
            os.kill(int(proc_dir.name), signal.SIGKILL)
            killed += 1
        except ProcessLookupError:
            pass
    return killed


def _domain_free(domain_id: int) -> bool:
    """No process holds ``domain_id``'s reservation lock."""
    try:
        with open(LOCK_DIR / f"{domain_id}.lock", "a+") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
    except OSError:  # BlockingIOError: held
        return False


def kill_process_group(proc: subprocess.Popen[bytes] | subprocess.Popen[str]) -> None:
    """Stop a child started with ``start_new_session=True`` and everything it spawned."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


def heed_ctrl_c() -> None:
    """Let Ctrl-C (SIGINT) reach this process and what it starts again when it came
    ignored: a shell starts background commands (``make test &``, a CI step) with SIGINT
    ignored, every child inherits that, and then a test's or a chapter's Ctrl-C to a
    ``ros2`` verb, a launch or a shell loop is lost: the command runs on until a timeout."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def run_isolated(argv: list[str], cwd: str | os.PathLike[str] | None = None) -> int:
    """Run ``argv`` in a fresh domain; leave no process of its group behind."""
    heed_ctrl_c()
    with reserve_domain() as reservation:
        proc = subprocess.Popen(argv, env=reservation.env(), start_new_session=True, cwd=cwd)
        try:
            return proc.wait()
        except KeyboardInterrupt:
            proc.send_signal(signal.SIGINT)
            return proc.wait()
        finally:
            kill_process_group(proc)
            kill_marked(reservation.token)


def main(argv: list[str] | None = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if args[:1] == ["--"]:
        args = args[1:]
    if not args:
        print("usage: python -m rosbook.runtime.isolation -- COMMAND [ARG ...]", file=sys.stderr)
        return 2
    return run_isolated(args)


if __name__ == "__main__":
    sys.exit(main())
