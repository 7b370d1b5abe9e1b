"""URDF files written for a full ROS install: package:// meshes, xacro, ROS's tolerance.

The robots are the fixture packages of tests/fixtures/urdf (see tests/urdf_fixtures.py):
``urdf_tour`` uses what the ROS URDF tutorial's robots use (shapes, origins, named
materials, package:// COLLADA meshes, collision and inertia, xacro properties and
macros); ``arm_description`` is a ``<robot>_description`` package that colcon installs.
A file ROS reads is read here; a broken one is one line naming the element.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import urdf_fixtures

from rosbook.launch.workspace import Workspace
from rosbook.robots import urdf
from rosbook.robots.urdf import URDFError
from rosbook.viz import scene as viz

RUN_XACRO = "run xacro first: urdf.load('NAME.urdf.xacro') or urdf.load(urdf.xacro(text))"


@pytest.fixture(scope="module")
def tour(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The urdf_tour package, meshes written, in a folder of its own name."""
    return urdf_fixtures.package("urdf_tour", tmp_path_factory.mktemp("src"))


@pytest.fixture(autouse=True)
def no_ament_index(monkeypatch: pytest.MonkeyPatch) -> None:
    """No workspace is sourced unless a test sources one."""
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)


def drawn_vertices(scene: viz.Scene, path: str) -> np.ndarray:
    """The vertices MeshCat is given for the object at ``path`` (its last set_object)."""
    command = [c for c in scene.commands if c["type"] == "set_object" and c["path"] == path][-1]
    position = command["object"]["geometries"][0]["data"]["attributes"]["position"]
    return np.frombuffer(position["array"].data, dtype=np.float32).reshape(-1, 3)


def assert_every_visual_drawn(robot: urdf.Robot, scene: viz.Scene) -> None:
    for link in robot.model.robot.links:
        assert f"/meshcat/{robot.name}/{link.name}/frame" in scene.paths, link.name
        for i in range(len(link.visuals)):
            assert f"/meshcat/{robot.name}/{link.name}/visual_{i}" in scene.paths, link.name


def error_of(source: str | Path) -> str:
    with pytest.raises(URDFError) as error:
        urdf.load(source)
    assert "\n" not in str(error.value), str(error.value)
    return str(error.value)


def error_of_in(text: str, folder: Path) -> str:
    """The one-line error of loading URDF ``text`` whose files are in ``folder``."""
    with pytest.raises(URDFError) as error:
        urdf.load(text, base_dir=folder)
    assert "\n" not in str(error.value), str(error.value)
    return str(error.value)


def one_link(visual: str, name: str = "base_link") -> str:
    link = f'<link name="{name}"><visual><geometry>{visual}</geometry></visual></link>'
    return f'<robot name="r">{link}</robot>'


# --- the tutorial's kinds of robots, from a package ------------------------------------


@pytest.mark.parametrize("name", ["shapes.urdf", "gripper.urdf", "gripper.urdf.xacro"])
def test_each_tutorial_style_robot_loads_and_draws_every_visual(tour: Path, name: str) -> None:
    robot = urdf.load(tour / "urdf" / name)
    assert_every_visual_drawn(robot, viz.show(robot))


def test_package_uri_meshes_come_from_the_packages_folder_with_their_whole_path(
    tour: Path,
) -> None:
    robot = urdf.load(tour / "urdf" / "gripper.urdf")
    found = urdf.mesh_path("package://urdf_tour/meshes/tips/finger_tip.dae", robot.base_dir)
    assert found == tour / "meshes" / "tips" / "finger_tip.dae"
    scene = viz.RobotView(robot).scene()
    tip = drawn_vertices(scene, "/meshcat/gripper/left_tip/visual_0")
    np.testing.assert_allclose(np.ptp(tip, axis=0), [0.04, 0.015, 0.015], rtol=1e-5)
    finger = drawn_vertices(scene, "/meshcat/gripper/left_finger/visual_0")
    np.testing.assert_allclose(np.ptp(finger, axis=0), [0.1, 0.02, 0.02], rtol=1e-5)


