"""``make lab``'s JupyterLab settings (``jupyter lab --config=rosbook/jupyterlab_config.py``).

- A terminal opened in JupyterLab is an interactive bash that reads the user's own
  ``~/.bashrc`` and then activates the project's venv (``rosbook/lab_terminal.bashrc``):
  ``ros2``, ``colcon`` and ``python`` are the venv's, and the ROS settings (domain,
  discovery range, logging) are the kernel's, inherited from the server, which
  ``python -m rosbook.runtime.isolation`` started. A login shell would reset PATH from
  ``/etc/profile``, so the terminal never is one.
- Running as root is allowed (containers run as root); JupyterLab refuses otherwise.
- Live 3D views reach MeshCat's server through this server (``jupyter-server-proxy``,
  an extension that is on once installed; see ``rosbook.viz.LiveVisualizer``).
"""

import os
import sys
from pathlib import Path

c = get_config()  # type: ignore[name-defined]  # noqa: F821  (traitlets config file)

c.ServerApp.terminado_settings = {
    "shell_command": [
        "bash",
        "--rcfile",
        str(Path(__file__).resolve().parent / "lab_terminal.bashrc"),
        "-i",
    ]
}
os.environ["ROSBOOK_VENV"] = sys.prefix  # the venv this server runs in, for the rc file
# `ros2` in this server's terminals and kernels starts its graph daemon by itself, as a
# full install's does (rosbook.cli.daemon): it carries the run's token, so it ends with
# `make lab` (on the course server, with the student's sandbox)
os.environ["ROSBOOK_CLI_DAEMON"] = "1"
c.ServerApp.allow_root = os.geteuid() == 0
