"""rosbook's robot_state_publisher: a URDF and /joint_states in, /tf and /tf_static out."""

from __future__ import annotations

import math
import threading
from collections.abc import Iterator

import numpy as np
import pytest
import rclpy
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.time import Time
from sensor_msgs.msg import JointState

from rosbook import robots
from rosbook.robots import urdf
from rosbook.runtime.transforms import Buffer, TransformListener
from rosbook.sim.robot_state_publisher import RobotStatePublisher, matrix_to_transform

DIFF_DRIVE = robots.DIFF_DRIVE_URDF
WAIT = Duration(seconds=120)  # only a hang guard: lookups return when the transform arrives


@pytest.fixture
def context() -> Iterator[rclpy.Context]:
    context = rclpy.Context()
    rclpy.init(context=context)
    yield context
    rclpy.shutdown(context=context)


def test_matrix_to_transform_keeps_rotation_and_translation() -> None:
    for roll, pitch, yaw in [(0, 0, 0), (math.pi, 0, 0), (0.3, -1.2, 2.9), (0, math.pi, 0.5)]:
        matrix = urdf.transform((1.0, -2.0, 0.5), (roll, pitch, yaw))
        t = matrix_to_transform(matrix, "a", "b", Time())
        q = t.transform.rotation
        x, y, z, w = q.x, q.y, q.z, q.w
        back = np.array([
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ])  # fmt: skip
        assert np.allclose(back, matrix[:3, :3]) and math.isclose(x * x + y * y + z * z + w * w, 1)
        assert (t.transform.translation.x, t.transform.translation.y) == (1.0, -2.0)


def test_fixed_joints_go_to_tf_static_and_moving_ones_follow_joint_states(context) -> None:
    publisher = RobotStatePublisher(DIFF_DRIVE.read_text(), context=context)
    listener_node = Node("rsp_listener", context=context)
    buffer = Buffer()
    listener = TransformListener(buffer, listener_node)
    states = listener_node.create_publisher(JointState, "joint_states", 10)
    executor = SingleThreadedExecutor(context=context)
    for node in (publisher, listener_node):
        executor.add_node(node)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        laser = buffer.lookup_transform("base_link", "laser_frame", Time(), timeout=WAIT)
        assert (laser.transform.translation.x, laser.transform.translation.z) == (0.0, 0.11)
        stamp = Time(seconds=7)
        turned = JointState(name=["base_link_left_wheel"], position=[math.pi / 2])
        turned.header.stamp = stamp.to_msg()
        while states.get_subscription_count() == 0:  # until the node's subscription is known
            spinner.join(0.01)
        states.publish(turned)
        wheel = buffer.lookup_transform("base_link", "left_wheel", stamp, timeout=WAIT)
        expected = matrix_to_transform(
            urdf.load(DIFF_DRIVE).joint_transform("base_link_left_wheel", math.pi / 2),
            "base_link", "left_wheel", stamp,
        )  # fmt: skip
        assert wheel.transform == expected.transform
        assert wheel.header == expected.header and wheel.child_frame_id == "left_wheel"
        # the right wheel was not in the message: nothing was sent for it
        assert not buffer.can_transform("base_link", "right_wheel", stamp)
    finally:
        executor.shutdown()
        spinner.join()
        listener.unregister()
        publisher.destroy_node()
        listener_node.destroy_node()


def test_an_empty_robot_description_is_one_line(context) -> None:
    with pytest.raises(urdf.URDFError, match="robot_description.*empty"):
        RobotStatePublisher("", context=context)
