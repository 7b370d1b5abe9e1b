"""URDF robot descriptions: load, validate, walk the tree, forward kinematics.

``load(source)`` takes a URDF as an XML string or a file path, checks it first (so a
mistake is reported as *which element* and *what is wrong*, not as a parser
traceback), then parses it with yourdfpy. The returned :class:`Robot` answers the
questions the book and the lab checks ask: which links and joints there are, how they
form a tree below the root link (``base_link``), and where a link is for given joint
positions (forward kinematics, computed here from the joints' origins and axes).
"""

from __future__ import annotations

import io
import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yourdfpy

#: Joint types of the URDF specification.
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
#: Joint types that move with one position value.
MOVING_TYPES = ("revolute", "continuous", "prismatic")


class URDFError(ValueError):
    """A malformed URDF: ``element`` names the element, ``problem`` what is wrong."""

    def __init__(self, element: str, problem: str) -> None:
        super().__init__(f"{element}: {problem}")
        self.element = element
        self.problem = problem


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """The 3x3 rotation of URDF's ``rpy``: about fixed x, then y, then z (Rz Ry Rx)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def transform(
    xyz: tuple[float, float, float] = (0, 0, 0), rpy: tuple[float, float, float] = (0, 0, 0)
) -> np.ndarray:
    """A 4x4 homogeneous transform from a URDF ``<origin xyz rpy>``."""
    t = np.eye(4)
    t[:3, :3] = rpy_matrix(*rpy)
    t[:3, 3] = xyz
    return t


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """The 3x3 rotation by ``angle`` about the unit vector ``axis`` (Rodrigues)."""
    x, y, z = axis / np.linalg.norm(axis)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


# --- validation -----------------------------------------------------------------------


def _numbers(text: str, count: int, element: str, attribute: str) -> list[float]:
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    if len(values) != count:
        raise URDFError(element, f"attribute {attribute}={text!r} must be {count} numbers")
    return values


def _require(node: ET.Element, attribute: str, element: str) -> str:
    value = node.get(attribute)
    if value is None or not value.strip():
        raise URDFError(element, f"missing required attribute {attribute!r}")
    return value


def mesh_path(filename: str, base_dir: Path | None) -> Path | None:
    """Where a mesh's ``filename`` points on disk (None for package:// without ROS)."""
    if filename.startswith("file://"):
        return Path(filename[len("file://") :])
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        # Without a ROS workspace, look for the package folder beside the URDF.
        return (base_dir or Path.cwd()) / rest.split("/", 1)[1] if "/" in rest else None
    path = Path(filename)
    return path if path.is_absolute() else (base_dir or Path.cwd()) / path


def validate(xml: str, base_dir: Path | None = None) -> ET.Element:
    """Check a URDF's structure; raise :class:`URDFError` on the first problem found.

    Checked: the XML parses, the root is ``<robot name>``; every link and joint has its
    required attributes and children; link and joint names are unique; each joint's
    parent and child are existing links; no link has two parents; the joints form one
    tree without cycles; numbers in ``xyz``/``rpy``/``axis``/geometry are well formed;
    mesh files exist (relative paths are taken from ``base_dir``).
    """
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as error:
        raise URDFError("URDF", f"not well-formed XML ({error})") from None
    if root.tag != "robot":
        raise URDFError(f"<{root.tag}>", "the root element of a URDF must be <robot>")
    _require(root, "name", "<robot>")

    links: list[str] = []
    for node in root.findall("link"):
        name = _require(node, "name", "<link>")
        element = f'<link name="{name}">'
        if name in links:
            raise URDFError(element, "a second link has this name; link names must be unique")
        links.append(name)
        for kind in ("visual", "collision"):
            for part in node.findall(kind):
                _check_part(part, f"{element} <{kind}>", base_dir)
    if not links:
        raise URDFError("<robot>", "has no <link>")

    parent_of: dict[str, str] = {}
    joints: set[str] = set()
    for node in root.findall("joint"):
        name = _require(node, "name", "<joint>")
        element = f'<joint name="{name}">'
        if name in joints:
            raise URDFError(element, "a second joint has this name; joint names must be unique")
        joints.add(name)
        kind = _require(node, "type", element)
        if kind not in JOINT_TYPES:
            raise URDFError(element, f"unknown type {kind!r}; one of {', '.join(JOINT_TYPES)}")
        ends = {}
        for end in ("parent", "child"):
            tag = node.find(end)
            if tag is None:
                raise URDFError(element, f"missing <{end} link=...>")
            ends[end] = _require(tag, "link", f"{element} <{end}>")
            if ends[end] not in links:
                raise URDFError(
                    element,
                    f"unknown {end} link {ends[end]!r}; the links are {', '.join(links)}",
                )
        if ends["parent"] == ends["child"]:
            raise URDFError(element, f"link {ends['child']!r} is its own parent")
        if ends["child"] in parent_of:
            raise URDFError(
                element,
                f"link {ends['child']!r} already has the parent {parent_of[ends['child']]!r}; "
                "in a URDF tree every link has at most one parent joint",
            )
        parent_of[ends["child"]] = ends["parent"]
        origin = node.find("origin")
        if origin is not None:
            _numbers(origin.get("xyz", "0 0 0"), 3, f"{element} <origin>", "xyz")
            _numbers(origin.get("rpy", "0 0 0"), 3, f"{element} <origin>", "rpy")
        axis = node.find("axis")
        if axis is not None:
            values = _numbers(axis.get("xyz", "1 0 0"), 3, f"{element} <axis>", "xyz")
            if not any(values):
                raise URDFError(f"{element} <axis>", "the axis xyz='0 0 0' has no direction")
        if kind in ("revolute", "prismatic"):
            limit = node.find("limit")
            if limit is None:
                raise URDFError(
                    element, f"a {kind} joint needs <limit lower upper effort velocity>"
                )
            for attribute in ("effort", "velocity"):
                _require(limit, attribute, f"{element} <limit>")

    for link in parent_of:
        seen = [link]
        while seen[-1] in parent_of:
            seen.append(parent_of[seen[-1]])
            if seen[-1] == link:
                raise URDFError(
                    "<joint>s", f"the joints form a cycle: {' <- '.join(reversed(seen))}"
                )
    roots = [link for link in links if link not in parent_of]
    if len(roots) != 1:
        raise URDFError(
            "<robot>",
            f"the links must form one tree, but {len(roots)} links have no parent joint: "
            f"{', '.join(roots)} (connect them with joints)",
        )
    return root


