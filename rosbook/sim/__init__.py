"""The simulator: differential-drive kinematics (``diff_drive``), the Pymunk world
(``physics``), the ROS simulator node (``node``) and its plots (``plot``).

``from rosbook.sim import X`` still gives the names of ``rosbook.sim.physics`` (this
package's earlier single module), loaded on first use.
"""

from rosbook import names_of

__getattr__ = names_of(__name__, "physics")
