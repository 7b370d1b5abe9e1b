"""The kernel manager the grader and the self-check run notebooks with: sandboxed.

Every kernel runs in a sandbox (``autograder/sandbox.py``) with a cgroup of its own
(``c.IpcKernelManager.cpus`` and ``.ram`` in the nbgrader config override its CPU quota
and memory limit, ``Limits.cpus`` and ``Limits.ram`` by default): the notebook's folder is
copied into the sandbox's home, and the kernel sees nothing of the grader's. It talks
to the grader over Unix sockets (``ipc``; TCP would need the grader inside the
sandbox's network): the kernel binds them in a small tmpfs of its own
(``/run/kernel``), and the grader reaches them through ``/proc/<sandbox>/root``, so
nothing the kernel can write lives on the host's disk. A folder of the grader's own
(``rosbook-kernel-*``, never visible inside) holds the connection files and a link to
the sockets. Interrupts are sent as messages: a signal would reach ``bwrap``, not the
kernel.

A cell that leaves its sandbox at its process limit (``Limits.processes``), say by
starting hundreds of programs and keeping them, leaves the kernel no room for a thread:
every later cell and check would hang until the submission's time runs out. Before each
cell, such a sandbox's other processes are ended (the kernel kept; it reaps them) and
``REAPED`` says how many, for the feedback.

``CappedExecute`` is nbgrader's ``Execute`` keeping at most ``Limits.output`` bytes of
output per cell, so a cell that prints 200 MB neither fills the grader's memory nor
the feedback page.

A kernel takes more than half a second to start (a Python interpreter, ipykernel),
during which a submission's grading would only wait. A grading worker that knows the
environment of its next submission (``expect_next``) has ``CappedExecute`` start that
submission's kernel at the end of this one's run: a fresh kernel in a fresh sandbox on
a network of its own, started with the next submission's environment (its ROS domain
and run token) in an empty folder of the notebook folder's name. Nothing of this
submission reaches it. The next submission adopts it (``adopt_spare``): its files are
copied in as the sandbox's start would have copied them (``sandbox.seed_late``), and its
kernel runs in it. A spare that does not fit (another environment, kernel or folder
name) or did not survive is shut down, and a kernel is started as usual.
"""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from jupyter_core.utils import run_sync
from nbformat import NotebookNode
from nbformat.v4 import new_code_cell, new_output
from nbgrader.preprocessors import Execute
from traitlets import Bool, Float, Integer, default

from autograder import cgroups, sandbox
from autograder.feedback import cell_name
from rosbook.runtime.kernels import AsyncUnixSocketKernelManager

#: Inside the sandbox: where the kernel's sockets and connection file are.
KERNEL_DIR = "/run/kernel"
#: Processes ended that way in this process's sandboxes (the worker reads it per job).
REAPED: list[int] = []
#: Bytes of the kernel's own stdout/stderr (not a cell's output) kept in the log.
KERNEL_LOG_MAX = 64 << 10


def _copy_capped(stream: Any, limit: int) -> None:
    """Copy the kernel's raw output to the grader's log, ``limit`` bytes at most."""
    kept = 0
    for chunk in iter(lambda: stream.read1(65536), b""):
        if kept < limit:
            sys.stderr.write(chunk[: limit - kept].decode(errors="replace"))
            sys.stderr.flush()
            kept += len(chunk)
    stream.close()


