"""``ros2 doctor [--report | --report-failed] [--include-warnings]``: check the set-up.

As ros2doctor: checks (platform, network, topics, QoS compatibility) whose warnings and
errors go to stderr, then ``All N checks passed`` or ``M/N check(s) failed``; with
``--report`` the reports (PLATFORM INFORMATION, ROS 2 INFORMATION, NETWORK
CONFIGURATION, RMW MIDDLEWARE, TOPIC LIST, QOS COMPATIBILITY LIST) instead. Upstream
reads the distribution's status from the rosdistro index on the internet and interface
details with psutil; here the distribution is the one of the installed ROS wheels and the
interfaces are read from Linux itself. Upstream's package-version check needs that index
and is left out.
"""

from __future__ import annotations

import argparse
import fcntl
import ipaddress
import os
import platform
import re
import socket
import struct
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from rclpy.node import Node
from rclpy.qos import QoSCompatibility, qos_check_compatible
from rclpy.utilities import get_rmw_implementation_identifier

from rosbook.cli import cli_node

#: Topics every node has, left out of the topic check and report (as upstream).
SKIP_TOPICS = ("/parameter_events", "/rosout")

#: What ros2doctor knows of the distributions from the rosdistro index (type, status).
DISTRIBUTIONS = {
    "humble": ("ros2", "active"),
    "jazzy": ("ros2", "active"),
    "kilted": ("ros2", "active"),
    "rolling": ("ros2", "rolling"),
    "iron": ("ros2", "end-of-life"),
}

#: Linux's interface flags by bit, as ros2doctor prints them.
NET_FLAGS = (
    "UP BROADCAST DEBUG LOOPBACK PTP NOTRAILERS RUNNING NOARP "
    "PROMISC ALLMULTI MASTER SLAVE MULTICAST PORTSEL AUTOMEDIA DYNAMIC"
).split()
SIOCGIFFLAGS, SIOCGIFADDR, SIOCGIFNETMASK, SIOCGIFMTU = 0x8913, 0x8915, 0x891B, 0x8921


@dataclass
class Report:
    """A titled list of (item, value) lines."""

    name: str
    items: list[tuple[str, object]] = field(default_factory=list)

    def format(self) -> str:
        padding = max([8] + [len(item) + 4 for item, _ in self.items if len(item) >= 8])
        lines = [f"\n   {self.name}"]
        lines += [f"{item:{padding}}: {value}" for item, value in self.items]
        return "\n".join(lines)


@dataclass
class Result:
    """What one check found: errors fail it, warnings only with ``--include-warnings``."""

    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


