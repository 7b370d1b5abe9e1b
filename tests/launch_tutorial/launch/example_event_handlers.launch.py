# Jazzy's "Using event handlers" tutorial (example_event_handlers.launch.py), with
# robot_talk's talker standing in for turtlesim: the "spawn" request is a real service
# call to the talker (`ros2 service call` waits for the service, as it does for /spawn),
# and `ros2 param set` changes the talker's rate where the tutorial changes background_r.
from launch import LaunchDescription
from launch.actions import (
    DeclareLaunchArgument,
    EmitEvent,
    ExecuteProcess,
    LogInfo,
    RegisterEventHandler,
    TimerAction,
)
from launch.conditions import IfCondition
from launch.event_handlers import (
    OnExecutionComplete,
    OnProcessExit,
    OnProcessIO,
    OnProcessStart,
    OnShutdown,
)
from launch.events import Shutdown
from launch.substitutions import (
    EnvironmentVariable,
    FindExecutable,
    LaunchConfiguration,
    LocalSubstitution,
    PythonExpression,
)
from launch_ros.actions import Node


def generate_launch_description():
    talker_ns = LaunchConfiguration("talker_ns")
    use_provided_rate = LaunchConfiguration("use_provided_rate")
    new_rate = LaunchConfiguration("new_rate")

    talker_ns_launch_arg = DeclareLaunchArgument("talker_ns", default_value="talker1")
    use_provided_rate_launch_arg = DeclareLaunchArgument("use_provided_rate", default_value="False")
    new_rate_launch_arg = DeclareLaunchArgument("new_rate", default_value="5.0")

    talker_node = Node(package="robot_talk", namespace=talker_ns, executable="talker", name="sim")
    spawn_request = ExecuteProcess(
        cmd=[
            [
                FindExecutable(name="ros2"),
                " service call ",
                talker_ns,
                "/sim/get_parameters ",
                "rcl_interfaces/srv/GetParameters ",
                '"{names: [rate]}"',
            ]
        ],
        shell=True,
    )
    change_rate = ExecuteProcess(
        cmd=[[FindExecutable(name="ros2"), " param set ", talker_ns, "/sim rate ", "3.0"]],
        shell=True,
    )
    change_rate_conditioned = ExecuteProcess(
        condition=IfCondition(PythonExpression([new_rate, " == 5.0", " and ", use_provided_rate])),
        cmd=[[FindExecutable(name="ros2"), " param set ", talker_ns, "/sim rate ", new_rate]],
        shell=True,
    )

    return LaunchDescription(
        [
            talker_ns_launch_arg,
            use_provided_rate_launch_arg,
            new_rate_launch_arg,
            talker_node,
            RegisterEventHandler(
                OnProcessStart(
                    target_action=talker_node,
                    on_start=[LogInfo(msg="Talker started, asking its rate"), spawn_request],
                )
            ),
            RegisterEventHandler(
                OnProcessIO(
                    target_action=spawn_request,
                    on_stdout=lambda event: LogInfo(
                        msg=f'Rate request says "{event.text.decode().strip()}"'
                    ),
                )
            ),
            RegisterEventHandler(
                OnExecutionComplete(
                    target_action=spawn_request,
                    on_completion=[
                        LogInfo(msg="Rate request finished"),
                        change_rate,
                        TimerAction(period=2.0, actions=[change_rate_conditioned]),
                    ],
                )
            ),
            RegisterEventHandler(
                OnProcessExit(
                    target_action=talker_node,
                    on_exit=[
                        LogInfo(msg=(EnvironmentVariable(name="USER"), " closed the talker")),
                        EmitEvent(event=Shutdown(reason="Window closed")),
                    ],
                )
            ),
            RegisterEventHandler(
                OnShutdown(
                    on_shutdown=[
                        LogInfo(
                            msg=[
                                "Launch was asked to shutdown: ",
                                LocalSubstitution("event.reason"),
                            ]
                        )
                    ]
                )
            ),
        ]
    )
