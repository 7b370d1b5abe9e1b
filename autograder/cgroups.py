"""A cgroup per sandbox: a CPU quota, a memory limit and a process (and thread) limit.

Rlimits (``autograder.sandbox.Limits``) limit each process; a cgroup limits the whole
sandbox: ``Limits.cpus`` CPUs of time per period, ``Limits.ram`` bytes of memory (an
allocation past it OOM-kills a process of that sandbox only) and ``Limits.processes``
tasks (``pids.max``: a fork bomb stops there).

``create`` makes the cgroup under the grader's own (``<own>/rosbook/<label>-<ns>x<pid>-<n>``):
cgroup v2 where the grader's group can have children with the ``cpu``, ``memory`` and
``pids`` controllers (its own group, or the parent of it when the grader runs in a leaf
of a delegated subtree: systemd's ``Delegate=yes`` with ``DelegateSubgroup=``); else
cgroup v1, one folder per hierarchy (a container or an older host, as root). The
sandbox's first process (``python -m autograder.sandbox join``) writes itself into
``cgroup.procs`` before it execs bwrap, so nothing of the student's ever runs outside
it. ``Cgroup.remove`` kills what is left in it and removes it; folders of graders that
died are removed by the next ``create``.

Where no cgroup can be made (not root and no delegation), ``create`` says once which
limits are missing and how to get them, and returns None: the rlimits stay.

This module runs inside sandboxes too (``enter``): it imports nothing of the grader's.
"""

from __future__ import annotations

import errno
import itertools
import math
import os
import re
import select
import signal
import sys
import threading
import time
from contextlib import suppress
from dataclasses import dataclass, field
from pathlib import Path

#: The CPU quota's period (microseconds).
PERIOD_US = 100_000
#: A hang guard for a removed sandbox's processes to be gone (they die at once).
REMOVE_TIMEOUT = 30.0
CONTROLLERS = ("cpu", "memory", "pids")
FIX = (
    "Fix: run the grader or the hub as root, or under systemd with a delegated cgroup "
    "(a service with Delegate=yes and DelegateSubgroup=main, or "
    "`systemd-run --user --scope -p Delegate=yes ...` on a host whose user manager "
    "delegates cpu, memory and pids)."
)

_counter = itertools.count()
_warned: set[str] = set()
_lock = threading.Lock()


def _warn_once(message: str) -> None:
    with _lock:
        if message in _warned:
            return
        _warned.add(message)
    print(f"autograder.cgroups: {message}", file=sys.stderr, flush=True)


def _mounts() -> dict[str, Path]:
    """cgroup mounts: ``"v2"`` -> the cgroup2 mount, each v1 controller -> its mount."""
    found: dict[str, Path] = {}
    for line in Path("/proc/self/mountinfo").read_text().splitlines():
        left, right = line.split(" - ", 1)
        fstype, _source, options = right.split()[:3]
        mount = Path(left.split()[4])
        if fstype == "cgroup2":
            found.setdefault("v2", mount)
        elif fstype == "cgroup":
            for option in options.split(","):
                if option in (*CONTROLLERS, "cpuacct"):
                    found.setdefault(option, mount)
    return found


def own(pid: int | str = "self") -> dict[str, str]:
    """The cgroups of ``pid``: ``"v2"`` or each v1 controller -> its path in the hierarchy."""
    groups: dict[str, str] = {}
    for line in Path(f"/proc/{pid}/cgroup").read_text().splitlines():
        _, names, path = line.split(":", 2)
        for name in names.split(",") if names else ["v2"]:
            groups[name] = path
    return groups


def _write(path: Path, value: str) -> None:
    path.write_text(value)


