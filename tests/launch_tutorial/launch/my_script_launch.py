# Jazzy's "Integrating launch files into ROS 2 packages" tutorial (my_script_launch.py),
# with robot_talk's talker for demo_nodes_cpp's.
import launch
import launch_ros.actions


def generate_launch_description():
    return launch.LaunchDescription(
        [
            launch_ros.actions.Node(package="robot_talk", executable="talker", name="talker"),
        ]
    )
