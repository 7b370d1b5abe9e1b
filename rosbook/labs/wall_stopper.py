"""The wall stopper that lab 8's students test: correct, or with one seeded bug.

A student's test file imports ``from wall_stopper import WallStopper, forward_speed``.
``rosbook.labs.lab08`` runs it with a module of that name made for the run from
``variant(bug)``: this file's implementation with each decision on ``_bug`` taken for
that bug (or none), so the module under test holds that variant's code and nothing that
names it. One implementation holds every variant, so a bug is one decision changed, as
in real code. ``variant(bug, rewrite=seed)`` writes it differently, with the same
behaviour (locals renamed, comparisons turned round): a test that recognises the code
instead of testing what it does fails on such a correct node.
"""

from __future__ import annotations

import ast
import math
import random
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from geometry_msgs.msg import Twist
from rclpy.node import Node
from sensor_msgs.msg import LaserScan

#: Half the cone ahead in which an obstacle stops the robot (10 degrees each side).
CONE = math.radians(10)
#: The parameters' defaults.
SPEED = 0.3
STOP_AT = 0.5

#: Each seeded bug, by name, as a student's feedback describes it.
BUGS = {
    "never_stops": "a node that never stops: it drives on whatever its scan shows",
    "cone_behind": (
        "a node whose cone looks behind the robot: it counts ray angles from the first "
        "ray (angle_min) instead of from straight ahead, so an obstacle ahead is not seen"
    ),
    "stops_late": (
        "a node that stops only for an obstacle closer than stop_at, and drives on for "
        "one at exactly stop_at"
    ),
    "wide_cone": (
        "a node that also stops for an obstacle beside its path (a cone of 45 degrees "
        "each side instead of 10)"
    ),
    "drives_blind": "a node that drives at full speed when the scan holds no range ahead",
    "wrong_topic": "a node that publishes its commands on 'cmd' instead of 'cmd_vel'",
    "ignores_stop_at": (
        "a node that ignores its stop_at parameter and always stops at the default 0.5 m"
    ),
}

#: The decision each variant takes away (``variant``): None in this module, correct.
_bug: str | None = None


def forward_speed(
    ranges: Sequence[float],
    angle_min: float,
    angle_increment: float,
    speed: float,
    stop_at: float,
) -> float:
    """``speed``, or 0.0 when a range within ``CONE`` of straight ahead is at most
    ``stop_at`` or when no range lies in the cone."""
    cone = math.radians(45) if _bug == "wide_cone" else CONE
    first = 0.0 if _bug == "cone_behind" else angle_min
    ahead = [r for i, r in enumerate(ranges) if abs(first + i * angle_increment) <= cone]
    if not ahead:
        return speed if _bug == "drives_blind" else 0.0
    if _bug == "never_stops":
        return speed
    closest = min(ahead)
    blocked = closest < stop_at if _bug == "stops_late" else closest <= stop_at
    return 0.0 if blocked else speed