@dataclass
class Cgroup:
    """One sandbox's cgroup: a folder in cgroup v2, or one per v1 hierarchy."""

    version: int
    folders: dict[str, Path]  # controller ("v2" for cgroup v2) -> its folder
    #: Set once the cgroup is removed (``remove``, or ``remove_after`` its sandbox).
    gone: threading.Event = field(default_factory=threading.Event)
    _removing: threading.Lock = field(default_factory=threading.Lock)

    def directories(self) -> list[Path]:
        return sorted(set(self.folders.values()))

    def _file(self, controller: str, name: str) -> Path:
        return self.folders["v2" if self.version == 2 else controller] / name

    def limits(self) -> tuple[float, int, int]:
        """(CPUs, memory bytes, tasks) this cgroup allows, as the kernel holds them."""
        cpus = _cpus(self.folders["v2" if self.version == 2 else "cpu"])
        assert cpus is not None, self.folders
        memory = "memory.max" if self.version == 2 else "memory.limit_in_bytes"
        ram = int(self._file("memory", memory).read_text())
        return cpus, ram, int(self._file("pids", "pids.max").read_text())

    def cpu_seconds(self) -> float:
        """CPU time used by everything in the sandbox."""
        if self.version == 2:
            return _keyed(self._file("cpu", "cpu.stat"))["usage_usec"] / 1e6
        return int(self._file("cpuacct", "cpuacct.usage").read_text()) / 1e9

    def cpu_periods(self) -> tuple[int, int]:
        """(periods in which the sandbox ran, periods in which its quota stopped it)."""
        stat = _keyed(self._file("cpu", "cpu.stat"))
        return stat["nr_periods"], stat["nr_throttled"]

    def oom_kills(self) -> int:
        """Processes of the sandbox killed for going past its memory limit."""
        name = "memory.events" if self.version == 2 else "memory.oom_control"
        return _keyed(self._file("memory", name)).get("oom_kill", 0)

    def pids_refused(self) -> int:
        """Forks and clones refused at ``pids.max``."""
        return _keyed(self._file("pids", "pids.events")).get("max", 0)

    def full(self, room: int = 16) -> bool:
        """Its tasks (processes and threads) are within ``room`` of ``pids.max``."""
        current = int(self._file("pids", "pids.current").read_text())
        return current + room >= int(self._file("pids", "pids.max").read_text())

    def pids(self) -> set[int]:
        found: set[int] = set()
        for folder in self.directories():
            with suppress(FileNotFoundError):
                found |= {int(p) for p in (folder / "cgroup.procs").read_text().split()}
        return found

    def remove(self) -> None:
        """Kill what is left in the sandbox's cgroup and remove it (idempotent)."""
        with self._removing:
            if self.gone.is_set():
                return
            _remove(self.directories())
            self.gone.set()

    def remove_after(self, pid: int) -> None:
        """Remove the cgroup (and what is left in it) once process ``pid`` has ended
        (``pidfd``: it need not be our child, and is not reaped here)."""
        try:
            pidfd = os.pidfd_open(pid)
        except ProcessLookupError:  # already gone
            self.remove()
            return

        def watch() -> None:
            try:
                select.select([pidfd], [], [])
            finally:
                os.close(pidfd)
            self.remove()

        threading.Thread(target=watch, daemon=True, name="cgroup-remove").start()


def _keyed(path: Path) -> dict[str, int]:
    pairs = (line.split() for line in path.read_text().splitlines())
    return {p[0]: int(p[1]) for p in pairs if len(p) == 2 and p[1].lstrip("-").isdigit()}


def _remove(folders: list[Path]) -> None:
    # with the cgroups made inside them (a grader run in one makes its sandboxes' there),
    # the deepest first
    folders = sorted({n for f in folders for n in f.glob("**/")}, key=lambda p: -len(p.parts))
    deadline = time.monotonic() + REMOVE_TIMEOUT
    for folder in folders:
        kill = folder / "cgroup.kill"
        if kill.exists():
            with suppress(FileNotFoundError):
                _write(kill, "1")
    while True:
        left = []
        for folder in folders:
            try:
                pids = [int(p) for p in (folder / "cgroup.procs").read_text().split()]
            except FileNotFoundError:
                continue
            for pid in pids:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            try:
                folder.rmdir()
            except FileNotFoundError:
                pass
            except OSError as exc:
                if exc.errno != errno.EBUSY:
                    raise
                left.append(folder)
        if not left:
            return
        if time.monotonic() > deadline:
            _warn_once(f"timeout: processes still in {left[0]} after {REMOVE_TIMEOUT:.0f} s")
            return
        folders = left
        time.sleep(0.01)  # polling for the killed processes to be reaped


