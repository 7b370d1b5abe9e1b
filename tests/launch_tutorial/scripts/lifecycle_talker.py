"""A lifecycle talker (rclpy.lifecycle): it publishes on 'chatter' only while active."""

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.lifecycle import Node, State, TransitionCallbackReturn
from std_msgs.msg import String


class LifecycleTalker(Node):
    def __init__(self):
        super().__init__("lifecycle_talker")
        self.publisher_ = None
        self.timer = None
        self.count = 0

    def on_configure(self, state: State) -> TransitionCallbackReturn:
        self.publisher_ = self.create_lifecycle_publisher(String, "chatter", 10)
        self.timer = self.create_timer(0.2, self.on_timer)
        self.get_logger().info("configured")
        return TransitionCallbackReturn.SUCCESS

    def on_timer(self):
        self.publisher_.publish(String(data=f"hello {self.count}"))
        self.count += 1


def main(args=None):
    rclpy.init(args=args)
    node = LifecycleTalker()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