class IpcKernelManager(AsyncUnixSocketKernelManager):
    """An ``AsyncKernelManager`` whose kernel runs sandboxed, on Unix sockets (in its
    private folder, a link to the sandbox's tmpfs where the kernel binds them)."""

    #: The kernel's working folder seen from outside its sandbox (set once started).
    sandbox_folder: str | None = None
    #: The sandbox's first process, by which a trusted process enters it (``enter_argv``).
    sandbox_pid: int | None = None
    #: The sandbox's cgroup (None where cgroups cannot be made: ``autograder.cgroups``).
    cgroup: cgroups.Cgroup | None = None
    #: The network to start the kernel on (default: ``sandbox.current_network()``, else
    #: one of its own).
    network: sandbox.Network | None = None

    cpus = Float(
        sandbox.Limits.cpus, config=True, help="CPUs of each kernel's sandbox (its cgroup's quota)."
    )
    ram = Integer(
        sandbox.Limits.ram,
        config=True,
        help="Memory of each kernel's sandbox (bytes; OOM past it).",
    )

    processes = Integer(
        sandbox.Limits.processes,
        config=True,
        help="Processes and threads of each kernel's sandbox (its cgroup's pids.max).",
    )

    @property
    def limits(self) -> sandbox.Limits:
        return sandbox.Limits(cpus=self.cpus, ram=self.ram, processes=self.processes)

    def private_parent(self) -> str:
        # the sandbox's user enters it (a private TMPDIR would stop bwrap: staging_base)
        return sandbox.staging_base()

    @default("ip")
    def _ip_default(self) -> str:
        # "sockets" becomes a link to /proc/<sandbox>/root/run/kernel once it started
        return str(Path(self.connection_file).parent / "sockets" / "k")

    async def _async_pre_start_kernel(self, **kw: Any) -> tuple[list[str], dict[str, Any]]:
        kernel_cmd, kw = await super()._async_pre_start_kernel(**kw)
        assert self.kernel_spec is not None
        self.kernel_spec.interrupt_mode = "message"
        return kernel_cmd, kw

    async def _async_launch_kernel(self, kernel_cmd: list[str], **kw: Any) -> None:
        private = Path(self.connection_file).parent
        network = self.network or sandbox.current_network()
        self._own_network = None if network is not None else sandbox.Network()
        network = network or self._own_network
        inside = dict(json.loads(Path(self.connection_file).read_text()), ip=f"{KERNEL_DIR}/k")
        inside_file = private / "inside.json"
        inside_file.write_text(json.dumps(inside))
        os.chmod(inside_file, 0o644)
        cmd = [
            f"{KERNEL_DIR}/kernel.json" if arg == self.connection_file else arg
            for arg in kernel_cmd
        ]
        # ipykernel rewrites its connection file: it gets a copy in its tmpfs
        cmd = [
            "/bin/sh",
            "-c",
            f'cp /run/rosbook/kernel.json {KERNEL_DIR}/kernel.json && exec "$@"',
            "sh",
            *cmd,
        ]
        seed = kw.pop("cwd", None)
        launch = sandbox.prepare(
            cmd,
            network=network,
            private=private,
            env=kw.pop("env", None) or os.environ,
            seed=seed,
            limits=self.limits,
            tmpfs=[KERNEL_DIR],
            files={"/run/rosbook/kernel.json": inside_file},
            label="kernel",
        )
        kw.update(
            env=launch.env,
            pass_fds=launch.pass_fds,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            cwd="/",
        )
        self.cgroup = launch.cgroup
        try:
            await super()._async_launch_kernel(launch.argv, **kw)
        finally:
            launch.close_fds()
        proc = self.provisioner.process  # type: ignore[union-attr]
        threading.Thread(
            target=_copy_capped, args=(proc.stdout, KERNEL_LOG_MAX), daemon=True
        ).start()
        pid = self.sandbox_pid = sandbox.sandbox_pid(launch, proc)
        os.symlink(f"/proc/{pid}/root{KERNEL_DIR}", private / "sockets")
        #: The kernel's working folder as the grader (and its judge) see it from outside.
        self.sandbox_folder = (
            f"/proc/{pid}/root{sandbox.HOME}/{Path(seed).name}" if seed is not None else None
        )

    async def _async_cleanup_resources(self, restart: bool = False) -> None:
        await super()._async_cleanup_resources(restart)
        if self.cgroup is not None:  # the kernel has ended
            await asyncio.to_thread(self.cgroup.remove)
            self.cgroup = None
        if getattr(self, "_own_network", None) is not None:
            self._own_network.close()
            self._own_network = None

    _launch_kernel = _async_launch_kernel  # type: ignore[assignment]
    cleanup_resources = _async_cleanup_resources  # type: ignore[assignment]

    def seed(self, folder: str) -> None:
        """Copy ``folder`` into this running kernel's (empty) working folder, as its
        start copies a seed (``sandbox.seed_late``); raises if that failed."""
        if self.sandbox_pid is None or self.sandbox_folder is None:
            raise RuntimeError("the kernel has no sandbox folder to seed")
        folder = str(Path(folder).resolve())
        if Path(self.sandbox_folder).name != Path(folder).name:
            raise RuntimeError(f"the kernel works in {self.sandbox_folder}, not in {folder}")
        sandbox.seed_late(self.sandbox_pid, self._private, folder, self.limits)