def _namespace() -> int:
    return os.stat("/proc/self/ns/pid").st_ino


def _sweep(parent: Path) -> None:
    """Remove the empty folders of graders that are gone (``<label>-<ns>x<pid>-<n>``).

    Only those of this PID namespace: another's pids are not in this ``/proc``.
    """
    for folder in parent.glob("*-*x*-*"):
        match = re.fullmatch(r".*-(\d+)x(\d+)-\d+", folder.name)
        if match and int(match.group(1)) == _namespace():
            if not Path(f"/proc/{match.group(2)}").exists():
                with suppress(OSError):  # still busy: its processes are dying
                    folder.rmdir()


def _v2_parent(mount: Path, path: str) -> tuple[Path | None, str]:
    """The v2 folder to put ``rosbook/`` in, with the controllers on; or why not."""
    own_group = mount / path.lstrip("/")
    reason = f"cgroup v2 at {own_group}: no parent of ours"
    for base in (own_group, own_group.parent):
        if not str(base).startswith(str(mount)):
            break
        available = (base / "cgroup.controllers").read_text().split()
        if not set(CONTROLLERS) <= set(available):
            return None, f"cgroup v2 at {base} lacks {set(CONTROLLERS) - set(available)}"
        try:
            enable = " ".join(f"+{c}" for c in CONTROLLERS)
            _write(base / "cgroup.subtree_control", enable)
            (base / "rosbook").mkdir(exist_ok=True)
            _write(base / "rosbook" / "cgroup.subtree_control", enable)
            return base / "rosbook", ""
        except OSError as exc:
            reason = f"cgroup v2 at {base}: {exc.strerror}"
    return None, reason


def _limit_v2(folder: Path, cpus: float, ram: int, processes: int) -> None:
    _write(folder / "cpu.max", f"{_quota(folder, cpus)} {PERIOD_US}")
    _write(folder / "memory.max", str(ram))
    with suppress(FileNotFoundError):  # no swap accounting: nothing to limit
        _write(folder / "memory.swap.max", "0")
    _write(folder / "pids.max", str(processes))


def _cpus(folder: Path) -> float | None:
    """The CPUs a cgroup folder's quota allows (v2's ``cpu.max``, v1's
    ``cpu.cfs_quota_us`` per period; ``math.inf`` unlimited), None without either file."""
    if (folder / "cpu.max").exists():
        quota, period = (folder / "cpu.max").read_text().split()
    elif (folder / "cpu.cfs_quota_us").exists():
        quota = (folder / "cpu.cfs_quota_us").read_text().strip()
        period = (folder / "cpu.cfs_period_us").read_text()
    else:
        return None
    return math.inf if quota in ("max", "-1") else int(quota) / int(period)


def _quota(folder: Path, cpus: float) -> int:
    """The CPU quota for ``cpus``, at most what the cgroups above allow (a grader in a
    container or pod with a CPU limit): cgroup v1 refuses a child more than its parent,
    and in v2 the parent's limit holds anyway (so ``limits`` says what holds)."""
    for above in folder.parents:
        allowed = _cpus(above)
        if allowed is None:  # past the hierarchy's root
            break
        cpus = min(cpus, allowed)
    return max(1000, int(cpus * PERIOD_US))


def _limit_v1(folders: dict[str, Path], cpus: float, ram: int, processes: int) -> None:
    if "cpu" in folders:
        _write(folders["cpu"] / "cpu.cfs_period_us", str(PERIOD_US))
        _write(folders["cpu"] / "cpu.cfs_quota_us", str(_quota(folders["cpu"], cpus)))
    if "memory" in folders:
        _write(folders["memory"] / "memory.limit_in_bytes", str(ram))
        with suppress(FileNotFoundError):  # swap accounting off: no swap to count
            _write(folders["memory"] / "memory.memsw.limit_in_bytes", str(ram))
    if "pids" in folders:
        _write(folders["pids"] / "pids.max", str(processes))


