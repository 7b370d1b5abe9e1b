"""The course server's pieces: each student's JupyterLab in a sandbox, and the roster.

``make hub`` runs JupyterHub with ``coursehub/jupyterhub_config.py``, which uses:

- ``SandboxSpawner``: a student's single-user server runs in the grader's sandbox
  (``autograder.sandbox``: its own user, PID, IPC and mount namespaces, the system and
  the venv read-only, per-process memory and process limits, and a cgroup of its own:
  ``SandboxSpawner.cpus`` CPUs and ``.ram`` bytes for everything the student runs,
  ``.processes`` tasks; ``autograder.cgroups``) on a ``Network`` of its
  own: a loopback only, so ROS traffic never crosses students, whatever their
  ``ROS_DOMAIN_ID``. The student's home is their own folder on the host
  (``home_dir_template``) bound at ``/home/student``; no other student's folder exists
  in the sandbox. When the hub is root, that folder is a disk of its own while the
  server runs (``coursehub.homes``: ``HOME_QUOTA`` bytes, ``SandboxSpawner.quota``).
- **Root never follows a student's link.** Everything below the hub's own folders (a
  home, an exchange, a socket folder) is the student's, who can put a symbolic link
  anywhere in it at any moment. The hub's file work there goes through
  ``coursehub.safefs`` (descriptors, ``O_NOFOLLOW``, ``fchown``, rename into place):
  a link where a file or folder is expected is refused, named in the log (the hub's,
  or the instructor's command's standard error), never followed; the relay connects
  only to a socket of the server's user, never through a link.
- **Crossing the network namespace.** Nothing outside reaches the sandbox's loopback
  and the server reaches nothing outside, so both ways go through unix sockets, which
  are files (``coursehub.relay``): the server listens on ``/run/hub/jupyter.sock``
  (a per-student host folder bound there) and a relay in the hub process gives the
  proxy and the hub a TCP port on the host's loopback for it; the server calls the hub's
  API at its usual address, where a relay joined to the sandbox's network
  (``Network.join_argv``, outside the sandbox otherwise) listens and pipes to a unix
  socket the hub process serves, out of the student's reach.
- Stopping a server kills its sandbox (its PID namespace ends with its first process)
  and its network; bwrap and the network holder die with the hub too
  (``--die-with-parent``), and the joined relay ends when its standard input closes.
  SIGTERM or SIGINT to the hub stops every server, then the proxy; ``make hub`` execs
  the hub, which also stops when make ends (``stop_with_parent``), and the hub's exit
  releases whatever a stop cut short left (``/tmp/rosbook-hub-NAME-*``, mounts).
- **The nbgrader exchange.** nbgrader's shared exchange folder relies on Unix users and
  file modes to keep students apart; here every student is the same uid, so one shared
  folder would let any student read (or overwrite) another's submission. Instead each
  student has an exchange of their own (``exchange/NAME``, bound at nbgrader's default
  ``/srv/nbgrader/exchange``), and only the hub's side, which sees them all, crosses
  between them: ``release`` copies a lab into every student's ``outbound``,
  ``collect`` copies each student's latest submission (by the time in its name) from
  their ``inbound`` into the grader's ``SUBMISSIONS/NAME/LAB/`` under their roster
  name (inside, everyone is "student"): folders and regular files only, at most the
  grader's ``MAX_NOTEBOOK_BYTES`` in all; and ``feedback`` puts the grader's feedback
  for each student into that student's ``feedback`` only, named as nbgrader's
  ``fetch_feedback`` looks for it (the hash of their submission's secret and the
  notebook). Students use the Assignments tab (or ``nbgrader fetch_assignment/validate/
  submit/fetch_feedback``) as on any nbgrader course; the instructor runs ``python -m
  coursehub.hub release|collect|feedback`` and ``python -m autograder grade``.
- ``RosterAuthenticator``: each student and instructor has a password of their own
  (``python -m coursehub.hub add NAME [--instructor]`` prints it; only its scrypt hash
  is kept); instructors are the hub's admins. Wrong passwords are throttled per
  username and per address (``LOGIN_THROTTLE``).
"""

from __future__ import annotations

import asyncio
import atexit
import contextlib
import ctypes
import datetime
import hashlib
import hmac
import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import urlparse, urlunparse