def test_a_package_is_found_by_the_name_in_its_package_xml(tmp_path: Path) -> None:
    """A clone whose folder is not called as the package (urdf-tour-main)."""
    folder = urdf_fixtures.package("urdf_tour", tmp_path, folder_name="urdf-tour-main")
    robot = urdf.load(folder / "urdf" / "gripper.urdf")
    found = urdf.mesh_path("package://urdf_tour/meshes/finger.dae", robot.base_dir)
    assert found == folder / "meshes" / "finger.dae"


def test_a_description_package_beside_the_urdf_is_found(tmp_path: Path) -> None:
    urdf_fixtures.package("arm_description", tmp_path)
    beside = tmp_path / "arm.urdf"
    beside.write_text((tmp_path / "arm_description" / "urdf" / "arm.urdf").read_text())
    robot = urdf.load(beside)
    assert urdf.mesh_path("package://arm_description/meshes/base.stl", robot.base_dir) == (
        tmp_path / "arm_description" / "meshes" / "base.stl"
    )
    assert_every_visual_drawn(robot, viz.show(robot))


def test_an_installed_description_is_found_through_the_ament_index(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """colcon builds the package; after sourcing install/, the URDF's text (no file to
    start from) finds its meshes, and xacro's $(find), in install/.../share/."""
    workspace = Workspace(tmp_path / "ws")
    urdf_fixtures.package("arm_description", workspace.src)
    built = workspace.build(symlink_install=False)
    assert built.ok, built.output
    share = workspace.install / "arm_description" / "share" / "arm_description"
    text = (share / "urdf" / "arm.urdf").read_text()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert error_of(text) == (
        '<link name="base_link"> <visual> <mesh>: mesh file '
        "'package://arm_description/meshes/base.stl' not found: no package 'arm_description' "
        "in the ament index (AMENT_PREFIX_PATH is not set) nor a folder with its package.xml "
        f"at or above {elsewhere}"
    )
    with workspace.sourced():
        robot = urdf.load(text)
        assert urdf.mesh_path("package://arm_description/meshes/link.stl", None) == (
            share / "meshes" / "link.stl"
        )
        assert_every_visual_drawn(robot, viz.show(robot))
        found = urdf.xacro(
            '<robot name="a" xmlns:xacro="http://www.ros.org/wiki/xacro">'
            '<link name="b"><visual><geometry>'
            '<mesh filename="file://$(find arm_description)/meshes/base.stl"/>'
            "</geometry></visual></link></robot>"
        )
        assert f'filename="file://{share}/meshes/base.stl"' in found


# --- file://, relative paths, and what cannot be found -----------------------------------


def test_file_uris_and_relative_paths_are_read_as_ros_reads_them(tour: Path) -> None:
    meshes = tour / "meshes"
    folder = tour / "urdf"
    assert urdf.mesh_path(f"file://{meshes}/finger.dae", folder) == meshes / "finger.dae"
    spaced = tour / "with space"
    spaced.mkdir()
    (spaced / "finger.dae").write_bytes((meshes / "finger.dae").read_bytes())
    assert urdf.mesh_path(f"file://{tour}/with%20space/finger.dae", folder) == (
        spaced / "finger.dae"
    )
    assert urdf.mesh_path("../meshes/finger.dae", folder) == folder / ".." / "meshes" / "finger.dae"
    assert urdf.mesh_path(str(meshes / "finger.dae"), folder) == meshes / "finger.dae"


def test_an_unresolvable_mesh_is_one_line_naming_the_link_the_uri_and_where_it_looked(
    tour: Path, tmp_path: Path
) -> None:
    missing = tour / "urdf" / "missing_mesh.urdf"
    missing.write_text(one_link('<mesh filename="package://urdf_tour/meshes/palm.dae"/>', "palm"))
    assert error_of(missing) == (
        "<link name=\"palm\"> <visual> <mesh>: mesh file 'package://urdf_tour/meshes/palm.dae' "
        f"not found: looked for {tour}/meshes/palm.dae"
    )
    alone = tmp_path / "alone.urdf"
    alone.write_text(one_link('<mesh filename="package://no_such_pkg/meshes/palm.stl"/>'))
    assert error_of(alone) == (
        '<link name="base_link"> <visual> <mesh>: mesh file '
        "'package://no_such_pkg/meshes/palm.stl' not found: no package 'no_such_pkg' in the "
        "ament index (AMENT_PREFIX_PATH is not set) nor a folder with its package.xml at or "
        f"above {tmp_path}"
    )
    assert error_of(one_link('<mesh filename="https://example.com/palm.stl"/>')) == (
        "<link name=\"base_link\"> <visual> <mesh>: mesh file 'https://example.com/palm.stl' "
        "not found: https:// is not read here; use package://, file:// or a path"
    )


# --- ROS's tolerance ----------------------------------------------------------------------


def test_a_fixed_joints_zero_axis_is_ignored_as_urdfdom_ignores_it(tour: Path) -> None:
    robot = urdf.load(tour / "urdf" / "shapes.urdf")
    assert robot.joint("leg_to_foot").type == "fixed"
    np.testing.assert_allclose(robot.position("foot"), [0, -0.2, -0.3], atol=1e-9)
    moving = one_link("<box size='1 1 1'/>").replace(
        "</robot>",
        '<link name="arm"/><joint name="turn" type="continuous"><parent link="base_link"/>'
        '<child link="arm"/><axis xyz="0 0 0"/></joint></robot>',
    )
    assert error_of(moving) == "<joint name=\"turn\"> <axis>: the axis xyz='0 0 0' has no direction"


def test_blank_lines_before_the_xml_declaration_are_accepted(tmp_path: Path) -> None:
    text = '\n\n  \t\n<?xml version="1.0"?>\n' + one_link("<sphere radius='0.1'/>")
    assert urdf.load(text).links == ["base_link"]
    path = tmp_path / "blank_first.urdf"
    path.write_text(text)
    assert urdf.load(path).links == ["base_link"]


# --- one line for a broken file ---------------------------------------------------------------


@pytest.mark.parametrize(
    ("shape", "message"),
    [
        ('<sphere radius="0"/>', "<sphere>: attribute radius='0' must be a positive number"),
        (
            '<cylinder radius="0.1" length="-1"/>',
            "<cylinder>: attribute length='-1' must be a positive number",
        ),
        ('<box size="0.1 0 0.1"/>', "<box>: attribute size='0.1 0 0.1' must be 3 positive numbers"),
        ('<sphere radius="nan"/>', "<sphere>: attribute radius='nan' must be a number"),
        ('<sphere radius="big"/>', "<sphere>: attribute radius='big' must be a number"),
        (
            '<capsule radius="0.1" length="0.2"/>',
            "<capsule>: unknown geometry; one of box, cylinder, sphere, mesh",
        ),
    ],
    ids=["zero sphere", "negative cylinder", "flat box", "nan", "word", "capsule"],
)
def test_degenerate_or_unsupported_geometry_is_one_line(shape: str, message: str) -> None:
    assert error_of(one_link(shape, "head")) == f'<link name="head"> <visual> {message}'


def test_a_mesh_file_without_triangles_or_unreadable_is_one_line(tmp_path: Path) -> None:
    (tmp_path / "empty.stl").write_text("solid hand\nendsolid hand\n")
    (tmp_path / "junk.dae").write_text("not a COLLADA file")
    hand = '<link name="hand"> <visual> <mesh>: '
    empty = one_link('<mesh filename="empty.stl"/>', "hand")
    assert error_of_in(empty, tmp_path) == hand + "mesh file 'empty.stl' holds no triangles"
    junk = error_of_in(one_link('<mesh filename="junk.dae"/>', "hand"), tmp_path)
    assert junk.startswith(hand + "mesh file 'junk.dae' cannot be read ("), junk


def test_a_nul_byte_is_one_line(tmp_path: Path) -> None:
    text = one_link("<sphere radius='0.1'/>").replace("<link", "\n<link\0", 1)
    assert error_of(text) == "URDF: holds a NUL byte (line 2); a URDF is plain text"
    path = tmp_path / "nul.urdf"
    path.write_text(text)
    assert error_of(path) == "URDF: holds a NUL byte (line 2); a URDF is plain text"


def test_xacro_left_in_a_urdf_says_to_run_xacro(tour: Path) -> None:
    xacro_text = (tour / "urdf" / "gripper.urdf.xacro").read_text()
    left = tour / "urdf" / "left_over.urdf"
    left.write_text(xacro_text)
    assert error_of(left) == (
        '<xacro:property name="body_radius">: xacro markup is left in the URDF; ' + RUN_XACRO
    )
    attribute = one_link('<cylinder radius="${width}" length="0.6"/>')
    assert error_of(attribute) == (
        "<link name=\"base_link\"> <cylinder>: attribute radius='${width}' is xacro markup "
        "left in the URDF; " + RUN_XACRO
    )
    passed_on = one_link('<sphere radius="0.1"/>').replace(
        "</robot>", '<gazebo><plugin filename="${plugin}.so"/></gazebo></robot>'
    )
    assert urdf.load(passed_on).links == ["base_link"]  # urdfdom does not read <gazebo>
    undeclared = one_link('<sphere radius="0.1"/>').replace(
        "</robot>", '<xacro:include filename="x.xacro"/></robot>'
    )
    assert error_of(undeclared) == (
        "URDF: xacro markup (<xacro:...>) is left in the URDF; " + RUN_XACRO
    )
    assert urdf.load(urdf.xacro(left), base_dir=left.parent).name == "gripper"  # the remedy


def test_a_xacro_file_gives_the_robot_of_the_urdf_it_stands_for(tour: Path) -> None:
    made = urdf.load(tour / "urdf" / "gripper.urdf.xacro")
    written = urdf.load(tour / "urdf" / "gripper.urdf")
    assert made.links == written.links
    q = {"pole_slide": -0.1, "left_finger_joint": 0.3, "right_finger_joint": 0.2}
    for link in made.links:
        np.testing.assert_allclose(made.pose(link, q), written.pose(link, q), atol=1e-9)
    tip = next(link for link in made.model.robot.links if link.name == "left_tip")
    # $(find urdf_tour) is the package's folder, found as package:// finds it
    assert tip.visuals[0].geometry.mesh.filename == f"file://{tour}/meshes/tips/finger_tip.dae"


def test_xacro_arguments_are_given_as_on_the_command_line(tour: Path) -> None:
    """xacro FILE radius:=0.3, as a launch file's Command(['xacro ', ...]) runs it."""
    made = tour / "urdf" / "ball.urdf.xacro"
    made.write_text(
        '<robot name="ball" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:arg name="radius" default="0.1"/><link name="base_link"><visual><geometry>'
        '<sphere radius="$(arg radius)"/></geometry></visual></link></robot>'
    )
    default = urdf.load(made)
    given = urdf.load(made, mappings={"radius": "0.3"})
    assert default.model.robot.links[0].visuals[0].geometry.sphere.radius == 0.1
    assert given.model.robot.links[0].visuals[0].geometry.sphere.radius == 0.3


def test_a_xacro_error_is_one_line(tour: Path) -> None:
    broken = tour / "urdf" / "broken.urdf.xacro"
    broken.write_text(
        '<robot name="b" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a">'
        '<visual><geometry><sphere radius="${radius}"/></geometry></visual></link></robot>'
    )
    assert (
        error_of(broken) == "xacro broken.urdf.xacro: name 'radius' is not defined "
        "when evaluating expression 'radius'"
    )
    lost = tour / "urdf" / "lost.urdf.xacro"
    lost.write_text(
        '<robot name="b" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a">'
        '<visual><geometry><mesh filename="file://$(find no_such_pkg)/m.stl"/></geometry>'
        "</visual></link></robot>"
    )
    assert error_of(lost) == (
        "xacro lost.urdf.xacro: no package 'no_such_pkg' in the ament index "
        "(AMENT_PREFIX_PATH is not set) nor a folder with its package.xml at or above "
        f"{tour / 'urdf'}"
    )


# --- nothing printed for a file that loads ---------------------------------------------------


def test_a_robot_that_loads_prints_nothing(tour: Path) -> None:
    """In a fresh process (as a notebook kernel): loading and drawing the gripper, whose
    COLLADA meshes name a texture that is not there, prints nothing; trimesh alone
    prints a traceback for it."""
    helper = str(Path(urdf_fixtures.__file__))
    paths = [str(tour / "urdf" / name) for name in ("gripper.urdf", "gripper.urdf.xacro")]
    drawn = subprocess.run(
        [sys.executable, helper, "draw", *paths], capture_output=True, text=True, check=False
    )
    assert drawn.returncode == 0, drawn.stderr
    assert (drawn.stdout, drawn.stderr) == ("", "")
    read = subprocess.run(
        [sys.executable, helper, "read", str(tour / "meshes" / "finger.dae")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert "Traceback" in read.stderr and urdf_fixtures.MISSING_TEXTURE in read.stderr
