"""``robot_state_publisher`` for this book: a URDF and ``/joint_states`` in, ``/tf`` out.

As upstream's node (ros/robot_state_publisher, jazzy) does: the URDF comes as the
parameter ``robot_description``; every fixed joint's transform is sent once on
``/tf_static``; every moving joint's (revolute, continuous, prismatic, and the mimic
joints that follow them) is sent on ``/tf`` for each ``sensor_msgs/msg/JointState`` on
``joint_states``, stamped with that message's stamp; the URDF itself is published on
``robot_description`` (``std_msgs/msg/String``, transient local); ``frame_prefix`` is put
in front of every frame name. Run it as a process with ``python -m
rosbook.sim.robot_state_publisher --ros-args -p robot_description:="$(cat robot.urdf)"``.
Left out: the ``publish_frequency`` limit (every joint state is sent on) and
``ignore_timestamp``.
"""

from __future__ import annotations

import math

import numpy as np
import rclpy
from geometry_msgs.msg import TransformStamped
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.time import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from rosbook.robots import urdf
from rosbook.runtime.transforms import StaticTransformBroadcaster, TransformBroadcaster


def matrix_to_transform(
    matrix: np.ndarray, parent: str, child: str, stamp: Time
) -> TransformStamped:
    """A 4x4 homogeneous transform (parent <- child) as a ``TransformStamped``."""
    t = TransformStamped()
    t.header.stamp = stamp.to_msg()
    t.header.frame_id, t.child_frame_id = parent, child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = (
        float(v) for v in matrix[:3, 3]
    )
    r = matrix[:3, :3]
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = ((r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, s / 4)
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(1.0 + r[i, i] - r[j, j] - r[k, k])
        q_list = [0.0, 0.0, 0.0, (r[k, j] - r[j, k]) / s]
        q_list[i] = s / 4
        q_list[j] = (r[j, i] + r[i, j]) / s
        q_list[k] = (r[k, i] + r[i, k]) / s
        q = tuple(q_list)
    rot = t.transform.rotation
    rot.x, rot.y, rot.z, rot.w = (float(v) for v in q)
    return t


class RobotStatePublisher(Node):
    """Publishes a URDF robot's link frames: fixed joints on /tf_static, moving ones on /tf."""

    def __init__(self, robot_description: str | None = None, **kwargs: object) -> None:
        super().__init__("robot_state_publisher", **kwargs)  # type: ignore[arg-type]
        self.declare_parameter("robot_description", robot_description or "")
        self.declare_parameter("frame_prefix", "")
        xml = self.get_parameter("robot_description").value
        if not xml:
            raise urdf.URDFError("robot_description", "the parameter is empty: give a URDF")
        self.robot = urdf.load(xml)
        self.prefix = self.get_parameter("frame_prefix").value
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.description = self.create_publisher(String, "robot_description", latched)
        self.description.publish(String(data=xml))
        self.static_broadcaster = StaticTransformBroadcaster(self)
        self.broadcaster = TransformBroadcaster(self)
        self.moving = [
            j for j in self.robot.joints if j.type in ("revolute", "continuous", "prismatic")
        ]
        now = self.get_clock().now()
        fixed = [
            self._transform(j.name, j.parent, j.child, 0.0, now)
            for j in self.robot.joints
            if j.type == "fixed"
        ]
        if fixed:
            self.static_broadcaster.sendTransform(fixed)
        self.subscription = self.create_subscription(
            JointState, "joint_states", self.on_joint_states, 10
        )
        self.get_logger().info(f"got segment {self.robot.root}")

    def _transform(
        self, joint: str, parent: str, child: str, position: float, stamp: Time
    ) -> TransformStamped:
        matrix = self.robot.joint_transform(joint, position)
        return matrix_to_transform(matrix, self.prefix + parent, self.prefix + child, stamp)

    def _source(self, joint: str) -> str | None:
        """The joint a mimic joint follows (None for any other)."""
        mimic = self.robot.model.joint_map[joint].mimic
        return None if mimic is None else mimic.joint

    def on_joint_states(self, msg: JointState) -> None:
        """Send the moving joints' transforms at the message's stamp."""
        positions = dict(zip(msg.name, msg.position))
        stamp = Time.from_msg(msg.header.stamp)
        sent = [
            self._transform(j.name, j.parent, j.child,
                            self.robot.joint_position(j.name, positions), stamp)
            for j in self.moving
            if (self._source(j.name) or j.name) in positions
        ]  # fmt: skip
        if sent:
            self.broadcaster.sendTransform(sent)


def main(args: list[str] | None = None) -> None:
    """Run the node until Ctrl-C (a URDF error is one line, not a traceback)."""
    rclpy.init(args=args)
    try:
        node = RobotStatePublisher()
    except urdf.URDFError as error:
        print(f"[robot_state_publisher] error: {error}", flush=True)
        rclpy.try_shutdown()
        raise SystemExit(1) from None
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
