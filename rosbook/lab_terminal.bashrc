# The shell of a terminal opened in `make lab` (see rosbook/jupyterlab_config.py):
# the user's usual interactive settings, then the project's venv first on PATH, so that
# `ros2`, `colcon` and `python` are the ones the lab's kernel uses. ROS_DOMAIN_ID and the
# other ROS settings are inherited from the server: the terminal is in the kernel's domain.
[ -f /etc/bash.bashrc ] && . /etc/bash.bashrc
[ -f "$HOME/.bashrc" ] && . "$HOME/.bashrc"
. "$ROSBOOK_VENV/bin/activate"
