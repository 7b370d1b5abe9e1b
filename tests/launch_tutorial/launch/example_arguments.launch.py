# Launch arguments as the Jazzy tutorials ("Managing large projects") use them: declared
# with defaults, descriptions and choices, given as name:=value; a group in a pushed
# namespace, a condition, a parameter file found in the package's share folder.
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, GroupAction, LogInfo
from launch.conditions import IfCondition
from launch.substitutions import EnvironmentVariable, LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node, PushRosNamespace
from launch_ros.substitutions import FindPackageShare


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "rate", default_value="2.0", description="Publishing rate of the talker in Hz"
            ),
            DeclareLaunchArgument("robot", default_value="robot1", choices=["robot1", "robot2"]),
            DeclareLaunchArgument("with_listener", default_value="true"),
            LogInfo(
                msg=[
                    "Launching for ",
                    LaunchConfiguration("robot"),
                    " in ",
                    EnvironmentVariable("ROBOT_SITE", default_value="the lab"),
                ]
            ),
            GroupAction(
                [
                    PushRosNamespace(LaunchConfiguration("robot")),
                    Node(
                        package="robot_talk",
                        executable="talker",
                        name="talker",
                        parameters=[{"rate": LaunchConfiguration("rate")}],
                        output="screen",
                    ),
                    Node(
                        package="robot_talk",
                        executable="listener",
                        name="listener",
                        condition=IfCondition(LaunchConfiguration("with_listener")),
                    ),
                ]
            ),
            Node(
                package="robot_talk",
                executable="talker",
                name="config_talker",
                parameters=[
                    PathJoinSubstitution(
                        [FindPackageShare("launch_tutorial"), "config", "talker.yaml"]
                    )
                ],
            ),
        ]
    )
