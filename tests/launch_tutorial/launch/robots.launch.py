# Jazzy's "Managing large projects" tutorial (launch_turtlesim_launch.py): a world file
# included twice, found with ament_index_python, the second time in a group with
# PushROSNamespace (Jazzy's spelling) and, here, a SetRemap as well.
import os

from ament_index_python.packages import get_package_share_directory

from launch import LaunchDescription
from launch.actions import GroupAction, IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch_ros.actions import PushROSNamespace, SetRemap


def generate_launch_description():
    launch_dir = os.path.join(get_package_share_directory("launch_tutorial"), "launch")
    world_1 = IncludeLaunchDescription(
        PythonLaunchDescriptionSource([launch_dir, "/robot_world.launch.py"])
    )
    world_2 = IncludeLaunchDescription(
        PythonLaunchDescriptionSource([launch_dir, "/robot_world.launch.py"]),
        launch_arguments={"rate": "6.0"}.items(),
    )
    world_2_with_namespace = GroupAction(
        actions=[
            PushROSNamespace("robot2"),
            SetRemap(src="chatter", dst="news"),
            world_2,
        ]
    )
    return LaunchDescription([world_1, world_2_with_namespace])
