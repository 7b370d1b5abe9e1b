"""Upstream's ``ros2lifecycle`` test fixtures, rewritten with rclpy: two lifecycle nodes
that do nothing in their transitions (``simple_lifecycle_node``), one of them hidden."""

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.lifecycle import Node

NAMES = ("test_lifecycle_node", "_hidden_test_lifecycle_node")


def main(args=None):
    rclpy.init(args=args)
    nodes = [Node(name) for name in NAMES]
    executor = SingleThreadedExecutor()
    for node in nodes:
        executor.add_node(node)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