def _check_part(part: ET.Element, element: str, base_dir: Path | None) -> None:
    """Check the geometry (and origin) of a ``<visual>`` or ``<collision>``."""
    origin = part.find("origin")
    if origin is not None:
        _numbers(origin.get("xyz", "0 0 0"), 3, f"{element} <origin>", "xyz")
        _numbers(origin.get("rpy", "0 0 0"), 3, f"{element} <origin>", "rpy")
    geometry = part.find("geometry")
    if geometry is None or len(geometry) == 0:
        raise URDFError(element, "missing <geometry> with a box, cylinder, sphere or mesh")
    shape = geometry[0]
    where = f"{element} <{shape.tag}>"
    if shape.tag == "box":
        _numbers(_require(shape, "size", where), 3, where, "size")
    elif shape.tag == "cylinder":
        for attribute in ("radius", "length"):
            _numbers(_require(shape, attribute, where), 1, where, attribute)
    elif shape.tag == "sphere":
        _numbers(_require(shape, "radius", where), 1, where, "radius")
    elif shape.tag == "mesh":
        filename = _require(shape, "filename", where)
        path = mesh_path(filename, base_dir)
        if path is None or not path.is_file():
            raise URDFError(where, f"mesh file {filename!r} not found (looked for {path})")
    else:
        raise URDFError(where, "unknown geometry; one of box, cylinder, sphere, mesh")


# --- the robot ----------------------------------------------------------------------


@dataclass(frozen=True)
class JointInfo:
    """A joint as the tree sees it: its name, type, parent and child links, axis."""

    name: str
    type: str
    parent: str
    child: str
    axis: tuple[float, float, float]


