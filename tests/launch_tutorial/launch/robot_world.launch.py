# The world file robots.launch.py includes (turtlesim_world_1_launch.py in the
# "Managing large projects" tutorial): one talker, its rate an argument.
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument("rate", default_value="3.0"),
            Node(
                package="robot_talk",
                executable="talker",
                name="sim",
                parameters=[{"rate": LaunchConfiguration("rate")}],
            ),
        ]
    )
