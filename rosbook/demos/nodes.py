"""Nodes that serve a service, an action and parameters, run as a process of their own.

``python -m rosbook.demos.nodes`` starts them (Ctrl-C stops it cleanly); tests of the
CLI and the service benchmark talk to them from another process, as on a robot:

- ``clock_server`` serves ``what_time`` (``std_srvs/srv/Trigger``: the ROS time now)
  and ``switch`` (``std_srvs/srv/SetBool``), and has a ``rate_hz`` parameter
  (double, default 2.0) that refuses values <= 0;
- ``countdown_server`` serves the action ``countdown`` (``test_msgs/action/Fibonacci``:
  goal ``order`` = start, feedback ``sequence`` = counted so far, result the whole
  countdown), one step per ``1 / rate_hz`` seconds, honouring cancel.
"""

from __future__ import annotations

import sys

import rclpy
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.action import ActionServer, CancelResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from std_srvs.srv import SetBool, Trigger
from test_msgs.action import Fibonacci

from rosbook.runtime.actions import clients_listen, sleep
from rosbook.runtime.executors import SingleThreadedExecutor


class ClockServer(Node):
    """Answers 'what time is it?' with its clock, and keeps a switch and a rate."""

    def __init__(self, node_name: str = "clock_server") -> None:
        super().__init__(node_name)
        self.switched_on = False
        self.declare_parameter(
            "rate_hz", 2.0, ParameterDescriptor(description="publishing rate (Hz), > 0")
        )
        self.add_on_set_parameters_callback(self.check_rate)
        self.what_time = self.create_service(Trigger, "what_time", self.on_what_time)
        self.switch = self.create_service(SetBool, "switch", self.on_switch)

    def on_what_time(
        self, request: Trigger.Request, response: Trigger.Response
    ) -> Trigger.Response:
        seconds = self.get_clock().now().nanoseconds / 1e9
        response.success = True
        response.message = f"It is {seconds:.3f} s"
        return response

    def on_switch(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self.switched_on = request.data
        response.success = True
        response.message = "on" if request.data else "off"
        return response

    def check_rate(self, parameters: list[Parameter]) -> SetParametersResult:
        for parameter in parameters:
            if parameter.name == "rate_hz" and parameter.value <= 0:
                return SetParametersResult(successful=False, reason="rate_hz must be > 0")
        return SetParametersResult(successful=True)


class CountdownServer(Node):
    """Counts down from a goal's ``order`` to 0, one feedback per step; honours cancel."""

    def __init__(self, node_name: str = "countdown_server") -> None:
        super().__init__(node_name)
        self.declare_parameter("rate_hz", 2.0)
        self.server = ActionServer(
            self,
            Fibonacci,
            "countdown",
            self.execute,
            cancel_callback=lambda goal_handle: CancelResponse.ACCEPT,
        )

    async def execute(self, goal_handle: ServerGoalHandle) -> Fibonacci.Result:
        counted = [goal_handle.request.order]
        await clients_listen(self, "countdown")  # feedback sent before that is lost
        goal_handle.publish_feedback(Fibonacci.Feedback(sequence=counted))
        while counted[-1] > 0:
            await sleep(self, 1.0 / self.get_parameter("rate_hz").value)
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
                return Fibonacci.Result(sequence=counted)
            counted.append(counted[-1] - 1)
            goal_handle.publish_feedback(Fibonacci.Feedback(sequence=counted))
        goal_handle.succeed()
        return Fibonacci.Result(sequence=counted)


#: The longest the demo waits for work before it looks for a Ctrl-C (seconds).
CTRL_C_WAKE_S = 0.1


def main(args: list[str] | None = None) -> None:
    """Serve until Ctrl-C. The process owns its Ctrl-C, as every process of the runtime
    does: with rclpy's signal handler, a thread of rclpy's shuts the context down while
    the ``finally`` below does too, and one of them fails ("rcl_shutdown already
    called", seen under stress). Python's ``KeyboardInterrupt`` comes between two waits
    instead, each at most ``CTRL_C_WAKE_S``."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    nodes = [ClockServer(), CountdownServer()]
    executor = SingleThreadedExecutor()
    for node in nodes:
        executor.add_node(node)
    try:
        while True:
            executor.spin_once(timeout_sec=CTRL_C_WAKE_S)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main(sys.argv)