@dataclass
class Spare:
    """A kernel started ahead for the next submission, on a network of its own."""

    km: IpcKernelManager
    env: dict[str, str]
    network: sandbox.Network


#: What the grader's log says when a notebook runs in a kernel started ahead.
STARTED_AHEAD = "the notebook runs in the kernel started ahead for it"
#: The environment of this worker's next submission, once it is known (``expect_next``).
_next_env: dict[str, str] | None = None
#: The kernel started for the next submission; ``adopt_spare`` hands it over.
_spare: Spare | None = None
#: The spare this submission adopted, until its notebook runs (``CappedExecute``).
_adopted: Spare | None = None


def expect_next(env: dict[str, str] | None) -> None:
    """Start a kernel in ``env`` (besides this process's environment) for the next
    submission at the end of the notebook run that comes now; None: start none."""
    global _next_env
    _next_env = dict(env) if env else None


def adopt_spare(env: dict[str, str]) -> sandbox.Network | None:
    """The network of the kernel started ahead for a submission in ``env``, now the
    caller's to close; the notebook run that comes next uses that kernel. None when
    there is no such kernel (one for another environment is shut down)."""
    global _spare, _adopted
    spare, _spare = _spare, None
    if spare is None:
        return None
    if spare.env != env or not run_sync(spare.km.is_alive)():
        _discard(spare)
        return None
    _adopted = spare
    return spare.network


def drop_adopted() -> None:
    """Shut down the kernel ``adopt_spare`` handed over if no notebook run used it
    (nbgrader stopped before); its network is the caller's."""
    global _adopted
    if _adopted is not None:
        run_sync(_shut_down)(_adopted.km)
        _adopted = None


def discard_spare() -> None:
    """Shut down the kernel started ahead (the worker has no next submission)."""
    global _spare
    if _spare is not None:
        _discard(_spare)
        _spare = None


def _discard(spare: Spare) -> None:
    run_sync(_shut_down)(spare.km)
    spare.network.close()


async def _shut_down(km: IpcKernelManager) -> None:
    try:
        await km.shutdown_kernel(now=True)
    except RuntimeError:  # it has ended already
        await km.cleanup_resources()


def end_strays(first: int) -> list[int]:
    """End every process below the sandbox's first one (bwrap's PID 1) but the oldest,
    the kernel; their PIDs inside the sandbox (the kernel must reap its children)."""
    below = sandbox.process_tree(first)
    if not below:
        return []
    kernel = min(below, key=lambda pid: int(below[pid]))
    ended = []
    for pid in set(below) - {kernel}:
        try:
            status = Path(f"/proc/{pid}/status").read_text()
            os.kill(pid, signal.SIGKILL)
        except (ProcessLookupError, FileNotFoundError):
            continue
        inner = [line.split()[-1] for line in status.splitlines() if line.startswith("NSpid:")]
        ended += [int(inner[0])] if inner else []
    return ended


#: Run in the kernel: reap the ended children whose PIDs (inside) it is given.
REAP = (
    "import os as _os\nfor _pid in {pids!r}:\n    try:\n        _os.waitpid(_pid, 0)\n"
    "    except ChildProcessError:\n        pass\ndel _os, _pid\n"
)


