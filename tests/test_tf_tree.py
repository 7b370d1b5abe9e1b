"""rosbook.viz.tf_tree: tf2's frame tree drawn in MeshCat where tf2 puts each frame,
live on a node's timer and recorded, from frames broadcast over real DDS on simulated time."""

from __future__ import annotations

import base64
import math
import re
import time

import numpy as np
import pytest
import umsgpack
from geometry_msgs.msg import TransformStamped
from rclpy.node import Node
from rclpy.time import Time

from rosbook import robots
from rosbook.runtime.session import Session
from rosbook.runtime.transforms import (
    Buffer,
    StaticTransformBroadcaster,
    TransformBroadcaster,
    TransformListener,
)
from rosbook.sim.node import Simulation
from rosbook.sim.physics import World
from rosbook.viz import scene as viz
from rosbook.viz import tf_tree

#: base_link -> laser_frame, static: 10 cm ahead, 11 cm up, turned 0.5 rad.
MOUNT = (0.1, 0.0, 0.11, 0.5)
#: The carrot's circle (radius, rad/s) and the base's drive (x, y per second, yaw rate).
CIRCLE = (1.0, 0.3)
DRIVE = (0.2, 0.1, 0.4)
#: Sim seconds to wait at most for a transform (a hang guard: the run stops when it is there).
PATIENCE = 120.0


def stamped(parent: str, child: str, now: Time, x: float, y: float, z: float, yaw: float):
    t = TransformStamped()
    t.header.stamp = now.to_msg()
    t.header.frame_id, t.child_frame_id = parent, child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = x, y, z
    t.transform.rotation.z, t.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return t


def base_at(seconds: float) -> tuple[float, float, float]:
    vx, vy, w = DRIVE
    return vx * seconds, vy * seconds, w * seconds


def carrot_at(seconds: float) -> tuple[float, float]:
    radius, w = CIRCLE
    return radius * math.cos(w * seconds), radius * math.sin(w * seconds)


class Mount(Node):
    """base_link -> laser_frame once on /tf_static; map -> charger, a tree of its own."""

    def __init__(self) -> None:
        super().__init__("mount")
        self.tf_static_broadcaster = StaticTransformBroadcaster(self)
        now = self.get_clock().now()
        x, y, z, yaw = MOUNT
        self.tf_static_broadcaster.sendTransform(
            [
                stamped("base_link", "laser_frame", now, x, y, z, yaw),
                stamped("map", "charger", now, 3.0, 1.0, 0.0, 0.0),
            ]
        )


class Mover(Node):
    """odom -> base_link (a straight drive, turning) and, if asked, odom -> carrot (a
    circle) on /tf, 50 times a second of the node's clock."""

    def __init__(self, name: str, frames: tuple[str, ...]) -> None:
        super().__init__(name)
        self.frames = frames
        self.tf_broadcaster = TransformBroadcaster(self)
        self.timer = self.create_timer(0.02, self.on_timer)

    def on_timer(self) -> None:
        now = self.get_clock().now()
        s = now.nanoseconds / 1e9
        sent = []
        if "base_link" in self.frames:
            x, y, yaw = base_at(s)
            sent.append(stamped("odom", "base_link", now, x, y, 0.0, yaw))
        if "carrot" in self.frames:
            sent.append(stamped("odom", "carrot", now, *carrot_at(s), 0.0, 0.0))
        self.tf_broadcaster.sendTransform(sent)


def listening() -> Buffer:
    node = Node("tree_listener")
    buffer = Buffer(node=node)
    node.tf_listener = TransformListener(buffer, node)
    return buffer


def heard(sim: Simulation, buffer: Buffer, frames: list[str]) -> None:
    """Run the simulation until ``buffer`` places every frame of ``frames`` in odom."""
    assert sim.run(
        PATIENCE, until=lambda: all(buffer.can_transform("odom", f, Time()) for f in frames)
    ), f"timeout: {frames} not heard in {PATIENCE} simulated seconds"


def broadcasting() -> tuple[Simulation, Buffer]:
    """A simulation with the mount and the mover broadcasting, and a buffer that has heard
    every frame of theirs in odom."""
    sim = Simulation(World(arena=None))
    Mount()
    Mover("mover", ("base_link", "carrot"))
    buffer = listening()
    heard(sim, buffer, ["base_link", "laser_frame", "carrot"])
    return sim, buffer


def expected_poses(seconds: float) -> dict[str, np.ndarray]:
    """Where each frame is in odom at ``seconds``, from the broadcasters' own formulas."""
    x, y, yaw = base_at(seconds)
    base = viz.planar_pose(x, y, yaw)
    mx, my, mz, myaw = MOUNT
    return {
        "odom": np.eye(4),
        "base_link": base,
        "laser_frame": base @ viz.planar_pose(mx, my, myaw, mz),
        "carrot": viz.planar_pose(*carrot_at(seconds), 0.0),
    }