import psutil
from jupyterhub.auth import Authenticator
from jupyterhub.proxy import ConfigurableHTTPProxy
from jupyterhub.spawner import SimpleLocalProcessSpawner
from nbgrader.utils import notebook_hash, parse_utc
from traitlets import Float, Integer, Unicode
from traitlets.config.loader import PyFileConfigLoader

from autograder import preflight
from autograder.cgroups import Cgroup
from autograder.sandbox import HOME, NOBODY, Limits, Network, prepare, staging_base, start
from autograder.worker import MAX_NOTEBOOK_BYTES
from coursehub import homes, relay, safefs
from rosbook import jupyter_assignments
from rosbook.runtime.isolation import BASE_ENV

ROOT = Path(__file__).resolve().parent.parent
#: Inside each sandbox: the folder holding the server's socket.
RUN = "/run/hub"
#: nbgrader's exchange inside each sandbox (its default root).
EXCHANGE = "/srv/nbgrader/exchange"
#: The course's id, from the course's nbgrader configuration.
COURSE = str(
    PyFileConfigLoader("nbgrader_config.py", path=str(ROOT / "autograder"))
    .load_config()
    .CourseDirectory.course_id
)
#: nbgrader's instructor tools (JupyterLab plugins), off in students' servers.
INSTRUCTOR_TOOLS = ("formgrader", "course-list", "create-assignment")
#: Server extensions off in students' servers (memory: an idle student's server
#: was 150 MB): nbgrader's instructor side; jupyter_lsp (no language server is
#: installed); jupytext (labs are notebooks: its JupyterLab plugin goes too);
#: notebook_shim (for classic-notebook extensions: none here). What the labs use stays:
#: terminals, the proxy for live 3D views, and nbgrader's Assignments tab and validate,
#: whose imports wait for their first use (``rosbook.jupyter_assignments``, on instead).
STUDENT_OFF = (
    "nbgrader.server_extensions.formgrader",
    "nbgrader.server_extensions.course_list",
    *jupyter_assignments.EXTENSIONS,
    "jupyter_lsp",
    "jupyterlab_jupytext",
    "notebook_shim",
    "notebook",
)
#: The server's socket, in its socket folder (``RUN`` inside).
SOCKET = "jupyter.sock"
#: nbgrader's ``submit`` writes it into each submission: feedback is found by it.
SECRET = "submission_secret.txt"
#: Who a sandbox is outside, given what the hub makes in a student's folders: nobody
#: when the hub is root; None (the hub's own user, who makes them) otherwise.
OUTSIDE = (NOBODY, NOBODY) if os.geteuid() == 0 else None
#: Each student's home is a disk of its own of this size (``coursehub.homes``: at the
#: limit, JupyterLab's save says "No space left on device"); the hub's config sets
#: another (``SandboxSpawner.quota``, ``ROSBOOK_HUB_QUOTA_MB``), 0 for no limit.
HOME_QUOTA = 1 << 30
#: prctl's option: the signal a process gets when its parent ends.
PR_SET_PDEATHSIG = 1
#: A hang guard for a relay or a server to come up (a loaded machine is slow).
START_TIMEOUT = 120.0


def state_dir() -> Path:
    """The hub's state (roster, database, homes): ``ROSBOOK_HUB_DIR`` or ``.hub/``."""
    return Path(os.environ.get("ROSBOOK_HUB_DIR", ROOT / ".hub")).resolve()


def _in_netns(url: str, port: int) -> str:
    """``url`` with its host the sandbox's loopback (where the joined relay listens)."""
    parts = urlparse(url)
    return urlunparse(parts._replace(netloc=f"127.0.0.1:{port}"))


