"""autograder.sandbox: what a sandboxed process sees, what it may use, and who hears it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from autograder import sandbox
from autograder.config import ROOT
from rosbook.runtime.isolation import RUN_MARKER
from tests.sandboxtools import ros_env, run_inside

PUBLISH = """
import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node('pinger')
pub = node.create_publisher(String, 'ping', 10)
node.create_timer(0.1, lambda: pub.publish(String(data='from the sandbox')))
rclpy.spin(node)
"""

LISTEN = """
import sys, time
import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node('listener')
heard = []
node.create_subscription(String, 'ping', lambda m: heard.append(m.data), 10)
deadline = time.monotonic() + float(sys.argv[1])
while not heard and time.monotonic() < deadline:
    rclpy.spin_once(node, timeout_sec=0.2)
print(heard[0] if heard else 'nothing heard', flush=True)
"""


def test_sandbox_sees_its_home_and_read_only_code_and_no_grader_file(tmp_path, private) -> None:
    hidden = [str(ROOT / "solutions"), str(ROOT / "tests"), str(tmp_path), "/etc/shadow"]
    code = f"""
import os, sys
print('uid', os.getuid())
print('cwd', os.getcwd(), sorted(os.listdir('.')))
for path in {hidden!r}:
    print('exists' if os.path.exists(path) else 'absent', path)
print('SECRET' in os.environ, os.environ['HOME'], os.environ['ROS_DOMAIN_ID'])
open('written.txt', 'w').write('mine')
open('/dev/null', 'w').write('devices work')
print('dev null ok')
try:
    open({str(ROOT / "rosbook" / "labs" / "probes.py")!r}, "a")
except OSError as exc:
    print('read-only', exc.errno)