class Robot:
    """A loaded URDF: its tree of links and joints, and forward kinematics."""

    def __init__(self, model: yourdfpy.URDF, xml: str, base_dir: Path | None) -> None:
        self.model = model
        self.xml = xml
        self.base_dir = base_dir
        robot = model.robot
        self.name: str = robot.name
        self.links: list[str] = [link.name for link in robot.links]
        self._joints = {j.name: j for j in robot.joints}
        self._parent_joint = {j.child: j for j in robot.joints}
        self.root: str = next(link for link in self.links if link not in self._parent_joint)
        # As urdfdom does: a material given a colour inside one link's <visual> can be
        # referred to by name from another link. The first definition counts, as in urdfdom.
        self.materials = {m.name: m for m in robot.materials if m.name}
        for link in robot.links:
            for visual in link.visuals:
                material = visual.material
                if material is not None and material.name and material.color is not None:
                    self.materials.setdefault(material.name, material)

    @property
    def joints(self) -> list[JointInfo]:
        """Every joint, in document order."""
        return [self.joint(name) for name in self._joints]

    def joint(self, name: str) -> JointInfo:
        """The joint called ``name`` (KeyError naming the joints if there is none)."""
        if name not in self._joints:
            raise KeyError(f"no joint {name!r}; the joints are {', '.join(self._joints)}")
        j = self._joints[name]
        axis = (1.0, 0.0, 0.0) if j.axis is None else tuple(float(v) for v in j.axis)
        return JointInfo(j.name, j.type, j.parent, j.child, axis)  # type: ignore[arg-type]

    @property
    def moving_joints(self) -> list[str]:
        """Joints with one position value (revolute, continuous, prismatic), not mimics."""
        return [j.name for j in self._joints.values() if j.type in MOVING_TYPES and j.mimic is None]

    def children(self, link: str) -> list[str]:
        """The links attached below ``link`` by one joint."""
        return [j.child for j in self._joints.values() if j.parent == link]

    def parent_joint(self, link: str) -> JointInfo | None:
        """The joint whose child is ``link`` (None for the root)."""
        j = self._parent_joint.get(link)
        return None if j is None else self.joint(j.name)

    def tree(self) -> str:
        """The link/joint tree as indented text, root first (like ``urdf_to_graphviz``)."""
        lines = [self.root]

        def walk(link: str, indent: str) -> None:
            below = [j for j in self._joints.values() if j.parent == link]
            for k, j in enumerate(below):
                last = k == len(below) - 1
                lines.append(f"{indent}{'└─' if last else '├─'} {j.name} ({j.type}) -> {j.child}")
                walk(j.child, indent + ("   " if last else "│  "))

        walk(self.root, "")
        return "\n".join(lines)

    def joint_transform(self, name: str, position: float = 0.0) -> np.ndarray:
        """Parent link frame -> child link frame for the joint at ``position``.

        The joint's ``<origin>`` places the joint frame in the parent; the motion
        (rotation about or translation along ``axis``) happens in that joint frame.
        """
        j = self._joints[name]
        origin = np.eye(4) if j.origin is None else np.asarray(j.origin, dtype=float)
        axis = np.array([1.0, 0.0, 0.0]) if j.axis is None else np.asarray(j.axis, dtype=float)
        motion = np.eye(4)
        if j.type in ("revolute", "continuous"):
            motion[:3, :3] = axis_angle(axis, position)
        elif j.type == "prismatic":
            motion[:3, 3] = axis / np.linalg.norm(axis) * position
        return origin @ motion

    def _position(self, name: str, positions: Mapping[str, float]) -> float:
        j = self._joints[name]
        if j.mimic is not None:
            source = self._position(j.mimic.joint, positions)
            return source * (j.mimic.multiplier or 1.0) + (j.mimic.offset or 0.0)
        return float(positions.get(name, 0.0))

    def pose(self, link: str, positions: Mapping[str, float] | None = None) -> np.ndarray:
        """The 4x4 pose of ``link`` in the root frame for the given joint positions.

        ``positions`` maps joint names to angles (rad) or displacements (m); joints not
        named stay at 0. Forward kinematics: the product of the joint transforms on the
        path from the root down to ``link``.
        """
        if link not in self.links:
            raise KeyError(f"no link {link!r}; the links are {', '.join(self.links)}")
        positions = positions or {}
        unknown = set(positions) - set(self._joints)
        if unknown:
            raise KeyError(f"no joint(s) {sorted(unknown)}; the joints are {list(self._joints)}")
        pose = np.eye(4)
        while link in self._parent_joint:
            j = self._parent_joint[link]
            pose = self.joint_transform(j.name, self._position(j.name, positions)) @ pose
            link = j.parent
        return pose

    def poses(self, positions: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
        """Every link's pose in the root frame (see :meth:`pose`)."""
        return {link: self.pose(link, positions) for link in self.links}

    def position(self, link: str, positions: Mapping[str, float] | None = None) -> np.ndarray:
        """The origin of ``link`` in the root frame, as (x, y, z)."""
        return self.pose(link, positions)[:3, 3]

    def axis_in_root(self, joint: str, positions: Mapping[str, float] | None = None) -> np.ndarray:
        """The unit axis of ``joint`` expressed in the root frame."""
        j = self.joint(joint)
        frame = self.pose(j.parent, positions) @ self.joint_transform(joint, 0.0)
        axis = frame[:3, :3] @ np.asarray(j.axis)
        return axis / np.linalg.norm(axis)

    def __repr__(self) -> str:
        return f"<Robot {self.name!r}: {len(self.links)} links, {len(self._joints)} joints>"


def _read(source: str | os.PathLike[str]) -> tuple[str, Path | None]:
    """The XML text and the folder relative mesh paths start from."""
    if isinstance(source, os.PathLike) or not str(source).lstrip().startswith("<"):
        path = Path(source)
        if not path.is_file():
            raise URDFError("URDF", f"file {str(path)!r} not found")
        return path.read_text(), path.resolve().parent
    return str(source), None


def load(source: str | os.PathLike[str], base_dir: str | os.PathLike[str] | None = None) -> Robot:
    """Validate and load a URDF given as XML text or as a file path.

    Relative mesh paths are taken from ``base_dir`` (default: the URDF file's folder,
    or the current folder for XML text). Raises :class:`URDFError` for a malformed URDF.
    """
    xml, folder = _read(source)
    folder = Path(base_dir) if base_dir is not None else folder
    validate(xml, folder)
    mesh_dir = str(folder or Path.cwd())

    def find_mesh(filename: str) -> str:
        return str(mesh_path(filename, Path(mesh_dir)))

    model = yourdfpy.URDF.load(
        io.BytesIO(xml.encode()),
        build_scene_graph=False,
        load_meshes=False,
        filename_handler=find_mesh,
        mesh_dir=mesh_dir,
    )
    return Robot(model, xml, folder)