class SandboxSpawner(SimpleLocalProcessSpawner):  # type: ignore[misc]
    """A LocalProcessSpawner whose command runs in the sandbox, on a network of its own."""

    memory = Integer(Limits.memory, config=True, help="Address space of each process (bytes).")
    processes = Integer(Limits.processes, config=True, help="Processes and threads.")
    cpus = Float(1.0, config=True, help="CPUs of a student's sandbox (its cgroup's quota).")
    ram = Integer(1 << 30, config=True, help="Memory of a student's sandbox (bytes).")
    disk = Integer(Limits.disk, config=True, help="Size of the sandbox's /tmp (bytes).")
    quota = Integer(
        HOME_QUOTA, config=True, help="Size of each student's home (bytes; 0: no limit)."
    )
    run_dir = Unicode(
        str(ROOT / ".hub" / "run"), config=True, help="Host folder of per-student sockets."
    )
    jupyter_config = Unicode(
        str(ROOT / "rosbook" / "jupyterlab_config.py"),
        config=True,
        help="The single-user server's config file (make lab's: terminals with ros2).",
    )

    _proc: subprocess.Popen[bytes] | None = None
    _network: Network | None = None
    _joined: subprocess.Popen[bytes] | None = None
    _cgroup: Cgroup | None = None
    _relays: list[asyncio.AbstractServer]
    _private = ""  # the sandbox's generated files (autograder.sandbox.prepare)
    _server_pid = 0  # the sandbox's first process, seen from the hub
    _mounted = ""  # the home, while its disk (coursehub.homes) is mounted
    _running: set[SandboxSpawner] = set()  # every server not yet released

    def _limits(self) -> Limits:
        return Limits(
            memory=self.memory,
            processes=self.processes,
            disk=self.disk,
            cpus=self.cpus,
            ram=self.ram,
        )

    async def _join_relay(self, listen: str, connect: str) -> subprocess.Popen[bytes]:
        assert self._network is not None
        # The relay needs only the standard library: -I -S skip site-packages' start-up
        # hooks (the ROS wheels' bootstrap among them), about 1 MB per student.
        relay_argv = [sys.executable, "-I", "-S", relay.__file__, listen, connect]
        argv = self._network.join_argv(relay_argv)
        proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE, cwd=ROOT)
        assert proc.stdout is not None
        try:
            line = await asyncio.wait_for(
                asyncio.to_thread(proc.stdout.readline), timeout=START_TIMEOUT
            )
        except asyncio.TimeoutError as exc:
            proc.kill()
            raise RuntimeError(
                f"relay in the sandbox's network: timeout after {START_TIMEOUT} s"
            ) from exc
        if not line.startswith(b"ready"):
            raise RuntimeError(f"relay in the sandbox's network failed (exit {proc.poll()})")
        return proc

    def _nbgrader_settings(self, home: Path) -> None:
        """The student's nbgrader settings: made once (theirs to change), never through
        a link, even a dangling one (``safefs.Refused``)."""
        nbgrader = f"c.CourseDirectory.course_id = {COURSE!r}\nc.Exchange.root = {EXCHANGE!r}\n"
        with safefs.folder(home, ".jupyter", create=True, owner=OUTSIDE) as fd:
            there = home / ".jupyter" / "nbgrader_config.py"
            safefs.create(fd, there.name, nbgrader.encode(), there, OUTSIDE)

    def _page_settings(self, home: Path) -> None:
        """A student's JupyterLab page settings, without the instructor's tools: written
        at each start, replacing what is there, never through a link."""
        if self.user.admin:  # the instructor's tools are the instructor's
            return
        disabled = {f"@jupyter/nbgrader:{name}": True for name in INSTRUCTOR_TOOLS}
        disabled["jupyterlab-jupytext"] = True
        # No build check: JupyterLab would start node (``yarn config``, ~50 MB) at each
        # login to offer a build nobody can run (the venv is read-only here).
        page = {"disabledExtensions": disabled, "buildCheck": False, "buildAvailable": False}
        there = home / ".jupyter" / "labconfig" / "page_config.json"
        with safefs.folder(home, ".jupyter", "labconfig", create=True, owner=OUTSIDE) as fd:
            safefs.write(fd, there.name, json.dumps(page).encode(), there, OUTSIDE)

    async def start(self) -> tuple[str, int]:  # type: ignore[override]
        try:
            return await self._start()
        except BaseException:
            await self.stop(now=True)  # nothing of a failed start stays behind
            raise

    async def _start(self) -> tuple[str, int]:
        # A server whose kernels cannot start here fails its spawn with the cause and the
        # fix (autograder.preflight.NotReady), before anything is made for the student.
        await asyncio.to_thread(preflight.once)
        # Everything below the hub's own folders (home/NAME, exchange/NAME, the socket
        # folder) is the student's: made and written with coursehub.safefs, never
        # through a link, and given to the sandbox's outside user by descriptor.
        home = Path(self.home_dir)
        home.mkdir(parents=True, exist_ok=True)
        with safefs.folder(home) as fd:
            safefs.give(fd, OUTSIDE)
        if self.quota:
            if why := homes.available():
                self.log.warning("%s: a home without a size limit: %s", self.user.name, why)
            else:
                image = state_dir() / "quota" / f"{self.user.name}.ext4"
                await asyncio.to_thread(homes.mount, home, image, self.quota, (NOBODY, NOBODY))
                self._mounted = str(home)
        run = Path(self.run_dir) / self.user.name
        server_dir = run / "server"
        server_dir.mkdir(parents=True, exist_ok=True)
        (run / "hub.sock").unlink(missing_ok=True)  # run/NAME is the hub's alone
        with safefs.folder(server_dir) as fd:
            safefs.give(fd, OUTSIDE)
            with contextlib.suppress(FileNotFoundError):
                os.unlink(SOCKET, dir_fd=fd)  # unlink removes a link, never its target
        exchange = state_dir() / "exchange" / self.user.name
        for making in (
            lambda: _exchange(self.user.name),
            lambda: self._nbgrader_settings(home),
            lambda: self._page_settings(home),
        ):
            try:  # a student's own link breaks only their own settings: named, not followed
                making()
            except (safefs.Refused, OSError) as exc:  # or a full home: said, not fatal
                self.log.warning("%s: %s", self.user.name, exc)
        env = self.get_env()
        env.update(BASE_ENV)  # the course's ROS settings (log lines on stdout, as graded)
        hub = urlparse(self.hub.api_url)
        hub_port = hub.port or 80
        self._relays = []
        self._network = Network()
        # the server -> the hub's API: joined relay (in the sandbox's network) -> unix
        # socket -> the hub process -> the hub's API on the host
        self._relays.append(
            await relay.serve(f"unix:{run / 'hub.sock'}", f"tcp:{hub.hostname}:{hub_port}")
        )
        self._joined = await self._join_relay(
            f"tcp:127.0.0.1:{hub_port}", f"unix:{run / 'hub.sock'}"
        )
        for key in ("JUPYTERHUB_API_URL", "JUPYTERHUB_ACTIVITY_URL"):
            env[key] = _in_netns(env[key], hub_port)
        # the proxy and the hub -> the server: a host port -> the server's unix socket
        to_server = await relay.serve(
            "tcp:127.0.0.1:0",
            f"unix:{server_dir / SOCKET}",
            owner=os.getuid() if OUTSIDE is None else OUTSIDE[0],
            refused=lambda why: self.log.warning("%s: %s", self.user.name, why),
        )
        self._relays.append(to_server)
        self.port = relay.port(to_server)
        self.ip = "127.0.0.1"
        # jupyter-server refuses a unix socket with a port other than its default one
        prefix = urlparse(env["JUPYTERHUB_SERVICE_URL"]).path
        env["JUPYTERHUB_SERVICE_URL"] = f"http://127.0.0.1:8888{prefix}"
        cmd = [
            *self.cmd,
            *self.get_args(),
            *(
                []
                if self.user.admin
                else [
                    *(f"--ServerApp.jpserver_extensions={name}=False" for name in STUDENT_OFF),
                    f"--ServerApp.jpserver_extensions={jupyter_assignments.__name__}=True",
                ]
            ),
            f"--config={self.jupyter_config}",
            f"--ServerApp.sock={RUN}/{SOCKET}",
        ]
        SandboxSpawner._running.add(self)
        self._private = tempfile.mkdtemp(
            prefix=f"rosbook-hub-{self.user.name}-", dir=staging_base()
        )
        launch = prepare(
            cmd,
            network=self._network,
            # where nobody (the sandbox, when the hub is root) can traverse, whatever run is
            private=Path(self._private),
            env=env,
            limits=self._limits(),
            binds={HOME: home, RUN: server_dir, EXCHANGE: exchange},
            label=f"hub-{self.user.name}",
        )
        launch.env.update(
            {k: v for k, v in env.items() if k.startswith("JUPYTERHUB_") or k == "JPY_API_TOKEN"}
        )
        self._cgroup = launch.cgroup
        self._proc, self._server_pid = await asyncio.to_thread(
            start, launch, stdin=subprocess.DEVNULL
        )
        self.pid = self._proc.pid
        return self.ip, self.port

    async def poll(self) -> int | None:  # type: ignore[override]
        if self._proc is None:
            return 0
        return self._proc.poll()

    async def stop(self, now: bool = False) -> None:  # type: ignore[override]
        proc = self._proc
        if proc is not None and proc.poll() is None and not now:
            # the server (the sandbox's first process) shuts its kernels down
            with contextlib.suppress(ProcessLookupError):
                os.kill(self._server_pid, signal.SIGTERM)
            with contextlib.suppress(asyncio.TimeoutError):
                await asyncio.wait_for(asyncio.to_thread(proc.wait), timeout=10)
        self._close_relays()
        await asyncio.to_thread(self._release)

    def _close_relays(self) -> None:
        for server in getattr(self, "_relays", []):
            server.close()
        self._relays = []

    def _release(self) -> None:
        """Everything the server holds, ended at once: its sandbox (killed), cgroup,
        joined relay, network and private files. From ``stop``, and at the hub's exit for
        a server whose stop was cut short (a second signal cancels the first's stops)."""
        proc, self._proc = self._proc, None
        if proc is not None:
            if proc.poll() is None:
                proc.kill()  # bwrap: the sandbox's PID namespace dies with it
            proc.wait()
        if self._cgroup is not None:  # now, not when its watcher runs: the hub may exit
            self._cgroup.remove()
            self._cgroup = None
        if self._joined is not None:
            assert self._joined.stdin is not None
            self._joined.stdin.close()  # the relay ends at EOF
            self._joined.wait()
            self._joined = None
        if self._network is not None:
            self._network.close()
            self._network = None
        if self._private:
            shutil.rmtree(self._private, ignore_errors=True)
            self._private = ""
        if self._mounted:
            homes.unmount(Path(self._mounted))
            self._mounted = ""
        SandboxSpawner._running.discard(self)

    def get_state(self) -> dict[str, Any]:
        return {}  # nothing of a student survives the hub: no pid to find again

    def load_state(self, state: dict[str, Any]) -> None:
        pass


