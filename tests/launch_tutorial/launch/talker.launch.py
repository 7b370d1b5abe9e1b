# The Python file the launch-file-formats page includes (demo_nodes_cpp's
# talker_listener_launch.py there): robot_talk's talker.
from launch import LaunchDescription
from launch_ros.actions import Node


def generate_launch_description():
    return LaunchDescription([Node(package="robot_talk", executable="talker", name="talker")])
