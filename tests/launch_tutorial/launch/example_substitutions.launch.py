# Jazzy's "Using substitutions" tutorial (example_substitutions.launch.py), with the
# talker of robot_talk for turtlesim, and `echo` for `ros2 param set ... background_r`
# (which races the node's start-up: echo shows the same substitutions, whatever the speed).
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, TimerAction
from launch.conditions import IfCondition
from launch.substitutions import FindExecutable, LaunchConfiguration, PythonExpression
from launch_ros.actions import Node


def generate_launch_description():
    talker_ns = LaunchConfiguration("talker_ns")
    use_provided_rate = LaunchConfiguration("use_provided_rate")
    new_rate = LaunchConfiguration("new_rate")

    talker_ns_launch_arg = DeclareLaunchArgument("talker_ns", default_value="talker1")
    use_provided_rate_launch_arg = DeclareLaunchArgument("use_provided_rate", default_value="False")
    new_rate_launch_arg = DeclareLaunchArgument("new_rate", default_value="4.0")

    talker_node = Node(
        package="robot_talk", namespace=talker_ns, executable="talker", name="talker"
    )
    change_rate_conditioned = ExecuteProcess(
        condition=IfCondition(PythonExpression([new_rate, " == 4.0", " and ", use_provided_rate])),
        cmd=[[FindExecutable(name="echo"), " rate of ", talker_ns, "/talker: ", new_rate]],
        shell=True,
        output="screen",
    )

    return LaunchDescription(
        [
            talker_ns_launch_arg,
            use_provided_rate_launch_arg,
            new_rate_launch_arg,
            talker_node,
            TimerAction(period=2.0, actions=[change_rate_conditioned]),
        ]
    )