@atexit.register
def _release_all() -> None:
    """At the hub's exit, whatever a stop left (a stop cut short, a failed start)."""
    for spawner in list(SandboxSpawner._running):
        spawner._close_relays()
        spawner._release()


def stop_with_parent(parent: int) -> None:
    """The hub gets SIGTERM, its clean stop, when ``parent`` (``make hub``) ends, however
    it ends; at once if it already has. (GNU make passes SIGTERM on to its recipe, so the
    hub stops with it; a SIGINT or SIGKILL to make alone reaches no recipe.)"""
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_PDEATHSIG, signal.SIGTERM) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_PDEATHSIG)")
    if os.getppid() != parent:
        sys.exit(f"make hub (pid {parent}) ended before the hub started")


def _exchange(name: str) -> Path:
    """``name``'s own nbgrader exchange, with the course's three folders (made, never
    through a link, and given to the sandbox's outside user)."""
    root = state_dir() / "exchange" / name
    root.mkdir(parents=True, exist_ok=True)  # exchange/ is the hub's: NAME is no link
    with safefs.folder(root) as fd:
        safefs.give(fd, OUTSIDE)
    for folder in ("outbound", "inbound", "feedback"):
        with safefs.folder(root, COURSE, folder, create=True, owner=OUTSIDE):
            pass
    return root