import rosbook.labs.probes
print("imports", rosbook.labs.probes.__name__)
"""
    result = run_inside(code, tmp_path, private, SECRET="grader-only")  # sandbox_env drops it
    out = result.stdout
    assert result.returncode == 0, out
    assert "uid 1000" in out
    assert f"cwd {sandbox.HOME}/lab ['given.txt']" in out
    assert "exists" not in out.replace("exists' if", ""), out
    assert f"False {sandbox.HOME} 7" in out
    assert "read-only 30" in out or "read-only 13" in out  # EROFS or EACCES
    assert "imports rosbook.labs.probes" in out and "dev null ok" in out
    assert not (tmp_path / "lab" / "written.txt").exists()


def test_the_runs_shared_folder_is_seen_read_only_and_only_it(tmp_path, private) -> None:
    """A folder the grader shares with a run's sandboxes (``SHARED_ENV``: lab 6's
    reference build) is seen at its own path, read-only, and its parent's other files
    (the template's gradebook) are not."""
    shared = tmp_path / "work" / "shared" / "lab"
    shared.mkdir(parents=True)
    (shared / "built.txt").write_text("the reference")
    for path in (shared, shared / "built.txt"):  # writable by anyone: but for the mount
        path.chmod(0o777)
    (tmp_path / "work" / "gradebook.db").write_text("hidden tests")
    code = f"""
import os
shared = os.environ[{sandbox.SHARED_ENV!r}]
print('reads', open(os.path.join(shared, 'built.txt')).read())
try:
    open(os.path.join(shared, 'built.txt'), 'a')
except OSError as exc:
    print('read-only', exc.errno)
print('gradebook', os.path.exists({str(tmp_path / "work" / "gradebook.db")!r}))
"""
    result = run_inside(code, tmp_path, private, **{sandbox.SHARED_ENV: str(shared)})
    assert result.returncode == 0, result.stdout
    assert "reads the reference" in result.stdout
    assert "read-only 30" in result.stdout  # EROFS
    assert "gradebook False" in result.stdout
    assert (shared / "built.txt").read_text() == "the reference"


def test_disk_memory_and_processes_are_limited(tmp_path, private) -> None:
    limits = sandbox.Limits(memory=1 << 30, processes=64, disk=32 << 20)
    code = """
import os, subprocess
try:
    with open('big', 'wb') as f:
        for _ in range(64):
            f.write(b'x' * (1 << 20))
except OSError as exc:
    print('disk full', exc.errno)
try:
    block = bytearray(3 << 30)
except MemoryError:
    print('memory refused')
children = []
try:
    for _ in range(200):
        children.append(subprocess.Popen(['sleep', '600']))
except OSError as exc:
    print('processes refused after', len(children), exc.errno)
"""
    out = run_inside(code, tmp_path, private, limits).stdout
    assert "disk full 28" in out  # ENOSPC
    assert "memory refused" in out
    assert "processes refused after" in out, out


def test_everything_in_the_sandbox_dies_with_it(tmp_path, private) -> None:
    token = uuid.uuid4().hex
    seed = tmp_path / "lab"
    seed.mkdir()
    escape = "import os, subprocess\nsubprocess.Popen(['sleep', '600'], start_new_session=True)\n"
    escape += "print('started', flush=True)\nimport time; time.sleep(600)\n"
    with sandbox.Network() as net:
        launch = sandbox.prepare(
            [sys.executable, "-c", escape],
            network=net,
            private=private,
            env={**ros_env(), RUN_MARKER: token},
            seed=seed,
        )
        proc, _ = sandbox.start(launch, stdout=subprocess.PIPE)
        assert proc.stdout is not None and proc.stdout.readline() == b"started\n"
        assert len(marked(token)) >= 2
        proc.kill()
        proc.wait()
        deadline = time.monotonic() + 60  # a hang guard: the kernel kills them at once
        while marked(token) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert marked(token) == []


ENTERED = """
import os, pathlib, signal, sys, time
print(os.getuid(), os.getpid() < 100, pathlib.Path('written').read_text(), flush=True)
print(sorted(k for k in os.environ if 'SECRET' in k), flush=True)
signal.signal(signal.SIGINT, lambda *_: sys.exit(3))
print('waiting', flush=True)
time.sleep(600)
"""


# a program entered into a sandbox is checked in the fast tier by test_cgroups'
# test_a_program_entered_into_a_sandbox_joins_its_cgroup
@pytest.mark.slow
def test_a_trusted_process_runs_a_program_inside_a_running_sandbox(tmp_path, private) -> None:
    """``enter_argv``: the student's program runs as the student, in the sandbox's
    folders and PIDs, without the grader's environment; Ctrl-C reaches it and its exit
    code comes back."""
    seed = tmp_path / "lab"
    seed.mkdir()
    stay = "import pathlib, time\npathlib.Path('written').write_text('by the kernel')\n"
    stay += "print('ready', flush=True)\ntime.sleep(600)\n"
    with sandbox.Network() as net:
        launch = sandbox.prepare(
            [sys.executable, "-c", stay], network=net, private=private, env=ros_env(), seed=seed
        )
        kernel, pid = sandbox.start(launch, stdout=subprocess.PIPE)
        try:
            assert kernel.stdout is not None and kernel.stdout.readline() == b"ready\n"
            program = subprocess.Popen(
                sandbox.enter_argv(pid, f"{sandbox.HOME}/lab", [sys.executable, "-c", ENTERED]),
                env={**ros_env(), "GRADER_SECRET": "hidden"},
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                text=True,
            )
            assert program.stdout is not None
            lines = [program.stdout.readline() for _ in range(3)]
            assert lines == [f"{sandbox.UID} True by the kernel\n", "[]\n", "waiting\n"], lines
            program.send_signal(signal.SIGINT)
            assert program.wait(timeout=120) == 3
        finally:
            kernel.kill()
            kernel.wait()


def marked(token: str) -> list[int]:
    needle = f"{RUN_MARKER}={token}".encode()
    found = []
    for proc in Path("/proc").glob("[0-9]*"):
        try:
            if needle in proc.joinpath("environ").read_bytes().split(b"\0"):
                found.append(int(proc.name))
        except OSError:
            pass
    return found


@pytest.mark.slow
def test_a_trusted_process_joins_the_sandbox_network_and_nobody_else_hears_it(
    tmp_path, private
) -> None:
    """DDS on the sandbox's own loopback: the trusted listener on its network hears
    the sandboxed publisher; a listener on the host and one in another sandbox, all
    in the same ROS domain, hear nothing."""
    seed = tmp_path / "lab"
    seed.mkdir()
    os.chmod(private, 0o711)  # holds two sandboxes' folders
    with sandbox.Network() as net, sandbox.Network() as other:
        launch = sandbox.prepare(
            [sys.executable, "-c", PUBLISH],
            network=net,
            private=private / "a",
            env=ros_env(),
            seed=seed,
        )
        publisher, _ = sandbox.start(launch, stdout=subprocess.DEVNULL)
        try:
            launch = sandbox.prepare(
                [sys.executable, "-c", LISTEN, "20"],
                network=other,
                private=private / "b",
                env=ros_env(),
                seed=seed,
            )
            outsider_sandbox, _ = sandbox.start(launch, stdout=subprocess.PIPE, text=True)
            host = subprocess.Popen(
                [sys.executable, "-c", LISTEN, "20"],
                env=ros_env(),
                stdout=subprocess.PIPE,
                text=True,
            )
            trusted = subprocess.run(
                net.join_argv([sys.executable, "-c", LISTEN, "240"]),
                env=ros_env(),
                capture_output=True,
                text=True,
                timeout=300,
            )
            # the last line is the listener's (Fast DDS may log before it)
            assert trusted.stdout.splitlines()[-1] == "from the sandbox", trusted.stderr
            assert host.communicate(timeout=300)[0].splitlines()[-1] == "nothing heard"
            assert outsider_sandbox.communicate(timeout=300)[0].splitlines()[-1] == "nothing heard"
        finally:
            publisher.kill()
            publisher.wait()


def test_without_user_namespaces_the_error_names_the_fix(tmp_path, private) -> None:
    """A machine that forbids user namespaces gets SandboxUnavailable, never a kernel."""
    probe = (
        "from autograder import sandbox\n"
        "try:\n    sandbox.Network()\nexcept sandbox.SandboxUnavailable as exc:\n    print(exc)\n"
    )
    limit_then_probe = (
        "echo 0 > /proc/sys/user/max_user_namespaces && exec " + sys.executable + ' -c "$0"'
    )
    result = subprocess.run(
        ["unshare", "--user", "--map-root-user", "sh", "-c", limit_then_probe, probe],
        capture_output=True,
        text=True,
        timeout=120,
    )
    if "max_user_namespaces" in result.stderr and "Permission denied" in result.stderr:
        pytest.skip("cannot forbid user namespaces in a child namespace here")
    assert "unprivileged user namespaces" in result.stdout, result.stdout + result.stderr
    assert "never run unsandboxed" in result.stdout


def test_a_network_is_joinable_once_made() -> None:
    """bwrap tells its process's pid before that process has made its mounts; a process
    joining the network then found an empty root (a course server's first spawn, on a
    busy machine: "No such file or directory" for its working folder). A ``Network`` is
    returned only once its holder runs its command, with every mount made."""
    for _ in range(10):
        with sandbox.Network() as network:
            command = Path(f"/proc/{network.pid}/cmdline").read_bytes().split(b"\0")
            assert command[:2] == [b"/bin/sh", b"-c"], command
            assert Path(f"/proc/{network.pid}/root{ROOT}").is_dir()
