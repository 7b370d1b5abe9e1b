"""A talker and a listener run by a Python outside the venv (tests/test_install_layouts.py):
``python3 wheel_nodes.py talker|listener``. ``import rosbook`` comes first, as in the
notebooks: it is what makes rclpy's libraries load where pip put them."""

from __future__ import annotations

import sys

import rosbook  # noqa: F401 (first: finds the ROS wheels' libraries)

# isort: split
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String

TEXT = "hello from outside a venv"


class Talker(Node):
    """Publishes TEXT on /chatter five times a second until stopped."""

    def __init__(self) -> None:
        super().__init__("talker")
        self.publisher = self.create_publisher(String, "chatter", 10)
        self.timer = self.create_timer(0.2, self.publish)

    def publish(self) -> None:
        self.publisher.publish(String(data=TEXT))


class Listener(Node):
    """Prints the first message heard on /chatter."""

    def __init__(self) -> None:
        super().__init__("listener")
        self.heard: str | None = None
        self.subscription = self.create_subscription(String, "chatter", self.on_message, 10)

    def on_message(self, message: String) -> None:
        if self.heard is None:
            self.heard = message.data
            print(f"heard: {message.data}", flush=True)


def main(args: list[str] | None = None) -> None:
    role = (args or sys.argv)[1]
    rclpy.init(args=args)
    node = Talker() if role == "talker" else Listener()
    try:
        if isinstance(node, Listener):
            while node.heard is None:
                rclpy.spin_once(node, timeout_sec=1.0)
        else:
            rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