def _fresh_name(label: str, parents: list[Path]) -> str:
    """``<label>-<ns>x<pid>-<n>`` that none of ``parents`` holds. A grader that is gone
    may have left its folder with the same name (pids are reused, and a folder whose
    processes are still dying is not swept): a sandbox never joins another's cgroup."""
    while True:
        name = f"{label}-{_namespace()}x{os.getpid()}-{next(_counter)}"
        if not any(os.path.lexists(parent / name) for parent in parents):
            return name


def create(label: str, cpus: float, ram: int, processes: int) -> Cgroup | None:
    """A new cgroup with these limits for one sandbox, or None (said once) if none can
    be made here."""
    safe = re.sub(r"[^A-Za-z0-9_.]", "_", label)
    mounts, groups = _mounts(), own()
    reasons = []
    if "v2" in mounts and "v2" in groups:
        parent, reason = _v2_parent(mounts["v2"], groups["v2"])
        if parent is not None:
            _sweep(parent)
            folder = parent / _fresh_name(safe, [parent])
            folder.mkdir()
            try:
                _limit_v2(folder, cpus, ram, processes)
            except BaseException:
                _remove([folder])
                raise
            return Cgroup(2, {"v2": folder})
        reasons.append(reason)
    folders: dict[str, Path] = {}
    parents: dict[str, Path] = {}
    for controller in (*CONTROLLERS, "cpuacct"):
        if controller not in mounts or controller not in groups:
            continue
        parent = mounts[controller] / groups[controller].lstrip("/") / "rosbook"
        try:
            parent.mkdir(exist_ok=True)
            _sweep(parent)
        except OSError as exc:
            reasons.append(f"cgroup v1 {controller}: {exc.strerror} ({parent})")
            continue
        parents[controller] = parent
    name = _fresh_name(safe, list(parents.values()))
    try:
        for controller, parent in parents.items():
            try:
                # a controller mounted with another (cpu,cpuacct) has the folder already
                (parent / name).mkdir(exist_ok=(parent / name) in folders.values())
            except OSError as exc:
                reasons.append(f"cgroup v1 {controller}: {exc.strerror} ({parent})")
                continue
            folders[controller] = parent / name
        _limit_v1(folders, cpus, ram, processes)
    except BaseException:
        _remove(sorted(set(folders.values())))
        raise
    lost = [c for c in CONTROLLERS if c not in folders]
    if lost:
        what = {"cpu": "the CPU quota", "memory": "the memory limit", "pids": "pids.max"}
        _warn_once(
            f"sandboxes run without {', '.join(what[c] for c in lost)} "
            f"({'; '.join(reasons) or 'no cgroup hierarchy for ' + ', '.join(lost)}). "
            f"For those, only the per-process rlimits apply. {FIX}"
        )
    if not any(c in folders for c in CONTROLLERS):
        _remove(sorted(set(folders.values())))
        return None
    if "cpuacct" not in folders and "cpu" in folders:
        folders["cpuacct"] = folders["cpu"]  # co-mounted (cpu,cpuacct), or absent
    return Cgroup(1, folders)


def join(directories: list[str], pid: int = 0) -> None:
    """Put ``pid`` (0: this process) into each of these cgroup folders."""
    for folder in directories:
        _write(Path(folder) / "cgroup.procs", str(pid))


def join_of(pid: int) -> None:
    """Put this process into the cgroups of ``pid`` (a sandbox's first process), those
    ``create`` made."""
    mounts = _mounts()
    folders = []
    for controller, path in own(pid).items():
        if controller in mounts and "/rosbook/" in path:
            folders.append(str(mounts[controller] / path.lstrip("/")))
    join(sorted(set(folders)))