def _students() -> list[str]:
    roster = state_dir() / "roster.json"
    people = json.loads(roster.read_text()) if roster.exists() else {}
    return sorted(name for name, person in people.items() if not person.get("instructor"))


def _say(refusal: str) -> None:
    """An instructor's command names what it refused on its standard error."""
    print(f"refused: {refusal}", file=sys.stderr)


def release(lab: str, labs: Path = ROOT / "labs", log: Callable[[str], None] = _say) -> list[str]:
    """Copy ``labs/LAB`` into every student's outbound (what was there is replaced);
    the students. A student whose outbound (or its ``LAB``) is a link gets nothing:
    the link is named in ``log``, never deleted or written through."""
    released = []
    for name in _students():
        root = state_dir() / "exchange" / name
        outbound = root / COURSE / "outbound"
        try:
            _exchange(name)
            with safefs.folder(root, COURSE, "outbound") as fd:
                safefs.remove_tree(fd, lab, outbound / lab)
                safefs.copy_in(labs / lab, fd, lab, outbound / lab, OUTSIDE)
        except safefs.Refused as exc:
            log(f"{name}: {exc}")
            continue
        released.append(name)
    return released


def _latest(inbound: int, lab: str, path: Path, log: Callable[[str], None]) -> str | None:
    """The folder of the latest submission of ``lab`` in the inbound ``inbound`` (a
    descriptor; ``path`` names it), by the time nbgrader's ``submit`` wrote in its name
    (``STUDENT+LAB+TIME+RANDOM``); links and names without a time are named in ``log``."""
    found: list[tuple[datetime.datetime, str]] = []
    with os.scandir(inbound) as entries:
        for entry in entries:
            parts = entry.name.split("+")
            if len(parts) < 3 or parts[1] != lab:
                continue
            if not entry.is_dir(follow_symlinks=False):
                log(str(safefs.Refused(path / entry.name, "not a folder (a link?)")))
                continue
            try:
                found.append((parse_utc(parts[2]), entry.name))
            except (ValueError, OverflowError):
                log(f"{path / entry.name}: no submission time in its name; left out")
    return max(found)[1] if found else None


