"""URDF robot descriptions: load, validate, walk the tree, forward kinematics.

``load(source)`` takes a URDF as an XML string or a file path (a ``.xacro`` file is run
through xacro first), checks it first (so a mistake is reported as *which element* and
*what is wrong*, in one line, not as a parser traceback), then parses it with yourdfpy.
Mesh files are found as ROS finds them (:mod:`rosbook.robots.resources`) and read once,
quietly: a file that loads prints nothing. The returned :class:`Robot` answers the
questions the book and the lab checks ask: which links and joints there are, how they
form a tree below the root link (``base_link``), and where a link is for given joint
positions (forward kinematics, computed here from the joints' origins and axes).
"""

from __future__ import annotations

import io
import logging
import math
import os
import re
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh
import xacro as xacro_processor
import yourdfpy
from xacro import substitution_args

from rosbook.robots import resources

#: Joint types of the URDF specification.
JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
#: Joint types that move with one position value.
MOVING_TYPES = ("revolute", "continuous", "prismatic")
#: Joint types whose ``<axis>`` ROS's parser (urdfdom) ignores.
AXISLESS_TYPES = ("fixed", "floating")
#: xacro's XML namespace, and what marks xacro text left in a URDF.
XACRO_NAMESPACE = "http://www.ros.org/wiki/xacro"
XACRO_MARKS = ("${", "$(")
#: The elements of ``<robot>`` that ROS's parser reads (others are passed on unread).
URDF_ELEMENTS = ("link", "joint", "material")
#: How to run xacro here, for messages about xacro left in a URDF.
RUN_XACRO = "run xacro first: urdf.load('NAME.urdf.xacro') or urdf.load(urdf.xacro(text))"
#: Loggers of the libraries that read URDFs and meshes, silenced while they do.
LIBRARY_LOGGERS = ("yourdfpy", "trimesh", "collada")


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


def _count(count: int, kind: str = "") -> str:
    """'a number', '3 numbers', 'a positive number', '3 positive numbers'."""
    words = f"{kind} number" if kind else "number"
    return f"a {words}" if count == 1 else f"{count} {words}s"


def _numbers(text: str, count: int, element: str, attribute: str) -> list[float]:
    try:
        values = [float(v) for v in text.split()]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise URDFError(element, f"attribute {attribute}={text!r} must be {_count(count)}")
    return values


def _positive(text: str, count: int, element: str, attribute: str) -> list[float]:
    """Numbers that are sizes: a shape of size 0 has nothing to draw or collide with."""
    values = _numbers(text, count, element, attribute)
    if not all(v > 0 for v in values):
        raise URDFError(
            element, f"attribute {attribute}={text!r} must be {_count(count, 'positive')}"
        )
    return values


def _require(node: ET.Element, attribute: str, element: str) -> str:
    value = node.get(attribute)
    if value is None or not value.strip():
        raise URDFError(element, f"missing required attribute {attribute!r}")
    return value


def mesh_path(filename: str, base_dir: Path | None) -> Path | None:
    """Where a mesh's ``filename`` is on disk, found as ROS finds it (None: not found)."""
    return resources.resolve(filename, base_dir).path


def _find_mesh(filename: str, base_dir: Path | None, element: str) -> Path:
    """The mesh file's path; :class:`URDFError` naming ``element`` and where it looked."""
    found = resources.resolve(filename, base_dir)
    if found.path is None:
        raise URDFError(element, f"mesh file {filename!r} not found: {found.why()}")
    return found.path


def _xacro_left(root: ET.Element) -> None:
    """Refuse xacro markup in a URDF: ``xacro:`` elements anywhere, ``${...}`` and
    ``$(...)`` in what ROS's parser reads (links, joints, materials; a ``<gazebo>`` or
    ``<ros2_control>`` block is passed on unread, as urdfdom does)."""
    for top in root:
        parsed = top.tag in URDF_ELEMENTS
        name = top.get("name")
        outer = f'<{_tag(top)} name="{name}">' if name else f"<{_tag(top)}>"
        for node in top.iter():
            where = outer if node is top else f"{outer} <{_tag(node)}>"
            if node.tag.startswith(f"{{{XACRO_NAMESPACE}}}"):
                raise URDFError(where, f"xacro markup is left in the URDF; {RUN_XACRO}")
            for attribute, value in node.attrib.items() if parsed else ():
                if any(mark in value for mark in XACRO_MARKS):
                    raise URDFError(
                        where,
                        f"attribute {attribute}={value!r} is xacro markup left in the URDF; "
                        f"{RUN_XACRO}",
                    )


def _tag(node: ET.Element) -> str:
    """An element's tag as written, with xacro's ``xacro:`` prefix for its namespace."""
    return node.tag.replace(f"{{{XACRO_NAMESPACE}}}", "xacro:")


