"""Views: MeshCat scenes of URDF robots (``scene``), the digital twin (``twin``), tf2's
frame tree (``tf_tree``) and pictures of the ROS graph (``graph_svg``).

``from rosbook.viz import X`` still gives the names of ``rosbook.viz.scene`` (this
package's earlier single module), loaded on first use.
"""

from rosbook import names_of

__getattr__ = names_of(__name__, "scene")
