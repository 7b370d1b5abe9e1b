"""``make hub``'s JupyterHub settings (``jupyterhub -f coursehub/jupyterhub_config.py``).

Every student's JupyterLab runs sandboxed on a network of its own
(``coursehub.hub.SandboxSpawner``); people log in with their own password from the
roster (``coursehub.hub.RosterAuthenticator``; instructors are admins). Settings from
the environment:

- ``ROSBOOK_HUB_URL``: where students connect (default ``http://127.0.0.1:8000``;
  put a TLS-terminating web server in front of it for a real course).
- ``ROSBOOK_HUB_LAB_ARGS``: extra options of every student's server (tests:
  ``--LabApp.expose_app_in_browser=True``).
- ``ROSBOOK_HUB_CPUS`` and ``ROSBOOK_HUB_RAM_MB``: what each student's sandbox may
  use in all (its cgroup's CPU quota and memory limit; default 1 CPU and 1024 MB).
- ``ROSBOOK_HUB_QUOTA_MB``: the size of each student's home, a disk of its own
  (default ``coursehub.hub.HOME_QUOTA``, 1024 MB; 0: no limit; a hub run as root only).
- ``ROSBOOK_HUB_DIR``: the hub's state: roster, database, cookie secret, each student's
  home (``home/NAME``) and sockets (default ``.hub/`` in the project).
- ``ROSBOOK_HUB_LTI13_ISSUER``, ``..._CLIENT_ID``, ``..._AUTHORIZE_URL``,
  ``..._JWKS_URL`` (all four, from the LMS's registration of the hub as an LTI 1.3 tool;
  the hub's own settings for it are at ``/hub/lti13/config``): people log in from the
  LMS (``jupyterhub-ltiauthenticator``, usernames its ``email`` claim) instead of with
  passwords. The roster still names the course's people at the hub's start, with their
  LMS usernames: only they may log in, its instructors are the admins, and release,
  collect and feedback go to its students; its passwords go unused.
"""

import json
import os
import shlex

from coursehub.hub import (
    ROOT,
    ListeningProxy,
    RosterAuthenticator,
    SandboxSpawner,
    free_port,
    state_dir,
    stop_with_parent,
)

c = get_config()  # type: ignore[name-defined]  # noqa: F821  (traitlets config file)

if os.environ.get("ROSBOOK_HUB_PARENT"):  # make hub's: the hub stops when make does
    stop_with_parent(int(os.environ["ROSBOOK_HUB_PARENT"]))

state = state_dir()
state.mkdir(parents=True, exist_ok=True)

c.JupyterHub.bind_url = os.environ.get("ROSBOOK_HUB_URL", "http://127.0.0.1:8000")
# The hub's API and the proxy's, on the host's loopback, on ports of their own
c.JupyterHub.hub_ip = "127.0.0.1"
c.JupyterHub.hub_port = free_port()
c.JupyterHub.proxy_class = ListeningProxy  # fails the start if it cannot listen at the URL
c.ConfigurableHTTPProxy.api_url = f"http://127.0.0.1:{free_port()}"
c.ConfigurableHTTPProxy.command = [
    str(ROOT / ".hub" / "node_modules" / ".bin" / "configurable-http-proxy")
]
c.JupyterHub.db_url = f"sqlite:///{state / 'jupyterhub.sqlite'}"
c.JupyterHub.cookie_secret_file = str(state / "jupyterhub_cookie_secret")
c.JupyterHub.pid_file = str(state / "jupyterhub.pid")
c.ConfigurableHTTPProxy.pid_file = str(state / "jupyterhub-proxy.pid")  # not in the cwd
c.JupyterHub.cleanup_servers = True  # stopping the hub stops every student's server
c.JupyterHub.cleanup_proxy = True

c.JupyterHub.authenticator_class = RosterAuthenticator
c.Authenticator.any_allow_config = True  # the roster decides (check_allowed)
c.RosterAuthenticator.roster = str(state / "roster.json")
if os.environ.get("ROSBOOK_HUB_LTI13_ISSUER"):
    lti = {key: os.environ[f"ROSBOOK_HUB_LTI13_{key.upper()}"] for key in
           ("issuer", "client_id", "authorize_url", "jwks_url")}  # fmt: skip
    c.JupyterHub.authenticator_class = "ltiauthenticator.lti13.auth.LTI13Authenticator"
    c.LTI13Authenticator.issuer = lti["issuer"]
    c.LTI13Authenticator.client_id = {lti["client_id"]}
    c.LTI13Authenticator.authorize_url = lti["authorize_url"]
    c.LTI13Authenticator.jwks_endpoint = lti["jwks_url"]
    roster = state / "roster.json"
    people = json.loads(roster.read_text()) if roster.exists() else {}
    c.Authenticator.allowed_users = set(people)
    c.Authenticator.admin_users = {name for name, person in people.items() if person["instructor"]}

c.JupyterHub.spawner_class = SandboxSpawner
c.SandboxSpawner.home_dir_template = str(state / "home" / "{username}")
c.SandboxSpawner.run_dir = str(state / "run")
c.SandboxSpawner.cpus = float(os.environ.get("ROSBOOK_HUB_CPUS", "1"))
c.SandboxSpawner.ram = int(os.environ.get("ROSBOOK_HUB_RAM_MB", "1024")) << 20
if "ROSBOOK_HUB_QUOTA_MB" in os.environ:  # each student's home (default: HOME_QUOTA)
    c.SandboxSpawner.quota = int(os.environ["ROSBOOK_HUB_QUOTA_MB"]) << 20
c.Spawner.default_url = "/lab"
c.Spawner.args = shlex.split(os.environ.get("ROSBOOK_HUB_LAB_ARGS", ""))
c.Spawner.http_timeout = 180  # a loaded machine starts JupyterLab slowly
c.Spawner.start_timeout = 180