def add_parser(verbs: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = verbs.add_parser("doctor", help="Check ROS setup and other potential issues")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--report", "-r", action="store_true", help="Print all reports.")
    group.add_argument(
        "--report-failed", "-rf", action="store_true", help="Print reports of failed checks only."
    )
    p.add_argument(
        "--include-warnings",
        "-iw",
        action="store_true",
        help="Include warnings as failed checks. Warnings are ignored by default.",
    )
    p.set_defaults(func=doctor)


# -- the installation ---------------------------------------------------------------
def distribution() -> str | None:
    """``ROS_DISTRO``, else the distribution of the installed ``ros-<distro>-rclpy`` wheel."""
    if os.environ.get("ROS_DISTRO"):
        return os.environ["ROS_DISTRO"].lower()
    for dist in metadata.distributions():
        found = re.fullmatch(r"ros-([a-z]+)-rclpy", (dist.metadata["Name"] or "").lower())
        if found:
            return found[1]
    return None


def platform_check(_: Node) -> Result:
    result = Result()
    name = distribution()
    if name is None:
        result.errors.append("ROS_DISTRO is not set.")
    elif name not in DISTRIBUTIONS:
        result.warnings.append(f"Distribution name {name} is not found")
    elif DISTRIBUTIONS[name][1] == "end-of-life":
        result.warnings.append(
            f"Distribution {name} is no longer supported or deprecated. "
            "To get the latest features, download the new versions at https://docs.ros.org"
        )
    return result


def platform_reports(_: Node) -> list[Report]:
    system = Report("PLATFORM INFORMATION")
    system.items += [
        ("system", platform.system()),
        ("platform info", platform.platform()),
        ("release", platform.release()),
        ("processor", platform.processor()),
    ]
    ros = Report("ROS 2 INFORMATION")
    name = distribution()
    if name in DISTRIBUTIONS:
        kind, status = DISTRIBUTIONS[name]
        ros.items += [
            ("distribution name", name),
            ("distribution type", kind),
            ("distribution status", status),
        ]
    return [system, ros]


# -- the network --------------------------------------------------------------------
def _ioctl(request: int, interface: str) -> bytes | None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            return fcntl.ioctl(s.fileno(), request, struct.pack("256s", interface.encode()[:15]))
        except OSError:
            return None


def interface_flags(interface: str) -> set[str]:
    raw = _ioctl(SIOCGIFFLAGS, interface)
    bits = struct.unpack("H", raw[16:18])[0] if raw else 0
    return {name for bit, name in enumerate(NET_FLAGS) if bits & (1 << bit)}


def interface_details(interface: str) -> list[tuple[str, object]]:
    """What ros2doctor reports of one interface, in its order, the empty ones left out."""
    address, netmask, mtu, raw = (
        _ioctl(r, interface) for r in (SIOCGIFADDR, SIOCGIFNETMASK, SIOCGIFMTU, SIOCGIFFLAGS)
    )
    inet = socket.inet_ntoa(address[20:24]) if address else None
    inet6 = [
        str(ipaddress.IPv6Address(bytes.fromhex(parts[0])))
        for parts in (line.split() for line in _read("/proc/net/if_inet6").splitlines())
        if parts[-1] == interface
    ]
    ether = _read(f"/sys/class/net/{interface}/address").strip()
    bits = struct.unpack("H", raw[16:18])[0] if raw else -1
    flags = ",".join(n for b, n in enumerate(NET_FLAGS) if bits >= 0 and bits & (1 << b))
    items: list[tuple[str, object]] = [
        ("inet", inet),
        ("inet4", [inet] if inet else []),
        ("ether", ether if ether and ether != "00:00:00:00:00:00" else None),
        ("inet6", inet6),
        ("netmask", socket.inet_ntoa(netmask[20:24]) if netmask and inet else None),
        ("device", interface),
        ("flags", f"{bits}<{flags}>" if bits >= 0 else None),
        ("mtu", struct.unpack("i", mtu[16:20])[0] if mtu else None),
    ]
    return [(k, v) for k, v in items if v]


def _read(path: str) -> str:
    try:
        return Path(path).read_text()
    except OSError:
        return ""


def network_check(_: Node) -> Result:
    result = Result()
    flags = [interface_flags(name) for _, name in socket.if_nameindex()]
    if not any("LOOPBACK" in f for f in flags):
        result.errors.append("No loopback IP address is found.")
    if all("LOOPBACK" in f for f in flags):
        result.warnings.append("Only loopback IP address is found.")
    if not any("MULTICAST" in f for f in flags):
        result.warnings.append("No multicast IP address is found.")
    return result


def network_reports(_: Node) -> list[Report]:
    report = Report("NETWORK CONFIGURATION")
    for _, name in socket.if_nameindex():
        report.items += interface_details(name)
    return [report]


# -- the middleware and the graph ---------------------------------------------------
def rmw_reports(_: Node) -> list[Report]:
    return [Report("RMW MIDDLEWARE", [("middleware name", get_rmw_implementation_identifier())])]


def _topics(node: Node, skip: tuple[str, ...] = ()) -> list[str]:
    return [name for name, _ in node.get_topic_names_and_types() if name not in skip]


def topic_check(node: Node) -> Result:
    result = Result()
    for topic in _topics(node, SKIP_TOPICS):
        publishers, subscribers = node.count_publishers(topic), node.count_subscribers(topic)
        if publishers and not subscribers:
            result.warnings.append(f"Publisher without subscriber detected on {topic}.")
        elif subscribers and not publishers:
            result.warnings.append(f"Subscriber without publisher detected on {topic}.")
    return result


def topic_reports(node: Node) -> list[Report]:
    report = Report("TOPIC LIST")
    topics = _topics(node, SKIP_TOPICS)
    if not topics:
        report.items += [("topic", "none"), ("publisher count", 0), ("subscriber count", 0)]
    for topic in topics:
        report.items += [
            ("topic", topic),
            ("publisher count", node.count_publishers(topic)),
            ("subscriber count", node.count_subscribers(topic)),
        ]
    return [report]


def _pairs(node: Node) -> list[tuple[str, object, object]]:
    return [
        (topic, pub, sub)
        for topic in _topics(node)
        for pub in node.get_publishers_info_by_topic(topic)
        for sub in node.get_subscriptions_info_by_topic(topic)
    ]


def _reason(text: str) -> str:
    head, sep, rest = text.partition(": ")
    return rest if sep and head.lower() in ("warning", "error") else text


def qos_check(node: Node) -> Result:
    result = Result()
    for topic, pub, sub in _pairs(node):
        compatibility, reason = qos_check_compatible(pub.qos_profile, sub.qos_profile)  # type: ignore[attr-defined]
        if compatibility == QoSCompatibility.WARNING:
            result.warnings.append(
                f"QoS compatibility warning found on topic '{topic}': {_reason(reason)}"
            )
        elif compatibility == QoSCompatibility.ERROR:
            result.errors.append(
                f"QoS compatibility error found on topic '{topic}': {_reason(reason)}"
            )
    return result


def qos_reports(node: Node) -> list[Report]:
    report = Report("QOS COMPATIBILITY LIST")
    for topic, pub, sub in _pairs(node):
        compatibility, reason = qos_check_compatible(pub.qos_profile, sub.qos_profile)  # type: ignore[attr-defined]
        report.items += [
            ("topic [type]", f"{topic} [{pub.topic_type}]"),  # type: ignore[attr-defined]
            ("publisher node", pub.node_name),  # type: ignore[attr-defined]
            ("subscriber node", sub.node_name),  # type: ignore[attr-defined]
            ("compatibility status", "OK" if compatibility == QoSCompatibility.OK else reason),
        ]
    if not report.items:
        report.items.append(("compatibility status", "No publisher/subscriber pairs found"))
    return [report]


#: (category, check) in upstream's order.
CHECKS: list[tuple[str, Callable[[Node], Result]]] = [
    ("platform", platform_check),
    ("network", network_check),
    ("topic", topic_check),
    ("middleware", qos_check),
]
#: (category, reports) in upstream's order.
REPORTS: list[tuple[str, Callable[[Node], list[Report]]]] = [
    ("platform", platform_reports),
    ("network", network_reports),
    ("middleware", rmw_reports),
    ("topic", topic_reports),
    ("middleware", qos_reports),
]


def doctor(args: argparse.Namespace) -> int:
    with cli_node(settle=True) as node:
        if args.report:
            for _, reports in REPORTS:
                for report in reports(node):
                    print(report.format())
            return 0
        failed: list[str] = []
        for category, check in CHECKS:
            result = check(node)
            for message in result.errors:
                print(f"ros2doctor: UserWarning: ERROR: {message}", file=sys.stderr)
            for message in result.warnings:
                print(f"ros2doctor: UserWarning: {message}", file=sys.stderr)
            if result.errors or (args.include_warnings and result.warnings):
                failed.append(category)
        if failed:
            print(f"\n{len(failed)}/{len(CHECKS)} check(s) failed\n")
            print("Failed modules:", *dict.fromkeys(failed))
        else:
            print(f"\nAll {len(CHECKS)} checks passed\n")
        if args.report_failed and failed:
            for category, reports in REPORTS:
                for report in reports(node) if category in failed else []:
                    print(report.format())
    return 0
