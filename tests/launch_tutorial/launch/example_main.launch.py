# Jazzy's "Using substitutions" tutorial (example_main.launch.py): the other file,
# included with launch arguments.
from launch import LaunchDescription
from launch.actions import IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import PathJoinSubstitution, TextSubstitution
from launch_ros.substitutions import FindPackageShare


def generate_launch_description():
    rates = {"rate": "4.0"}

    return LaunchDescription(
        [
            IncludeLaunchDescription(
                PythonLaunchDescriptionSource(
                    [
                        PathJoinSubstitution(
                            [
                                FindPackageShare("launch_tutorial"),
                                "launch",
                                "example_substitutions.launch.py",
                            ]
                        )
                    ]
                ),
                launch_arguments={
                    "talker_ns": "talker2",
                    "use_provided_rate": "True",
                    "new_rate": TextSubstitution(text=str(rates["rate"])),
                }.items(),
            )
        ]
    )