def _parse(xml: str) -> ET.Element:
    """The XML tree; a NUL byte, an undeclared ``xacro:`` prefix or bad XML is one line."""
    if "\0" in xml:
        line = xml.count("\n", 0, xml.index("\0")) + 1
        raise URDFError("URDF", f"holds a NUL byte (line {line}); a URDF is plain text")
    try:
        return ET.fromstring(xml)
    except ET.ParseError as error:
        if "unbound prefix" in str(error) and "<xacro:" in xml:
            raise URDFError(
                "URDF", f"xacro markup (<xacro:...>) is left in the URDF; {RUN_XACRO}"
            ) from None
        raise URDFError("URDF", f"not well-formed XML ({error})") from None


def validate(xml: str, base_dir: Path | None = None) -> ET.Element:
    """Check a URDF's structure; raise :class:`URDFError` on the first problem found.

    Checked: the XML parses, the root is ``<robot name>``; every link and joint has its
    required attributes and children; link and joint names are unique; each joint's
    parent and child are existing links; no link has two parents; the joints form one
    tree without cycles; numbers in ``xyz``/``rpy``/``axis``/geometry are well formed;
    mesh files exist (relative paths are taken from ``base_dir``).
    """
    root = _parse(xml)
    if root.tag != "robot":
        raise URDFError(f"<{_tag(root)}>", "the root element of a URDF must be <robot>")
    _xacro_left(root)
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
        if axis is not None and kind not in AXISLESS_TYPES:  # urdfdom ignores theirs
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
        _positive(_require(shape, "size", where), 3, where, "size")
    elif shape.tag == "cylinder":
        for attribute in ("radius", "length"):
            _positive(_require(shape, attribute, where), 1, where, attribute)
    elif shape.tag == "sphere":
        _positive(_require(shape, "radius", where), 1, where, "radius")
    elif shape.tag == "mesh":
        filename = _require(shape, "filename", where)
        scale = _numbers(shape.get("scale", "1 1 1"), 3, where, "scale")
        if not all(scale):
            raise URDFError(
                where, f"attribute scale={shape.get('scale')!r} must be {_count(3, 'non-zero')}"
            )
        _find_mesh(filename, base_dir, where)
    else:
        raise URDFError(
            f"{element} <{_tag(shape)}>", "unknown geometry; one of box, cylinder, sphere, mesh"
        )


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
        self._meshes: dict[str, trimesh.Trimesh] = {}

    def mesh(self, filename: str, element: str = "<mesh>") -> trimesh.Trimesh:
        """The triangles of mesh file ``filename`` (a copy; each file is read once).

        Read quietly (no library warnings); a file that cannot be read or has no
        triangles raises :class:`URDFError` naming ``element``.
        """
        if filename not in self._meshes:
            path = _find_mesh(filename, self.base_dir, element)
            try:
                with quiet():
                    mesh = trimesh.load(str(path), force="mesh")
            except Exception as error:  # any reader's failure is the file's problem
                raise URDFError(
                    element, f"mesh file {filename!r} cannot be read ({_one_line(error)})"
                ) from None
            if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
                raise URDFError(element, f"mesh file {filename!r} holds no triangles")
            if not np.all(np.isfinite(mesh.vertices)):
                raise URDFError(
                    element, f"mesh file {filename!r} has vertices that are not numbers"
                )
            self._meshes[filename] = mesh
        return self._meshes[filename].copy()

    @property
    def joints(self) -> list[JointInfo]:
        """Every joint, in document order."""
        return [self.joint(name) for name in self._joints]

    def joint(self, name: str) -> JointInfo:
        """The joint called ``name`` (KeyError naming the joints if there is none)."""
        if name not in self._joints:
            raise KeyError(f"no joint {name!r}; the joints are {', '.join(self._joints)}")
        j = self._joints[name]
        ignored = j.type in AXISLESS_TYPES and not np.any(j.axis)
        axis = (1.0, 0.0, 0.0) if j.axis is None or ignored else tuple(float(v) for v in j.axis)
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

    def joint_position(self, name: str, positions: Mapping[str, float]) -> float:
        """The position of joint ``name`` in ``positions`` (a mimic joint: from its source)."""
        j = self._joints[name]
        if j.mimic is not None:
            source = self.joint_position(j.mimic.joint, positions)
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
            pose = self.joint_transform(j.name, self.joint_position(j.name, positions)) @ pose
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


@contextmanager
def quiet() -> Iterator[None]:
    """Silence the URDF and mesh libraries' log lines and warnings while they read.

    yourdfpy logs lxml's complaints before parsing again, trimesh logs a traceback for
    each texture a COLLADA file names but does not ship: noise under a notebook cell for
    a robot that loads. Only these libraries' loggers, and only inside the block.
    """
    loggers = [logging.getLogger(name) for name in LIBRARY_LOGGERS]
    before = [logger.level for logger in loggers]
    for logger in loggers:  # their modules' loggers (trimesh.util, ...) inherit the level
        logger.setLevel(logging.CRITICAL + 1)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        for logger, level in zip(loggers, before):
            logger.setLevel(level)


def _is_text(source: str | os.PathLike[str]) -> bool:
    return not isinstance(source, os.PathLike) and str(source).lstrip().startswith("<")