class WallStopper(Node):
    """For each scan on 'scan', publishes one command on 'cmd_vel': ``forward_speed``
    of the scan with the parameters ``speed`` and ``stop_at``."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("wall_stopper", **kwargs)
        self.speed = self.declare_parameter("speed", SPEED).value
        self.stop_at = self.declare_parameter("stop_at", STOP_AT).value
        if _bug == "ignores_stop_at":
            self.stop_at = STOP_AT
        topic = "cmd" if _bug == "wrong_topic" else "cmd_vel"
        self.publisher_ = self.create_publisher(Twist, topic, 10)
        self.subscription = self.create_subscription(LaserScan, "scan", self.on_scan, 10)

    def on_scan(self, msg: LaserScan) -> None:
        cmd = Twist()
        cmd.linear.x = forward_speed(
            msg.ranges, msg.angle_min, msg.angle_increment, self.speed, self.stop_at
        )
        self.publisher_.publish(cmd)


# -- the module under test, made for each run ------------------------------------------

#: This module's top-level names that a variant holds, with the imports they use.
IMPLEMENTATION = ("CONE", "SPEED", "STOP_AT", "forward_speed", "WallStopper")


def variant(bug: str | None = None, rewrite: int | None = None) -> str:
    """The source of the module under test: ``IMPLEMENTATION`` with every decision on
    ``_bug`` taken for ``bug`` (a key of ``BUGS``; None: correct), so that nothing in it
    names the bug; with ``rewrite``, written differently by that seed (same behaviour)."""
    if bug is not None and bug not in BUGS:
        raise ValueError(f"no seeded bug {bug!r}; the bugs: {', '.join(BUGS)}")
    tree = ast.parse(Path(__file__).read_text())
    kept = [node for node in tree.body if _bound(node) & set(IMPLEMENTATION)]
    used = {node.id for part in kept for node in ast.walk(part) if isinstance(node, ast.Name)}
    imports = [
        node
        for node in tree.body
        if isinstance(node, (ast.Import, ast.ImportFrom))
        and (_bound(node) & used or getattr(node, "module", None) == "__future__")
    ]
    module = _Seeded(bug).visit(ast.Module(body=[*imports, *kept], type_ignores=[]))
    if rewrite is not None:
        module = _rewritten(module, random.Random(rewrite))
    source = ast.unparse(ast.fix_missing_locations(module)) + "\n"
    assert "_bug" not in source, "a decision on _bug that variant() cannot take"
    return source


def _bound(node: ast.stmt) -> set[str]:
    """The names a top-level statement binds."""
    if isinstance(node, (ast.Import, ast.ImportFrom)):
        return {(a.asname or a.name).split(".")[0] for a in node.names}
    if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
        return {node.name}
    targets = node.targets if isinstance(node, ast.Assign) else [getattr(node, "target", None)]
    return {t.id for t in targets if isinstance(t, ast.Name)}


class _Seeded(ast.NodeTransformer):
    """``_bug`` replaced by the bug, and each test on it (``_bug == name``) decided."""

    def __init__(self, bug: str | None) -> None:
        self.bug = bug

    def visit_Name(self, node: ast.Name) -> ast.AST:
        return ast.Constant(self.bug) if node.id == "_bug" else node

    def visit_Compare(self, node: ast.Compare) -> ast.AST:
        self.generic_visit(node)
        sides = [node.left, *node.comparators]
        if len(node.ops) == 1 and all(isinstance(side, ast.Constant) for side in sides):
            left, right = (side.value for side in sides)  # type: ignore[attr-defined]
            if isinstance(node.ops[0], (ast.Eq, ast.NotEq)):
                return ast.Constant((left == right) == isinstance(node.ops[0], ast.Eq))
        return node

    def visit_IfExp(self, node: ast.IfExp) -> ast.AST:
        self.generic_visit(node)
        if isinstance(node.test, ast.Constant):
            return node.body if node.test.value else node.orelse
        return node

    def visit_If(self, node: ast.If) -> ast.AST | list[ast.stmt]:
        self.generic_visit(node)
        if isinstance(node.test, ast.Constant):
            return node.body if node.test.value else node.orelse
        return node


#: Each comparison the same turned round (``a < b`` is ``b > a``).
_MIRRORED: dict[type[ast.cmpop], type[ast.cmpop]] = {
    ast.Lt: ast.Gt, ast.Gt: ast.Lt, ast.LtE: ast.GtE, ast.GtE: ast.LtE,
    ast.Eq: ast.Eq, ast.NotEq: ast.NotEq,
}  # fmt: skip


def _rewritten(module: ast.Module, rng: random.Random) -> ast.Module:
    """``module`` written differently, behaving the same: each function's locals renamed
    and a local of no use added (so each function's bytecode differs too), some
    comparisons and conditional expressions turned round (at least one)."""
    for function in [n for n in ast.walk(module) if isinstance(n, ast.FunctionDef)]:
        arguments = {a.arg for a in ast.walk(function.args) if isinstance(a, ast.arg)}
        stored = {
            n.id
            for n in ast.walk(function)
            if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store) and n.id not in arguments
        }
        names = {name: f"{name}_{rng.randrange(16**4):04x}" for name in sorted(stored)}
        for node in ast.walk(function):
            if isinstance(node, ast.Name) and node.id in names:
                node.id = names[node.id]
        unused = ast.Name(f"unused_{rng.randrange(16**4):04x}", ast.Store())
        docstring = int(ast.get_docstring(function) is not None)
        function.body.insert(
            docstring, ast.Assign([unused], ast.Constant(rng.randrange(10**6)), lineno=0)
        )
    turnable = [
        n
        for n in ast.walk(module)
        if isinstance(n, ast.IfExp)
        or (isinstance(n, ast.Compare) and len(n.ops) == 1 and type(n.ops[0]) in _MIRRORED)
    ]
    chosen = [n for n in turnable if rng.random() < 0.5] or turnable[:1]
    for node in chosen:
        if isinstance(node, ast.Compare):
            node.left, node.comparators = node.comparators[0], [node.left]
            node.ops = [_MIRRORED[type(node.ops[0])]()]
        else:
            node.body, node.orelse = node.orelse, node.body
            node.test = ast.UnaryOp(ast.Not(), node.test)
    return module