#: The error a cell shows when it was not run: the kernel was still busy with a cell
#: interrupted at the time limit (``CappedExecute.busy_with``).
NOT_RUN = "CellNotRun"


def not_run_output(busy_with: str, cell_timeout: float) -> NotebookNode:
    evalue = (
        f"not run: the kernel was still busy with {busy_with}, which ran past the "
        f"{cell_timeout:g} s limit and had not stopped {cell_timeout:g} s after it was "
        "interrupted"
    )
    return new_output("error", ename=NOT_RUN, evalue=evalue, traceback=[f"{NOT_RUN}: {evalue}"])


class CappedExecute(Execute):  # type: ignore[misc]
    """nbgrader's ``Execute`` keeping at most ``max_output_bytes`` of output per cell,
    and running no more cells once an interrupted one keeps the kernel busy.

    A cell past the time limit is interrupted, and is given the limit once more to
    stop (a launch shutting down, a spin woken by its next timer). A cell still running
    after that never lets the kernel take another request (``rclpy.spin`` of a node
    with only a subscription: rcl's wait is not woken by the interrupt), so the later
    cells are not sent to it, each waiting out the limit: they show ``NOT_RUN`` at once
    (``busy_with`` names the cell), and the kernel is ended with the notebook."""

    max_output_bytes = Integer(sandbox.Limits().output).tag(config=True)
    # A cell that printed far more than it keeps leaves its output queued after its
    # reply; the cut output is dropped and the notebook goes on (nbgrader would abandon
    # the whole notebook: 0 points earned elsewhere).
    raise_on_iopub_timeout = Bool(False).tag(config=True)
    #: The cell the kernel is still busy with, interrupted and not stopped; None.
    busy_with: str | None = None
    _interrupted = False
    _still_busy = False

    async def _async_handle_timeout(
        self, timeout: int, cell: NotebookNode | None = None
    ) -> None | dict[str, Any]:
        reply = await super()._async_handle_timeout(timeout, cell)
        # nbclient then waits ``iopub_timeout`` for the interrupted cell's end: the limit
        self._interrupted, self.iopub_timeout = True, max(self.iopub_timeout, timeout)
        return reply  # type: ignore[no-any-return]

    async def _async_poll_for_reply(
        self,
        msg_id: str,
        cell: NotebookNode,
        timeout: int | None,
        task_poll_output_msg: asyncio.Future[Any],
        task_poll_kernel_alive: asyncio.Future[Any],
    ) -> dict[str, Any]:
        iopub_timeout, self._interrupted = self.iopub_timeout, False
        try:
            reply = await super()._async_poll_for_reply(
                msg_id, cell, timeout, task_poll_output_msg, task_poll_kernel_alive
            )
        finally:
            self.iopub_timeout = iopub_timeout
        # its end (the kernel's "idle") never came: the wait for it was cancelled
        self._still_busy = self._interrupted and task_poll_output_msg.cancelled()
        return reply  # type: ignore[no-any-return]

    @default("shutdown_kernel")
    def _shutdown_kernel_default(self) -> str:
        # Once the last cell has run, nothing of the kernel is kept: it is ended at once
        # rather than asked to exit (0.2-0.3 s of every submission's grading).
        return "immediate"

    async def async_start_new_kernel(self, **kwargs: Any) -> None:
        """The kernel started ahead for this submission (``adopt_spare``) when it fits
        and takes this notebook's folder, else a new one."""
        global _adopted
        spare, _adopted = _adopted, None
        if spare is not None:
            folder = kwargs.get("cwd") or self.resources.get("metadata", {}).get("path")
            try:
                if spare.km.kernel_name != self.km.kernel_name or not folder:
                    raise RuntimeError(f"kernel {spare.km.kernel_name}, folder {folder}")
                await asyncio.to_thread(spare.km.seed, str(folder))
            except (RuntimeError, OSError, subprocess.SubprocessError) as exc:
                self.log.warning("The kernel started ahead is not used: %s", exc)
                await _shut_down(spare.km)  # its network is the submission's now
            else:
                unused = self.km
                self.km = spare.km
                if getattr(unused, "_private", None) is not None:
                    shutil.rmtree(unused._private, ignore_errors=True)
                print(f"[grader] {STARTED_AHEAD}", flush=True)
                return
        await super().async_start_new_kernel(**kwargs)

    async def _async_cleanup_kernel(self) -> None:
        global _next_env, _spare
        env, _next_env = _next_env, None
        if env is not None and self.km is not None:
            _spare = await self._start_spare(env)
        await super()._async_cleanup_kernel()

    async def _start_spare(self, env: dict[str, str]) -> Spare | None:
        """A kernel like this one's, started for the next submission (``expect_next``)."""
        assert self.km is not None
        folder = self.resources.get("metadata", {}).get("path") or "."
        km = type(self.km)(kernel_name=self.km.kernel_name, config=self.config)
        km.network = network = sandbox.Network()
        empty = Path(tempfile.mkdtemp(prefix="rosbook-spare-")) / Path(folder).resolve().name
        empty.mkdir()
        try:
            await km.start_kernel(
                extra_arguments=self.extra_arguments, cwd=str(empty), env={**os.environ, **env}
            )
        except Exception as exc:  # noqa: BLE001 - the next submission starts its own
            self.log.warning("No kernel could be started ahead: %s", exc)
            await km.cleanup_resources()
            network.close()
            return None
        finally:
            shutil.rmtree(empty.parent, ignore_errors=True)
        return Spare(km, dict(env), network)

    # nbclient's blocking forms, made from its own coroutines: made again from these
    start_new_kernel = run_sync(async_start_new_kernel)
    _cleanup_kernel = run_sync(_async_cleanup_kernel)

    def preprocess_cell(
        self, cell: NotebookNode, resources: dict[str, Any], index: int
    ) -> tuple[NotebookNode, dict[str, Any]]:
        if self.busy_with is not None:
            if cell.cell_type == "code" and cell.source.strip():
                cell.outputs, cell.execution_count = (
                    [not_run_output(self.busy_with, self.timeout)],
                    None,
                )
            return cell, resources
        self.make_room(resources, index)
        cell, resources = super().preprocess_cell(cell, resources, index)
        if self._still_busy:
            self.busy_with = cell_name(cell, index)
        return cell, resources

    def make_room(self, resources: dict[str, Any], index: int) -> None:
        """A sandbox left at its process limit by the cells so far: end its other
        processes and have the kernel reap them (a cell of its own, not kept)."""
        group, first = getattr(self.km, "cgroup", None), getattr(self.km, "sandbox_pid", None)
        try:
            if group is None or first is None or not group.full():
                return
        except (FileNotFoundError, ValueError):
            return
        ended = end_strays(first)
        if ended:
            REAPED.append(len(ended))
            reap = new_code_cell(REAP.format(pids=ended))
            super().preprocess_cell(reap, resources, index)

    def output(
        self, outs: list[NotebookNode], msg: dict[str, Any], display_id: str | None, cell_index: int
    ) -> NotebookNode | None:
        used: dict[int, int] = self.__dict__.setdefault("_output_bytes", {})
        size = len(json.dumps(msg.get("content", {})))
        if used.get(cell_index, 0) + size <= self.max_output_bytes:
            used[cell_index] = used.get(cell_index, 0) + size
            return super().output(outs, msg, display_id, cell_index)  # type: ignore[no-any-return]
        if used.get(cell_index) != -1:  # the first output past the cap: say so, once
            used[cell_index] = -1
            text = f"\n[output truncated: a cell keeps at most {self.max_output_bytes} bytes]\n"
            outs.append(new_output("stream", name="stdout", text=text))
        return None
