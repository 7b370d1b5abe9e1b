"""The nodes of upstream ros2cli's CLI tests (jazzy branch), in one process.

Rewritten for this project from ``ros2*/test/fixtures/*.py`` of ros2/ros2cli: the
talker and listener of ros2topic, its repeaters (one message type each), ros2node's
complex node (also serving ros2action's Fibonacci action as its fixture does), ros2service's
echo server and ros2param's parameter node. ``tests/test_cli_upstream.py`` starts it
once and runs the ``ros2`` verbs against it. With the argument ``lifecycle`` it runs
instead ros2lifecycle's fixtures (``simple_lifecycle_node``, once visible and once hidden)
for ``tests/test_cli_lifecycle.py``.
"""

import sys
import time

import rclpy
from geometry_msgs.msg import TwistStamped
from rclpy.action import ActionServer
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.lifecycle import Node as LifecycleNode
from rclpy.node import Node
from rclpy.parameter import PARAMETER_SEPARATOR_STRING
from rclpy.qos import qos_profile_system_default
from std_msgs.msg import String
from test_msgs.action import Fibonacci
from test_msgs.msg import Arrays, Defaults, Strings
from test_msgs.srv import BasicTypes

#: The topic an action server publishes the feedback of its ``fibonacci`` action on.
FEEDBACK_TOPIC = "/fibonacci/_action/feedback"


class Talker(Node):
    """ros2topic/test/fixtures/talker_node.py, at 20 Hz (upstream: 1 Hz)."""

    def __init__(self, name="talker", topic="chatter"):
        super().__init__(name)
        self.count = 0
        self.publisher = self.create_publisher(String, topic, 10)
        self.timer = self.create_timer(0.05, self.tick)

    def tick(self):
        self.publisher.publish(String(data=f"Hello World: {self.count}"))
        self.count += 1


class Listener(Node):
    """ros2topic/test/fixtures/listener_node.py, remapped to chit_chatter as upstream."""

    def __init__(self):
        super().__init__("listener")
        self.subscription = self.create_subscription(String, "chit_chatter", lambda msg: None, 10)


class Repeater(Node):
    """ros2topic/test/fixtures/repeater_node.py: a message of one type, over and over."""

    def __init__(self, name, msg_type, topic):
        super().__init__(name)
        self.publisher = self.create_publisher(msg_type, topic, 10)
        self.timer = self.create_timer(0.1, lambda: self.publisher.publish(msg_type()))


class StampedTalker(Node):
    """What ros2topic/test/test_cli.py's /cmd_vel publisher is to ``topic delay``:
    ``geometry_msgs/msg/TwistStamped`` stamped with the time it is sent."""

    def __init__(self):
        super().__init__("cmd_vel_talker")
        self.publisher = self.create_publisher(TwistStamped, "cmd_vel", 10)
        self.timer = self.create_timer(0.1, self.tick)

    def tick(self):
        message = TwistStamped()
        message.header.stamp = self.get_clock().now().to_msg()
        self.publisher.publish(message)


class ComplexNode(Node):
    """ros2node/test/fixtures/complex_node.py; its Fibonacci action computes the
    sequence with feedback as ros2action/test/fixtures/fibonacci_action_server.py."""

    def __init__(self, name="complex_node", action=True):
        super().__init__(name)
        self.publisher = self.create_publisher(Arrays, "arrays", qos_profile_system_default)
        self.subscription = self.create_subscription(
            Strings, "strings", lambda msg: None, qos_profile_system_default
        )
        self.server = self.create_service(BasicTypes, "basic", lambda req, res: res)
        self.timer = self.create_timer(1.0, lambda: self.publisher.publish(Arrays()))
        if action:
            self.action_server = ActionServer(self, Fibonacci, "fibonacci", self.execute)

    def execute(self, goal_handle):
        # Upstream's server publishes at once and its test retries when the client's
        # feedback subscription was not matched yet; this one waits until it is
        # discovered (the limit only guards against a hang).
        deadline = time.monotonic() + 30.0
        while self.count_subscribers(FEEDBACK_TOPIC) == 0 and time.monotonic() < deadline:
            time.sleep(0.01)
        feedback = Fibonacci.Feedback()
        feedback.sequence = [0, 1]
        for i in range(1, goal_handle.request.order):
            feedback.sequence.append(feedback.sequence[i] + feedback.sequence[i - 1])
            goal_handle.publish_feedback(feedback)
        goal_handle.succeed()
        return Fibonacci.Result(sequence=feedback.sequence)


class EchoServer(Node):
    """ros2service/test/fixtures/echo_server.py, in namespace my_ns as upstream."""

    def __init__(self, name="echo_server", service="echo"):
        super().__init__(name, namespace="my_ns")
        self.server = self.create_service(BasicTypes, service, self.callback)

    def callback(self, request, response):
        for field_name in request.get_fields_and_field_types():
            setattr(response, field_name, getattr(request, field_name))
        return response


class ParameterNode(Node):
    """ros2param/test/fixtures/parameter_node.py, in namespace foo as upstream."""

    def __init__(self):
        super().__init__("parameter_node", namespace="foo")
        self.declare_parameter("bool_param", True)
        self.declare_parameter("int_param", 42)
        self.declare_parameter("double_param", 1.23)
        self.declare_parameter("str_param", "Hello World")
        self.declare_parameter("bool_array_param", [False, False, True])
        self.declare_parameter("int_array_param", [1, 2, 3])
        self.declare_parameter("str_array_param", ["foo", "bar", "baz"])
        self.declare_parameter("double_array_param", [3.125, 6.25, 12.5])
        self.declare_parameter("foo" + PARAMETER_SEPARATOR_STRING + "str_param", "foo")
        self.declare_parameter(
            PARAMETER_SEPARATOR_STRING.join(["foo", "bar", "str_param"]), "foobar"
        )


def cli_nodes():
    """The nodes of ros2topic, ros2node, ros2action, ros2service and ros2param's tests."""
    return [
        Talker(),
        Talker("_hidden_talker", "_hidden_chatter"),
        Listener(),
        Repeater("defaults_repeater", Defaults, "defaults"),
        StampedTalker(),
        ComplexNode(),
        ComplexNode("_hidden_complex_node", action=False),
        EchoServer(),
        EchoServer("_hidden_echo_server", "_echo"),
        ParameterNode(),
        # two nodes of one name (ros2node/test/test_cli_duplicate_node_names.py)
        Node("twin"),
        Node("twin"),
    ]


def lifecycle_nodes():
    """ros2lifecycle's ``simple_lifecycle_node``, once visible and once hidden."""
    return [LifecycleNode(name) for name in ("test_lifecycle_node", "_hidden_test_lifecycle_node")]


def main(args=None):
    rclpy.init(args=args)
    nodes = lifecycle_nodes() if sys.argv[1:] == ["lifecycle"] else cli_nodes()
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