def test_each_triad_sits_where_lookup_transform_puts_its_frame(session: Session) -> None:
    sim, buffer = broadcasting()
    sim.run(1.0)
    # a time between two stamps: tf2 interpolates, and the view shows what it says
    asked = Time(nanoseconds=round((sim.now - 0.51) * 1e9))
    tree = tf_tree.FrameTree("odom")
    drawn = tree.draw(buffer, asked)
    shown = tf_tree.final_frames(tree.vis.window.commands)

    assert set(drawn) == {"odom", "base_link", "laser_frame", "carrot"}, drawn
    for frame, pose in expected_poses(asked.nanoseconds / 1e9).items():
        told = buffer.lookup_transform("odom", frame, asked).transform
        at = shown[frame]
        assert at is not None, f"{frame} hidden"
        assert np.allclose(at[:3, 3], [told.translation.x, told.translation.y, told.translation.z])
        assert np.allclose(at, pose, atol=1e-6), (frame, at, pose)
        assert tree.drawn[frame].transform == told
    # each line reaches from its frame's origin to its parent's
    local = viz.final_transforms(tree.vis.window.commands)
    visible = viz.final_properties(tree.vis.window.commands, "visible")
    for frame, parent in [("laser_frame", "base_link"), ("base_link", "odom"), ("carrot", "odom")]:
        line = f"/meshcat/tf/{frame}/to_parent"
        scale = [c for c in tree.vis.window.commands if c.get("path") == line and
                 c.get("property") == "scale"][-1]["value"]  # fmt: skip
        end = shown[frame] @ local[line] @ [scale[0], 0.0, 0.0, 1.0]
        assert np.allclose(end[:3], shown[parent][:3, 3], atol=1e-9), (frame, end)
        assert visible[line] is True
    assert visible["/meshcat/tf/odom/to_parent"] is False  # the root has no parent
    # the frames of another tree (map -> charger) cannot be had in odom: hidden
    assert shown["map"] is None and shown["charger"] is None


def test_a_frame_tf2_cannot_place_yet_is_hidden_not_an_error(session: Session) -> None:
    sim = Simulation(World(arena=None))
    Mover("base_mover", ("base_link",))
    buffer = listening()
    tree = tf_tree.FrameTree("odom")
    assert tree.draw(buffer) == {}  # nothing heard yet: nothing drawn, no error
    heard(sim, buffer, ["base_link"])
    sim.run(2.0)
    Mover("carrot_mover", ("carrot",))
    heard(sim, buffer, ["carrot"])
    sim.run(2.0)
    first_carrot = buffer.lookup_transform("odom", "carrot", Time())
    # before the carrot's first stamp tf2 would extrapolate: it is hidden, base_link shown
    before = Time(nanoseconds=round((sim.now - 3.0) * 1e9))
    drawn = tree.draw(buffer, before)
    shown = tf_tree.final_frames(tree.vis.window.commands)
    assert "carrot" not in drawn and shown["carrot"] is None
    assert shown["base_link"] is not None and "base_link" in drawn
    # and shown again once tf2 can place it
    tree.draw(buffer, Time.from_msg(first_carrot.header.stamp))
    assert tf_tree.final_frames(tree.vis.window.commands)["carrot"] is not None

    # recorded across its arrival: hidden first, shown at the end, no error
    recorded = tf_tree.FrameTree("odom")
    times = tf_tree.sample_times(buffer, "odom", seconds=3.5, fps=10)
    recorded.record(buffer, times, fps=10)
    (command,) = [c for c in recorded.vis.window.commands if c["type"] == "set_animation"]
    (clip,) = [a["clip"] for a in command["animations"] if a["path"] == "/meshcat/tf/carrot"]
    (track,) = [t for t in clip["tracks"] if t["name"] == ".visible"]
    keys = [k["value"] for k in track["keys"]]
    assert keys[0] is False and keys[-1] is True and len(keys) == len(times), keys
    assert tf_tree.final_frames(recorded.scene().commands)["carrot"] is not None

    # a frame the buffer forgot (as when simulated time jumps back) is hidden too
    buffer.clear()
    assert set(tree.draw(buffer)) <= {"odom"}  # the fixed frame itself, at most
    forgotten = tf_tree.final_frames(tree.vis.window.commands)
    assert forgotten["base_link"] is None and forgotten["carrot"] is None


