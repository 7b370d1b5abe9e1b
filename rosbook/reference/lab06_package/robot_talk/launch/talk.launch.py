from launch import LaunchDescription
from launch_ros.actions import Node


def generate_launch_description():
    return LaunchDescription(
        [
            Node(package="robot_talk", executable="talker", name="talker", output="screen"),
            Node(package="robot_talk", executable="listener", name="listener", output="screen"),
        ]
    )