def _file(source: str | os.PathLike[str]) -> Path:
    path = Path(source)
    if not path.is_file():
        raise URDFError("URDF", f"file {str(path)!r} not found")
    return path


@contextmanager
def _find_packages_near(folder: Path) -> Iterator[None]:
    """Let xacro's ``$(find PKG)`` find a package as ``package://`` does.

    xacro asks the ament index only (``substitution_args._eval_find``, also behind
    ``$(eval find(...))``); while it runs, the lookup also finds a package's source
    folder above ``folder`` (:func:`rosbook.robots.resources.package_folders`).
    """

    def find(package: str) -> str:
        folders = resources.package_folders(package, folder)
        if not folders:
            raise LookupError(resources.where_searched(package, folder))
        return str(folders[0])

    original = substitution_args._eval_find
    substitution_args._eval_find = find
    substitution_args._eval_dict["find"] = find
    try:
        yield
    finally:
        substitution_args._eval_find = original
        substitution_args._eval_dict["find"] = original


def xacro(source: str | os.PathLike[str], mappings: Mapping[str, str] | None = None) -> str:
    """The URDF that xacro makes of a ``.xacro`` file (a path) or of xacro text.

    ``mappings`` are xacro's arguments (``xacro FILE name:=value``). ``$(find PKG)`` is
    the package's folder, found as for ``package://``. A xacro error is one
    :class:`URDFError` line.
    """
    text = _is_text(source)
    path = None if text else _file(source).absolute()
    args = {str(k): str(v) for k, v in (mappings or {}).items()}
    try:
        with _find_packages_near(Path.cwd() if path is None else path.parent):
            if path is None:
                xacro_processor.init_stacks(None)
                doc = xacro_processor.parse(str(source).lstrip())
                xacro_processor.process_doc(doc, mappings=args)
            else:
                doc = xacro_processor.process_file(str(path), mappings=args)
    except Exception as error:  # xacro's own, expat's, a file's: the document's problem
        where = "xacro" if path is None else f"xacro {path.name}"
        raise URDFError(where, _xacro_message(error)) from None
    return doc.toprettyxml(indent="  ")


def _one_line(error: object) -> str:
    """An error's text on one line (a library's message may span several)."""
    return " ".join(str(error).split())


def _xacro_message(error: BaseException) -> str:
    """A xacro error in one line: its parts once each, without Python's class names."""
    parts: list[str] = []
    for part in (*error.args[:1], getattr(error, "exc", None), getattr(error, "suffix", None)):
        text = _one_line(re.sub(r"<class '[\w.]+'>: ", "", str(part or "")))
        if text and not any(text in seen for seen in parts):
            parts.append(text)
    return " ".join(parts) or repr(error)


def _read(
    source: str | os.PathLike[str], mappings: Mapping[str, str] | None = None
) -> tuple[str, Path | None]:
    """The URDF text (xacro run for a ``.xacro`` file) and the folder it was in."""
    if _is_text(source):
        return str(source), None
    path = _file(source)
    if path.suffix == ".xacro":
        return xacro(path, mappings), path.resolve().parent
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except OSError as error:
        raise URDFError("URDF", f"file {str(path)!r} cannot be read ({error.strerror})") from None
    except UnicodeDecodeError as error:
        raise URDFError("URDF", f"file {str(path)!r} is not UTF-8 text ({error})") from None
    return text, path.resolve().parent


def load(
    source: str | os.PathLike[str],
    base_dir: str | os.PathLike[str] | None = None,
    mappings: Mapping[str, str] | None = None,
) -> Robot:
    """Validate and load a URDF given as XML text or as a file path.

    A ``.xacro`` file is run through xacro first, with ``mappings`` as its arguments
    (``xacro FILE name:=value``; see :func:`xacro`). Relative mesh
    paths are taken from ``base_dir`` (default: the URDF file's folder, or the current
    folder for XML text). Raises :class:`URDFError`, one line naming the element and the
    problem, for a malformed URDF; reading it prints nothing.
    """
    xml, folder = _read(source, mappings)
    xml = xml.lstrip()  # as urdfdom: blank lines before <?xml ...?> are no error
    folder = Path(base_dir) if base_dir is not None else folder
    root = validate(xml, folder)
    try:
        with quiet():
            model = yourdfpy.URDF.load(
                io.BytesIO(xml.encode()),
                build_scene_graph=False,
                load_meshes=False,
                filename_handler=lambda name: str(mesh_path(name, folder)),
                mesh_dir=str(folder or Path.cwd()),
            )
    except Exception as error:  # what the checks above let through, in one line
        raise URDFError("URDF", f"yourdfpy cannot read it ({_one_line(error)})") from None
    robot = Robot(model, xml, folder)
    for link in root.findall("link"):
        for visual in link.findall("visual"):
            mesh = visual.find("geometry/mesh")
            if mesh is not None:  # read now: a broken mesh is the URDF's error, not the view's
                robot.mesh(
                    mesh.get("filename", ""), f'<link name="{link.get("name")}"> <visual> <mesh>'
                )
    return robot