def test_the_live_view_redraws_on_its_nodes_timer_in_simulated_time(session: Session) -> None:
    sim = Simulation(World(arena=None))
    Mount()
    Mover("mover", ("base_link", "carrot"))
    vis = viz.recording_visualizer()
    tree = tf_tree.live(Node("frame_view"), vis, "odom", robot=robots.diff_drive())
    assert tree.listener is not None
    buffer = tree.listener.buffer
    heard(sim, buffer, ["base_link", "laser_frame", "carrot"])
    draws = tree.draws
    started = time.perf_counter()
    sim.run(1.0)
    took = time.perf_counter() - started
    assert tree.draws - draws == 10, "a 0.1 s timer fires 10 times in 1 s of simulated time"
    # at the robot's pace: 9 redraws after the first, each 0.1 s later on the wall clock too
    assert took >= 0.9, f"1 s of simulated time went by in {took:.3f} s of wall time"

    # the last redraw put the frames where tf2 placed them then, in simulated time
    shown = tf_tree.final_frames(vis.window.commands)
    carrot = tree.drawn["carrot"]
    stamp = Time.from_msg(carrot.header.stamp)
    assert sim.now - 0.1 <= stamp.nanoseconds / 1e9 <= sim.now
    told = buffer.lookup_transform("odom", "carrot", stamp).transform.translation
    lift = tree.robot.height
    assert np.allclose(shown["carrot"][:3, 3], [told.x, told.y, told.z + lift])
    # the robot stands on base_link as drawn
    base = viz.final_transforms(vis.window.commands)["/meshcat/bot"]
    assert np.allclose(base, shown["base_link"]) and math.isclose(lift, 0.04, abs_tol=1e-6)

    tree.stop()
    sim.run(1.0)
    assert tree.draws - draws == 10, "stopped: no more redraws"

    # without realtime it redraws on the same timer, at whatever pace the simulator runs
    fast = tf_tree.live(Node("fast_view"), viz.recording_visualizer(), realtime=False)
    heard(sim, fast.listener.buffer, ["base_link"])
    drawn = fast.draws
    sim.run(2.0)
    assert fast.draws - drawn == 20


def test_a_recorded_tree_ends_where_tf2_says_with_the_robot_in_view(session: Session) -> None:
    sim, buffer = broadcasting()
    sim.run(4.0)
    times = tf_tree.sample_times(buffer, "odom", seconds=3.0, fps=15)
    assert len(times) == 46 and (times[-1] - times[0]).nanoseconds == 3_000_000_000
    tree = tf_tree.FrameTree("odom", robot=robots.diff_drive())
    tree.record(buffer, times)
    scene = tree.scene()
    end = tf_tree.final_frames(scene.commands)
    lift = np.eye(4)
    lift[2, 3] = tree.robot.height
    for frame, pose in expected_poses(times[-1].nanoseconds / 1e9).items():
        told = tf_tree.transform_matrix(buffer.lookup_transform("odom", frame, times[-1]))
        assert np.allclose(end[frame], lift @ told) and np.allclose(told, pose, atol=1e-6)
    robot = viz.final_transforms(scene.commands)["/meshcat/bot"]
    assert np.allclose(robot, end["base_link"])
    # the view is framed on every frame's path and the robot's
    centre, radius = np.array(scene.frame["target"]), scene.frame["radius"]
    for t in times:
        for pose in expected_poses(t.nanoseconds / 1e9).values():
            assert np.linalg.norm(pose[:3, 3] - centre) <= radius + 0.05
    assert "Animated 3D view of the robot bot" in scene.description
    assert "carrot" in scene.description and any("/visual_" in p for p in scene.paths)


def test_frame_names_with_a_slash_get_one_scene_node() -> None:
    for frame in ["robot1/base_link", "odom", "a%2Fb"]:
        name = tf_tree.node_name(frame)
        assert "/" not in name and tf_tree.frame_name(name) == frame


def test_recording_nothing_is_refused_with_a_reason() -> None:
    with pytest.raises(ValueError, match="no frame of this buffer moves in 'odom'"):
        tf_tree.sample_times(Buffer(), "odom", 1.0)
    with pytest.raises(ValueError, match="no times to record"):
        tf_tree.FrameTree().record(Buffer(), [])


def test_a_live_server_holds_the_frames_where_tf2_put_them_and_stops(session: Session) -> None:
    """The chapter's live view, with a real MeshCat server: what a browser opening the
    view would get is the tree as last drawn; stopped, then closed, nothing hangs."""
    sim = Simulation(World(arena=None))
    Mount()
    Mover("mover", ("base_link", "carrot"))
    vis = viz.live_visualizer()
    proc = vis.window.server_proc
    try:
        frames_live = tf_tree.live(Node("frame_view"), vis, "odom", robot=robots.diff_drive())
        heard(sim, frames_live.listener.buffer, ["base_link", "laser_frame", "carrot"])
        sim.run(0.5)
        frames_live.stop()
        served = [
            umsgpack.unpackb(base64.b64decode(blob))
            for blob in re.findall(r"octet-binary;base64,([^\"]+)", vis.static_html())
        ]
        shown = tf_tree.final_frames(served)
        for frame, t in frames_live.drawn.items():
            expected = tf_tree.transform_matrix(t)
            expected[2, 3] += frames_live.robot.height
            assert np.allclose(shown[frame], expected), frame
        assert set(frames_live.drawn) == {"odom", "base_link", "laser_frame", "carrot"}
    finally:
        viz.close_live(vis)
    assert proc.poll() is not None, "the MeshCat server process is still running"
