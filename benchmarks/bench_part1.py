"""Part I of the book: its build time, and the accuracy of the toolkit's ``topic hz``.

- "Part I build": seconds to build only Part I's chapters (a TOC of that part alone),
  every cell executed with a fresh cache into a temporary directory, in a ROS domain of
  its own.
- "topic hz accuracy on 10 Hz": percent error of ``rosbook.runtime.graph.hz`` against a real
  publisher process whose wall-clock timer fires at 10 Hz (target: within 2 %).
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import yaml

from benchmarks import Figure, sized
from rosbook.book import pages as bookpages

ROOT = Path(__file__).resolve().parent.parent
HZ_SECONDS = sized(10.0, 2.0)

PUBLISHER = textwrap.dedent(
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rclpy.node import Node
    from std_msgs.msg import String


    class Beacon(Node):
        def __init__(self):
            super().__init__('beacon')
            self.publisher_ = self.create_publisher(String, 'beacon', 10)
            self.timer = self.create_timer(0.1, self.on_timer)

        def on_timer(self):
            self.publisher_.publish(String(data='ping'))


    rclpy.init()
    node = Beacon()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    """
)


def part_one_chapters() -> list[str]:
    """The chapters of the book's Part I, in order."""
    toc = yaml.safe_load((ROOT / "_toc.yml").read_text())
    parts = [p for p in toc["parts"] if str(p.get("caption", "")).startswith("Part I:")]
    if not parts:
        raise RuntimeError("_toc.yml has no part whose caption starts with 'Part I:'")
    return [chapter["file"] for chapter in parts[0]["chapters"]]


def build_seconds() -> float:
    """Wall time of a clean build of Part I; raises if the build fails."""
    with tempfile.TemporaryDirectory(prefix="bench_part1_") as tmp:
        start = time.monotonic()
        bookpages.build(Path(tmp), sized(part_one_chapters(), part_one_chapters()[:1]))
        return time.monotonic() - start


def hz_error_percent() -> tuple[float, float]:
    """(percent error, measured rate) of ``graph.hz`` on a 10 Hz publisher process."""
    from rosbook.cli import cli_node
    from rosbook.runtime import graph
    from rosbook.runtime.isolation import isolated_environ

    with isolated_environ(), tempfile.TemporaryDirectory(prefix="bench_hz_") as tmp:
        script = Path(tmp) / "beacon.py"
        script.write_text(PUBLISHER)
        proc = subprocess.Popen([sys.executable, str(script)])
        try:
            with cli_node() as node:
                rate = graph.hz("/beacon", node, duration=HZ_SECONDS, wait=10.0).rate
        finally:
            proc.kill()
            proc.wait()
    return abs(rate - 10.0) / 10.0 * 100.0, rate


def run() -> list[Figure]:
    error, rate = hz_error_percent()
    return [
        Figure("Part I build", build_seconds(), "s"),
        Figure("topic hz accuracy on 10 Hz", error, "%"),
        Figure("topic hz measured on 10 Hz", rate, "Hz"),
    ]