@contextlib.contextmanager
def _latest_submission(
    name: str, lab: str, log: Callable[[str], None]
) -> Iterator[tuple[int, Path] | None]:
    """A descriptor of ``name``'s latest submission of ``lab`` in their inbound, and its
    path (None if they submitted none); ``safefs.Refused`` if a link is in the way."""
    root = state_dir() / "exchange" / name
    inbound = root / COURSE / "inbound"
    _exchange(name)
    with safefs.folder(root, COURSE, "inbound") as fd:
        latest = _latest(fd, lab, inbound, log)
        if latest is None:
            yield None
            return
        submission = safefs.open_folder(fd, latest, inbound / latest)
        try:
            yield submission, inbound / latest
        finally:
            os.close(submission)


def collect(lab: str, submissions: Path, log: Callable[[str], None] = _say) -> list[str]:
    """Each student's latest submission of ``lab`` into ``submissions/NAME/LAB/``: its
    folders and regular files, at most the grader's ``MAX_NOTEBOOK_BYTES`` in all,
    counted while copying. A submission holding a link, a FIFO or a device, or too
    large, is not collected (``log`` names what); the other students' are."""
    collected = []
    for name in _students():
        target = submissions / name / lab
        partial = target.with_name(f".{lab}.partial")
        try:
            with _latest_submission(name, lab, log) as latest:
                if latest is None:
                    continue
                shutil.rmtree(partial, ignore_errors=True)
                partial.parent.mkdir(parents=True, exist_ok=True)
                safefs.copy_out(*latest, partial, MAX_NOTEBOOK_BYTES)
        except safefs.Refused as exc:
            shutil.rmtree(partial, ignore_errors=True)
            log(f"{name}: {exc}")
            continue
        shutil.rmtree(target, ignore_errors=True)
        partial.rename(target)
        collected.append(name)
    return collected


def feedback(lab: str, graded: Path, log: Callable[[str], None] = _say) -> list[str]:
    """The grader's feedback (``graded/feedback/NAME/LAB/*.html``) into each student's
    own exchange, where ``nbgrader fetch_feedback`` finds it for their latest submission.
    Each page replaces what is at its name (a link there is replaced, never written
    through); a link where the submission's secret should be is named in ``log``."""
    returned = []
    for name in _students():
        pages = sorted((graded / "feedback" / name / lab).glob("*.html"))
        root = state_dir() / "exchange" / name
        try:
            with _latest_submission(name, lab, log) as latest:
                if latest is None:
                    continue
                submission, path = latest
                secret = safefs.read(submission, SECRET, path / SECRET, MAX_NOTEBOOK_BYTES)
            with safefs.folder(root, COURSE, "feedback") as fd:
                for page in pages:
                    digest = notebook_hash(
                        secret=secret.decode(errors="replace"), notebook_id=page.stem
                    )
                    there = root / COURSE / "feedback" / f"{digest}.html"
                    safefs.write(fd, there.name, page.read_bytes(), there, OUTSIDE)
        except FileNotFoundError:
            continue  # a submission without its secret: nothing to find feedback by
        except safefs.Refused as exc:
            log(f"{name}: {exc}")
            continue
        returned += [name] if pages else []
    return returned


