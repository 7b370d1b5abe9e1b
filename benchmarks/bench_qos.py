"""QoS: the delivery scenarios on the simulated clock against the seconds they cover,
and the one-way latency of a small message between two processes.

Target: the scenarios run at least 10x faster than real time ("x" = simulated seconds
per wall second).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import time

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import String

from benchmarks import Figure, sized
from rosbook.demos import qos
from rosbook.runtime.isolation import isolated_environ
from rosbook.runtime.session import ros

LATENCY_MESSAGES = sized(200, 20)

#: The receiving process: prints one latency (ns) per message, then exits.
RECEIVER = """
import sys, time
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from std_msgs.msg import String

count = int(sys.argv[1])
rclpy.init()
node = Node('latency_receiver')
latencies = []
node.create_subscription(
    String, 'latency', lambda m: latencies.append(time.time_ns() - int(m.data)),
    QoSProfile(depth=count))
while len(latencies) < count and rclpy.ok():
    rclpy.spin_once(node, timeout_sec=0.5)
print(' '.join(map(str, latencies)), flush=True)
node.destroy_node()
rclpy.try_shutdown()
"""


def scenario_speed() -> list[Figure]:
    runs = {
        "no subscriber, late joiner": qos.run_late_joiner(DurabilityPolicy.TRANSIENT_LOCAL),
        "fast subscriber": qos.run_delivery(0.1),
        "slow subscriber": qos.run_delivery(1.7),
    }
    wall = sum(r.wall_s for r in runs.values())
    simulated = sum(r.simulated_s for r in runs.values())
    figures = [
        Figure(f"qos {name}: sim s per wall s", r.simulated_s / r.wall_s, "x")
        for name, r in runs.items()
    ]
    figures += [
        Figure("qos 3 scenarios: wall time", wall, "s"),
        Figure("qos 3 scenarios: simulated time they cover", simulated, "s"),
        Figure("qos 3 scenarios, sim vs real time (target >= 10)", simulated / wall, "x"),
    ]
    return figures


def latency_ms(count: int = LATENCY_MESSAGES, rate_hz: float = 100.0) -> float:
    """Median one-way latency: sent from this process, stamped on the same system clock."""
    ros.init()
    receiver = subprocess.Popen(
        [sys.executable, "-c", RECEIVER, str(count)], stdout=subprocess.PIPE, text=True
    )
    node = Node("latency_sender")
    try:
        pub = node.create_publisher(String, "latency", QoSProfile(depth=count))
        if not ros.spin_until(lambda: pub.get_subscription_count() > 0, node, timeout=20.0):
            raise TimeoutError("the receiving process never subscribed")
        time.sleep(0.5)  # let the reliable writer finish matching
        for _ in range(count):
            pub.publish(String(data=str(time.time_ns())))
            time.sleep(1.0 / rate_hz)
        output, _ = receiver.communicate(timeout=20.0)
    finally:
        if receiver.poll() is None:
            receiver.kill()
        ros.remove(node)
    latencies = [int(v) for v in output.split()]
    return statistics.median(latencies) / 1e6


def run() -> list[Figure]:
    ros.shutdown()  # initialise again inside a domain of our own
    with isolated_environ():
        try:
            figures = scenario_speed()
            figures.append(Figure("qos one-way latency, 2 processes (median)", latency_ms(), "ms"))
        finally:
            ros.shutdown()
    return figures
