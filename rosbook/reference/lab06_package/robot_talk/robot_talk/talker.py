import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from std_msgs.msg import String


class Talker(Node):
    """Publishes 'hello N' on 'chatter' at `rate` Hz (a parameter, a float)."""

    def __init__(self):
        super().__init__("talker")
        self.declare_parameter("rate", 1.0)
        rate = self.get_parameter("rate").value
        self.publisher_ = self.create_publisher(String, "chatter", 10)
        self.timer = self.create_timer(1.0 / rate, self.on_timer)
        self.count = 0

    def on_timer(self):
        msg = String(data=f"hello {self.count}")
        self.publisher_.publish(msg)
        self.get_logger().info(f'Publishing: "{msg.data}"')
        self.count += 1


def main(args=None):
    rclpy.init(args=args)
    node = Talker()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