def _hash(password: str, salt: bytes) -> str:
    return hashlib.scrypt(password.encode(), salt=salt, n=1 << 14, r=8, p=1).hex()


class ListeningProxy(ConfigurableHTTPProxy):  # type: ignore[misc]
    """JupyterHub's proxy, which fails the hub's start when it cannot listen at the hub's
    URL. The proxy (node.js) logs ``EADDRINUSE`` for a port another program holds and
    runs on, and JupyterHub takes the port's answering a connection (the other
    program's) for the proxy's: the hub said it was running at a URL where students
    would reach something else."""

    async def start(self) -> None:
        await super().start()  # its API answers: both its listens were made by now
        at = urlparse(self.public_url)
        port = at.port or (443 if at.scheme == "https" else 80)
        listening = [
            c
            for c in psutil.Process(self.proxy_process.pid).net_connections(kind="tcp")
            if c.status == psutil.CONN_LISTEN and c.laddr.port == port
        ]
        if not listening:
            self.stop()
            raise RuntimeError(
                f"the proxy could not listen at {self.public_url}: port {port} is taken "
                "by another program (Address already in use); stop it or give the hub "
                "another HUB_URL"
            )


@dataclass(frozen=True)
class Throttle:
    """How wrong passwords hold logins back, per username and per address."""

    free: int = 5  # wrong passwords in a row before a lockout
    first: float = 30.0  # the first lockout (seconds); each further wrong one doubles it
    most: float = 900.0  # the longest lockout (seconds)

    def lockout(self, wrong: int) -> float:
        """Seconds every login is refused after ``wrong`` wrong passwords in a row."""
        return 0.0 if wrong < self.free else min(self.most, self.first * 2 ** (wrong - self.free))


#: Login throttling: after 5 wrong passwords in a row for one username, or from one
#: address, every login of that name or from that address (even with the right
#: password) is refused for 30 s, doubled at each further wrong password, up to 15 min.
#: The right password, once let in, clears the name's and the address's count.
LOGIN_THROTTLE = Throttle()


class RosterAuthenticator(Authenticator):  # type: ignore[misc]
    """A password of each person's own, from a roster file of scrypt hashes; wrong
    passwords are throttled (``LOGIN_THROTTLE``)."""

    roster = Unicode(str(ROOT / ".hub" / "roster.json"), config=True, help="The roster file.")

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self._wrong: dict[str, tuple[int, float]] = {}  # key -> (in a row, refused until)

    def _people(self) -> dict[str, dict[str, Any]]:
        path = Path(self.roster)
        return json.loads(path.read_text()) if path.exists() else {}

    def check_allowed(self, username: str, authentication: Any = None) -> bool:
        return username in self._people()

    def is_admin(self, handler: Any, authentication: dict[str, Any]) -> bool:
        return bool(self._people().get(authentication["name"], {}).get("instructor"))

    async def authenticate(self, handler: Any, data: dict[str, str]) -> str | None:
        name = data.get("username", "")
        address = handler.request.remote_ip if handler is not None else ""
        keys = (f"username {name!r}", f"address {address}")
        now = time.monotonic()
        for key in keys:
            wrong, until = self._wrong.get(key, (0, 0.0))
            if until > now:
                self.log.warning(
                    "login refused: %s throttled for %.0f s more (%d wrong passwords in a row)",
                    key, until - now, wrong,
                )  # fmt: skip
                return None
        person = self._people().get(name)
        given = _hash(data.get("password", ""), bytes.fromhex(person["salt"])) if person else ""
        if person is not None and hmac.compare_digest(given, person["hash"]):
            for key in keys:
                self._wrong.pop(key, None)
            return name
        for key in keys:
            wrong = self._wrong.get(key, (0, 0.0))[0] + 1
            self._wrong[key] = (wrong, now + LOGIN_THROTTLE.lockout(wrong))
        self.log.warning("wrong password: %s from %s", name, address)
        return None


#: What a server's log says when a port it was to bind was taken (the proxy's node.js,
#: the hub's tornado).
PORT_TAKEN = ("EADDRINUSE", "Address already in use")


