"""autograder.cgroups: each sandbox's CPU quota, memory limit and pids.max, and its end."""

from __future__ import annotations

import asyncio
import os
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from nbformat.v4 import new_code_cell, new_notebook
from traitlets.config import Config

from autograder import cgroups, kernels, sandbox
from autograder.kernels import IpcKernelManager
from tests.sandboxtools import ros_env

#: A hang guard (a loaded machine is slow): hitting it says "timeout".
GUARD = 120.0


@pytest.fixture(scope="module")
def writable() -> None:
    probe = cgroups.create("probe", 1.0, 1 << 30, 64)
    if probe is None:
        pytest.skip("cgroups cannot be written here (not root, no delegation)")
    probe.remove()


def wait_for(what: str, condition) -> None:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + GUARD
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timeout after {GUARD:.0f} s waiting for {what}")
        time.sleep(0.05)  # polling the cgroup's counters, not a wait for time


def started(
    cmd: list[str], tmp_path: Path, private: Path, net: sandbox.Network, limits: sandbox.Limits
) -> tuple[subprocess.Popen[str], cgroups.Cgroup, int]:
    """``cmd`` running in a sandbox with ``limits``, its cgroup and its first process."""
    seed = tmp_path / "lab"
    seed.mkdir(exist_ok=True)
    launch = sandbox.prepare(
        cmd,
        network=net,
        private=private,
        env=ros_env(),
        seed=seed,
        limits=limits,
        label="test",
    )
    assert launch.cgroup is not None
    proc, pid = sandbox.start(
        launch, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    return proc, launch.cgroup, pid


def ended(proc: subprocess.Popen[str], group: cgroups.Cgroup) -> str:
    """Stop the sandbox; its output. Its cgroup is gone afterwards."""
    if proc.poll() is None:
        proc.kill()
    out, _ = proc.communicate(timeout=GUARD)
    assert group.gone.wait(GUARD), "timeout: the cgroup was not removed"
    assert not any(folder.exists() for folder in group.directories())
    return out


# a sandbox and a second of its quota's periods (longer on a loaded machine): slow tier
@pytest.mark.slow
def test_a_busy_sandbox_gets_at_most_its_cpu_quota(tmp_path, private, writable) -> None:
    """A busy loop gets at most its quota: CPU used <= quota x periods it ran in (the
    kernel's own counters; on a loaded machine it may get less, never more)."""
    cpus = 0.2
    with sandbox.Network() as net:
        proc, group, pid = started(
            [sys.executable, "-c", "print('spinning', flush=True)\nwhile True:\n    pass\n"],
            tmp_path,
            private,
            net,
            sandbox.Limits(cpus=cpus),
        )
        try:
            assert proc.stdout is not None and proc.stdout.readline() == "spinning\n"
            # Ten periods of the quota pass whatever the load; a throttled period needs the
            # loop to reach its quota in one, which a CPU shared by many may never give it
            # (make stress: none in 120 s). The bound below holds either way, and an idle
            # machine would run an unlimited loop far past it.
            wait_for("10 periods of the CPU quota", lambda: group.cpu_periods()[0] >= 10)
            used = group.cpu_seconds()
            periods, throttled = group.cpu_periods()
        finally:
            ended(proc, group)
    quota = cpus * cgroups.PERIOD_US / 1e6
    assert used <= (periods + 1) * quota * 1.05, (used, periods, throttled)
    assert used > 0


# two sandboxes, one filled up to its limit: slow tier
@pytest.mark.slow
def test_a_memory_hog_is_oom_killed_in_its_sandbox_and_its_neighbour_lives(
    tmp_path, private, writable
) -> None:
    """Past its memory limit a sandbox's biggest process is killed; the sandbox next to
    it (same limit, same network) keeps running and allocating."""
    # it stays until killed: a sandbox's cgroup goes as its process ends, and its
    # counter is read after that (a stress run found the counter gone)
    neighbour_code = (
        "print('ready')\ninput()\nblock = b'n' * (32 << 20)\nprint('alive', len(block) >> 20)\n"
        "input()\n"
    )
    hog_code = (
        "blocks = []\nfor i in range(64):\n    blocks.append(b'h' * (16 << 20))\n"
        "    print('allocated', (i + 1) * 16)\nprint('allocated all')\n"
    )
    # the hog under a shell that stays: its status and the cgroup's counter are read
    hog_cmd = ["/bin/sh", "-c", f'{sys.executable} -u -c "$0"; echo "exit $?"; read _', hog_code]
    limits = sandbox.Limits(ram=160 << 20)
    os.chmod(private, 0o711)  # holds two sandboxes' folders
    with sandbox.Network() as net:
        neighbour, neighbours, _ = started(
            [sys.executable, "-u", "-c", neighbour_code], tmp_path, private / "a", net, limits
        )
        hog, hogs, _ = started(hog_cmd, tmp_path, private / "b", net, limits)
        try:
            assert neighbour.stdout is not None and neighbour.stdout.readline() == "ready\n"
            assert hog.stdout is not None
            lines = []
            while not lines or not lines[-1].startswith("exit"):
                lines.append(hog.stdout.readline())
                assert lines[-1], lines  # the shell prints the status: EOF is a failure
            assert lines[-1] == "exit 137\n" and "allocated 16\n" in lines, lines  # SIGKILL
            assert hogs.oom_kills() >= 1
            assert neighbour.stdin is not None
            neighbour.stdin.write("go\n")
            neighbour.stdin.flush()
            assert neighbour.stdout.readline() == "alive 32\n"
            assert neighbours.oom_kills() == 0
        finally:
            ended(hog, hogs)
            ended(neighbour, neighbours)


FORK_BOMB = """
import os, signal
children = 0
try:
    while True:
        if os.fork() == 0:
            signal.pause()
        children += 1
except OSError as exc:
    print('refused after', children, exc.errno, flush=True)
input()
"""


# the process limit is checked in the fast tier by test_sandbox's limits test, a
# program entered later by test_a_program_entered_into_a_sandbox_joins_its_cgroup
@pytest.mark.slow
def test_a_fork_bomb_stops_at_pids_max_and_a_program_entered_later_is_counted(
    tmp_path, private, writable
) -> None:
    """Forks past ``Limits.processes`` tasks are refused by the sandbox's cgroup; a
    program a trusted process runs in the sandbox (``enter_argv``) is in it too."""
    tasks = 48
    with sandbox.Network() as net:
        proc, group, pid = started(
            [sys.executable, "-c", FORK_BOMB],
            tmp_path,
            private,
            net,
            sandbox.Limits(processes=tasks),
        )
        try:
            assert proc.stdout is not None
            words = proc.stdout.readline().split()
            assert words[:2] == ["refused", "after"] and words[3] == "11", words  # EAGAIN
            assert int(words[2]) < tasks
            assert group.pids_refused() >= 1  # the cgroup refused it, not only the rlimit
            assert len(group.pids()) <= tasks
        finally:
            ended(proc, group)


def test_a_program_entered_into_a_sandbox_joins_its_cgroup(tmp_path, private, writable) -> None:
    with sandbox.Network() as net:
        proc, group, pid = started(
            [sys.executable, "-c", "print('ready', flush=True)\ninput()\n"],
            tmp_path,
            private,
            net,
            sandbox.Limits(),
        )
        try:
            assert proc.stdout is not None and proc.stdout.readline() == "ready\n"
            before = group.pids()
            program = subprocess.Popen(
                sandbox.enter_argv(pid, f"{sandbox.HOME}/lab", [sys.executable, "-c", "input()"]),
                env=ros_env(),
                stdin=subprocess.PIPE,
            )
            try:
                wait_for("the entered program", lambda: len(group.pids() - before) >= 2)
                assert program.pid in group.pids()
            finally:
                program.kill()
                program.wait()
        finally:
            ended(proc, group)


def test_cgroups_made_inside_a_smaller_one_get_its_quota_and_go_with_it(writable) -> None:
    """A grader run inside a cgroup with a CPU quota (a container's or a pod's; the slow
    machine of tests/slowdown.py) makes its sandboxes' cgroups in it: one asked for more
    CPU than the outer allows is made with the outer's quota (cgroup v1 refused it: every
    submission was an error), and removing the outer ends their processes and removes
    them too, at once (not after the removal's hang guard)."""
    outer = cgroups.create("outer", 0.25, 1 << 30, 64)
    assert outer is not None
    inside = [str(d) for d in outer.directories()]
    child = subprocess.Popen(
        [sys.executable, "-c", "from autograder import cgroups\n"
         "g = cgroups.create('inner', 1.0, 1 << 29, 32)\n"
         "cgroups.join([str(d) for d in g.directories()])\n"
         "print(g.limits()[0], g.directories(), flush=True)\ninput()"],
        preexec_fn=lambda: cgroups.join(inside), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    try:
        assert child.stdout is not None
        made = child.stdout.readline()
        assert made.startswith("0.25 "), made  # the outer's quota, not the 1.0 asked for
        assert all(made.count(d) == 1 for d in inside), (made, inside)  # made inside
        started = time.monotonic()
        outer.remove()
        assert time.monotonic() - started < cgroups.REMOVE_TIMEOUT
        assert child.wait(timeout=GUARD) == -9  # killed with its cgroup
        assert not any(Path(d).exists() for d in inside)
    finally:
        child.kill()
        child.wait()


def test_without_cgroups_the_missing_limits_and_the_fix_are_said_once(tmp_path, private) -> None:
    """Cgroups that cannot be written (here: read-only, in a sandbox): no cgroup, the
    rlimits stay, and the grader says once which limits are missing and the fix."""
    code = (
        "from autograder import cgroups\n"
        "print(cgroups.create('a', 1.0, 1 << 30, 64), cgroups.create('b', 1.0, 1 << 30, 64))\n"
    )
    with sandbox.Network() as net:
        launch = sandbox.prepare(
            [sys.executable, "-c", code],
            network=net,
            private=private,
            env=ros_env(),
            files={"/sys/fs/cgroup": "/sys/fs/cgroup"},
        )
        proc, _ = sandbox.start(launch, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        out, err = proc.communicate(timeout=GUARD)
    assert out == "None None\n", out + err
    assert err.count("autograder.cgroups: sandboxes run without") == 1, err
    assert "the CPU quota, the memory limit, pids.max" in err and "Read-only" in err, err
    assert "rlimits apply" in err and "Fix:" in err


def test_a_grading_kernel_runs_in_a_cgroup_of_the_configured_size(writable) -> None:
    """``c.IpcKernelManager.cpus`` and ``.ram`` (the nbgrader config) size each kernel's
    sandbox; its cgroup goes with the kernel."""
    config = Config({"IpcKernelManager": {"cpus": 0.5, "ram": 300 << 20}})

    async def run() -> cgroups.Cgroup:
        manager = IpcKernelManager(config=config, kernel_name="python3")
        await manager.start_kernel(env=ros_env())
        try:
            group = manager.cgroup
            assert group is not None and manager.sandbox_pid in group.pids()
            assert group.limits() == (0.5, 300 << 20, sandbox.Limits.processes)
        finally:
            await manager.shutdown_kernel(now=True)
        return group

    # in a thread of its own: an earlier test's Playwright may hold this thread's loop
    with ThreadPoolExecutor(1) as pool:
        group = pool.submit(asyncio.run, run()).result()
    assert group.gone.is_set() and not any(f.exists() for f in group.directories())


SPAWN = """import subprocess
kids = []
try:
    while True:
        kids.append(subprocess.Popen(['sleep', '600']))
except OSError as exc:
    print('stopped at', len(kids), exc.errno)
"""
AFTER = """import threading
room = threading.Thread(target=print, args=('room for a thread',))
room.start()
room.join()
print('left running:', sum(kid.poll() is None for kid in kids))
"""


@pytest.mark.slow  # a kernel filled to its limit; the fork-bomb test above is its kin
def test_a_kernel_left_at_its_process_limit_gets_room_back(writable, tmp_path) -> None:
    """A cell that fills the sandbox's pids.max with programs it keeps would leave the
    kernel no room for a thread (every later cell and check hangs to the submission's
    time limit): before the next cell those programs are ended, the kernel kept."""
    config = Config({"IpcKernelManager": {"processes": 64}})
    notebook = new_notebook(cells=[new_code_cell(SPAWN), new_code_cell(AFTER)])
    kernels.REAPED.clear()
    execute = kernels.CappedExecute(
        config=config, kernel_manager_class=kernels.IpcKernelManager, timeout=int(GUARD)
    )
    with ThreadPoolExecutor(1) as pool:  # an earlier test's Playwright may hold this loop
        pool.submit(execute.preprocess, notebook, {"metadata": {"path": str(tmp_path)}}).result()
    spawned, after = ("".join(o.get("text", "") for o in c.outputs) for c in notebook.cells)
    assert spawned.startswith("stopped at") and spawned.endswith(" 11\n"), spawned  # EAGAIN
    assert after == "room for a thread\nleft running: 0\n", notebook.cells[1].outputs
    assert kernels.REAPED and kernels.REAPED[0] >= 30, kernels.REAPED


def test_a_new_sandbox_never_joins_a_cgroup_left_by_a_grader_of_the_same_pid(writable) -> None:
    """Pids are reused (32768 of them on a busy machine), and a gone grader's folder whose
    processes are still dying is not swept: the next name is one nobody holds."""
    first = cgroups.create("reuse", 1.0, 1 << 30, 64)
    assert first is not None
    left = first.directories()
    taken = int(left[0].name.rsplit("-", 1)[1]) + 1
    # the folders the next sandbox would get, left behind (as by a killed grader)
    stale = [folder.with_name(f"{folder.name.rsplit('-', 1)[0]}-{taken}") for folder in left]
    for folder in stale:
        folder.mkdir()
    try:
        second = cgroups.create("reuse", 1.0, 1 << 30, 64)
        assert second is not None
        assert not set(second.directories()) & set(stale), second.directories()
        second.remove()
    finally:
        first.remove()
        for folder in stale:
            folder.rmdir()
