"""Lab 6's two-robot system: time to build it with colcon, bring it up, and stop it.

Targets (2-core machine): build under 10 s, launch to first message on both robots'
topics under 5 s, Ctrl-C to every process gone under 2 s.
"""

from __future__ import annotations

import time

from std_msgs.msg import String

from benchmarks import Figure
from rosbook.labs.lab06 import add_reference_package
from rosbook.labs.probes import Probe
from rosbook.launch.launcher import LaunchDescription, Node, launch
from rosbook.launch.workspace import Workspace
from rosbook.runtime.isolation import isolated_environ
from rosbook.runtime.session import ros


def two_robots() -> LaunchDescription:
    """The lab's two robots: talker at 2 Hz and 5 Hz, a listener each."""
    nodes = []
    for robot, rate in (("robot1", 2.0), ("robot2", 5.0)):
        nodes.append(
            Node(
                package="robot_talk",
                executable="talker",
                name="talker",
                namespace=robot,
                parameters=[{"rate": rate}],
            )
        )
        nodes.append(
            Node(package="robot_talk", executable="listener", name="listener", namespace=robot)
        )
    return LaunchDescription(nodes)


def run() -> list[Figure]:
    with isolated_environ():
        ws = Workspace.scratch("bench_launch_")
        try:
            add_reference_package(ws.src)
            start = time.monotonic()
            build = ws.build()
            build_s = time.monotonic() - start
            if not build.ok:
                raise RuntimeError(build.output)
            env = ws.environ()
            ros.init()
            probes = [Probe(f"/{robot}/chatter", String) for robot in ("robot1", "robot2")]
            start = time.monotonic()
            system = launch(two_robots(), env=env, echo=None)
            up = ros.spin_until(lambda: all(p.received.messages for p in probes), timeout=30.0)
            up_s = time.monotonic() - start
            start = time.monotonic()
            codes = system.shutdown()
            down_s = time.monotonic() - start
            for probe in probes:
                probe.close()
            if not up or any(codes.values()):
                raise RuntimeError(f"two robots did not come up or stop cleanly: {codes}")
        finally:
            ros.shutdown()
            ws.remove()
    return [
        Figure("lab06 colcon build --symlink-install (robot_talk)", build_s, "s"),
        Figure("lab06 launch to first message on both robots", up_s, "s"),
        Figure("lab06 one Ctrl-C to all 4 processes exited", down_s, "s"),
        Figure("lab06 build + launch of the two-robot system", build_s + up_s, "s"),
    ]