def free_port() -> int:
    """A loopback TCP port that is free now (another process may take it before whoever
    it is given to binds it: ``serve`` starts the hub again if so)."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def serve(
    env: dict[str, str], log: Any, url: str | None = None, tries: int = 3
) -> tuple[subprocess.Popen[bytes], str]:
    """``make hub HUB_URL=url`` (a free loopback port's if not given; in a session of its
    own: stop it with ``os.killpg``) and its URL, once it answers on its API.

    The hub is given ports found free a moment before (its URL's, its API's and its
    proxy's: ``jupyterhub_config.py``); if another process took one first, it exits
    saying so and is started again, on other ports, up to ``tries`` times. Otherwise
    ``RuntimeError`` if it exits first, ``TimeoutError`` if it never answers (its
    output is in ``log``)."""
    for attempt in range(1, tries + 1):
        at = url or f"http://127.0.0.1:{free_port()}"
        start = Path(log.name).stat().st_size
        try:
            return _serve(at, env, log), at
        except RuntimeError as exc:
            said = Path(log.name).read_bytes()[start:].decode(errors="replace")
            if not any(taken in said for taken in PORT_TAKEN):
                raise
            if attempt == tries:
                raise RuntimeError(
                    f"{exc}: a port it was given was taken by another process, "
                    f"{tries} time(s) in a row"
                ) from None


def _serve(url: str, env: dict[str, str], log: Any) -> subprocess.Popen[bytes]:
    server = subprocess.Popen(
        ["make", "--no-print-directory", "-C", str(ROOT), "hub", f"HUB_URL={url}"],
        stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True,
    )  # fmt: skip
    deadline = time.monotonic() + START_TIMEOUT * 5  # make may first install the proxy
    while True:
        try:
            with urllib.request.urlopen(f"{url}/hub/api", timeout=10) as response:
                json.loads(response.read())
            return server
        except OSError:
            if server.poll() is not None:
                code = server.returncode
                raise RuntimeError(f"make hub exited ({code}) before serving") from None
            if time.monotonic() > deadline:
                os.killpg(server.pid, signal.SIGKILL)
                server.wait()
                raise TimeoutError(f"timeout: make hub did not serve at {url}") from None
            time.sleep(0.2)  # polling for the hub to answer, not a wait for time


def stop(server: subprocess.Popen[bytes], timeout: float = 120.0) -> None:
    """Stop what ``serve`` started as Ctrl-C would; SIGKILL after ``timeout`` (a hang
    guard)."""
    if server.poll() is not None:
        return
    os.killpg(server.pid, signal.SIGINT)
    try:
        server.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(server.pid, signal.SIGKILL)
        server.wait()


def add(roster: Path, name: str, instructor: bool = False) -> str:
    """Add (or reset) ``name`` in ``roster``; the new password (shown once)."""
    people = json.loads(roster.read_text()) if roster.exists() else {}
    password, salt = secrets.token_urlsafe(12), secrets.token_bytes(16)
    people[name] = {"salt": salt.hex(), "hash": _hash(password, salt), "instructor": instructor}
    roster.parent.mkdir(parents=True, exist_ok=True)
    roster.write_text(json.dumps(people, indent=1))
    os.chmod(roster, 0o600)
    return password


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(prog="python -m coursehub.hub")
    sub = parser.add_subparsers(dest="command", required=True)
    adding = sub.add_parser("add", help="add a student (or --instructor); prints the password")
    adding.add_argument("names", nargs="+")
    adding.add_argument("--instructor", action="store_true")
    releasing = sub.add_parser("release", help="copy labs/LAB to every student")
    releasing.add_argument("lab")
    collecting = sub.add_parser("collect", help="latest submissions into SUBMISSIONS/NAME/LAB")
    collecting.add_argument("lab")
    collecting.add_argument("submissions", type=Path)
    returning = sub.add_parser("feedback", help="GRADED/feedback/NAME/LAB to each student")
    returning.add_argument("lab")
    returning.add_argument("graded", type=Path)
    args = parser.parse_args()
    if args.command == "add":
        for name in args.names:
            print(f"{name} {add(state_dir() / 'roster.json', name, args.instructor)}")
    elif args.command == "release":
        print("released to", " ".join(release(args.lab)))
    elif args.command == "collect":
        print("collected from", " ".join(collect(args.lab, args.submissions)))
    else:
        print("feedback to", " ".join(feedback(args.lab, args.graded)))
