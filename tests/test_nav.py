"""rosbook.nav: the occupancy grid, A*, the run's measures, and the three nodes finding
their way through a doorway on the simulator."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest
from rclpy.parameter import Parameter

from rosbook.nav import metrics
from rosbook.nav.grid import FREE, OCCUPIED, UNKNOWN, GridSpec, OccupancyMapper, from_msg, to_msg
from rosbook.nav.nodes import Mapper, PathFollower, Planner, lookahead_point
from rosbook.nav.planner import NoPath, astar, dilate, plan
from rosbook.runtime.session import ros
from rosbook.sim.node import Simulation
from rosbook.sim.physics import DiffDriveSim, Pose, RobotGeometry, Trajectory, Wall, World

ROOM = World(arena=(0.0, 0.0, 4.0, 3.0), start=(1.0, 1.5, 0.0))
ROOM_SPEC = GridSpec.covering((-0.5, -0.5, 4.5, 3.5), 0.05)


def mapped(world: World, spec: GridSpec) -> np.ndarray:
    """The grid after one scan from the world's start pose."""
    sim = DiffDriveSim(world)
    mapper = OccupancyMapper(spec)
    laser = sim.laser
    mapper.add_scan(
        world.start, sim.scan(), laser.angle_min, laser.angle_increment, laser.range_max
    )
    return mapper.occupancy()


def at(grid: np.ndarray, spec: GridSpec, x: float, y: float) -> int:
    row, col = spec.cells(np.array(x), np.array(y))
    return int(grid[int(row), int(col)])


def test_grid_covers_its_bounds_in_whole_cells() -> None:
    spec = GridSpec.covering((-1.0, 0.0, 2.0, 1.0), 0.05)
    assert (spec.width, spec.height) == (60, 20)
    assert spec.center(0, 0) == pytest.approx((-0.975, 0.025))


def test_one_scan_maps_free_space_walls_and_leaves_the_outside_unknown() -> None:
    grid = mapped(ROOM, ROOM_SPEC)
    assert at(grid, ROOM_SPEC, 2.0, 1.5) == FREE  # between the robot and the east wall
    assert at(grid, ROOM_SPEC, 3.0, 2.5) == FREE
    east = [at(grid, ROOM_SPEC, x, 1.5) for x in (3.975, 4.025)]
    assert OCCUPIED in east  # the east wall's face, 3 m ahead
    assert at(grid, ROOM_SPEC, 4.3, 1.5) == UNKNOWN  # behind the wall
    assert at(grid, ROOM_SPEC, -0.3, 2.5) == UNKNOWN


def test_a_cell_seen_through_often_enough_turns_free_again() -> None:
    spec = GridSpec.covering((0.0, 0.0, 2.0, 1.0), 0.05)
    mapper = OccupancyMapper(spec)
    ray = dict(angle_min=0.0, angle_increment=0.1, range_max=5.0)
    mapper.add_scan((0.1, 0.525, 0.0), [1.0], **ray)  # a hit at x = 1.1
    assert at(mapper.occupancy(), spec, 1.1, 0.525) == OCCUPIED
    for _ in range(3):
        mapper.add_scan((0.1, 0.525, 0.0), [1.6], **ray)  # it has gone: rays pass through
    assert at(mapper.occupancy(), spec, 1.1, 0.525) == FREE
    assert at(mapper.occupancy(), spec, 1.7, 0.525) == OCCUPIED


def test_ray_at_max_range_hits_nothing() -> None:
    spec = GridSpec.covering((0.0, 0.0, 2.0, 1.0), 0.05)
    mapper = OccupancyMapper(spec)
    mapper.add_scan((0.1, 0.525, 0.0), [1.5], angle_min=0.0, angle_increment=0.1, range_max=1.5)
    grid = mapper.occupancy()
    assert OCCUPIED not in grid and at(grid, spec, 1.0, 0.525) == FREE


def test_occupancy_grid_message_round_trips() -> None:
    from builtin_interfaces.msg import Time

    grid = mapped(ROOM, ROOM_SPEC)
    msg = to_msg(grid, ROOM_SPEC, Time(sec=3))
    assert (msg.info.width, msg.info.height, msg.header.frame_id) == (100, 80, "odom")
    assert msg.data[0] == UNKNOWN  # row-major from the origin, the lower-left corner
    back, spec = from_msg(msg)
    assert spec == ROOM_SPEC and np.array_equal(back, grid)


def test_dilate_grows_by_a_disk() -> None:
    mask = np.zeros((9, 9), dtype=bool)
    mask[4, 4] = True
    grown = dilate(mask, 2)
    assert grown[4, 2] and grown[2, 4] and grown[3, 3] and not grown[2, 2]
    assert grown.sum() == 13


def test_astar_takes_the_shortest_way_and_the_gap_in_a_wall() -> None:
    blocked = np.zeros((10, 10), dtype=bool)
    assert len(astar(blocked, (0, 0), (0, 9))) == 10  # a straight row
    assert len(astar(blocked, (0, 0), (9, 9))) == 10  # the diagonal
    blocked[:, 5] = True
    blocked[8, 5] = False  # the only gap
    path = astar(blocked, (0, 0), (0, 9))
    assert (8, 5) in path and all(not blocked[c] for c in path)


def test_astar_says_why_there_is_no_path() -> None:
    blocked = np.zeros((5, 5), dtype=bool)
    blocked[:, 2] = True
    with pytest.raises(NoPath, match="walled off"):
        astar(blocked, (0, 0), (0, 4))
    with pytest.raises(NoPath, match=r"the goal \(0, 2\) is blocked"):
        astar(blocked, (0, 0), (0, 2))
    with pytest.raises(NoPath, match="outside the grid"):
        astar(blocked, (0, 0), (7, 0))


def test_plan_keeps_the_robot_radius_from_walls_and_prefers_a_margin() -> None:
    spec = GridSpec.covering((0.0, 0.0, 4.0, 2.0), 0.05)
    grid = np.zeros((spec.height, spec.width), dtype=np.int8)
    grid[0, :] = OCCUPIED  # a wall along y = 0
    points = plan(grid, spec, (0.5, 0.5), (3.5, 0.5), radius=0.35)
    assert points[0] == (0.5, 0.5) and points[-1] == (3.5, 0.5)
    assert min(y for _, y in points) >= 0.05 + 0.35 - 0.05  # never closer than the radius
    assert max(y for _, y in points) > 0.6  # moved away from the wall where it could
    with pytest.raises(NoPath, match="blocked"):
        plan(grid, spec, (0.5, 0.2), (3.5, 0.5), radius=0.35)


def test_path_length_and_clearance_of_a_known_drive() -> None:
    run = Trajectory()
    for k in range(11):
        run.append(k * 0.1, Pose(1.0 + 0.1 * k, 1.5, 0.0), 0.0, 0.0)
    assert metrics.path_length(run) == pytest.approx(1.0)
    # the back of the base is 0.5 m behind the axle: at the start, 0.5 m from x = 0
    assert metrics.clearance(ROOM, run, RobotGeometry()) == pytest.approx(0.5)
    near = Trajectory()
    near.append(0.0, Pose(3.7, 1.5, 0.0), 0.0, 0.0)
    assert metrics.clearance(ROOM, near) == pytest.approx(0.2)  # its front, 0.1 m ahead


@pytest.fixture
def session() -> Iterator[None]:
    ros.init()
    yield
    ros.reset()


DOORWAY_WORLD = World(
    arena=(0.0, 0.0, 6.0, 4.0),
    walls=(Wall((3.0, 0.0), (3.0, 1.4), 0.1), Wall((3.0, 2.6), (3.0, 4.0), 0.1)),
    start=(1.0, 3.0, 0.0),
)


def test_nodes_map_plan_and_drive_through_a_doorway_without_touching(session: None) -> None:
    goal = (5.0, 3.0)
    sim = Simulation(DOORWAY_WORLD)
    Mapper(parameter_overrides=[Parameter("bounds", value=[-0.5, -0.5, 6.5, 4.5])])
    planner = Planner(parameter_overrides=[Parameter("goal", value=list(goal))])
    follower = PathFollower()
    assert sim.run(90.0, until=lambda: follower.arrived), "did not arrive in 90 s"
    run = sim.trajectory
    assert math.dist((run.x[-1], run.y[-1]), goal) < 0.1 + 0.02
    assert sim.physics.collisions == [] and planner.failures == 0
    crossing = int(np.argmin(np.abs(np.array(run.x) - 3.0)))
    assert 1.4 < run.y[crossing] < 2.6  # through the doorway
    assert metrics.clearance(DOORWAY_WORLD, run) > 0.05


def test_follower_brakes_for_what_the_lidar_sees_ahead(session: None) -> None:
    # A plan straight into a wall the planner does not know of: the lidar stops the robot.
    from geometry_msgs.msg import PoseStamped
    from nav_msgs.msg import Path
    from rclpy.node import Node

    world = World(arena=(0.0, 0.0, 3.0, 2.0), start=(0.8, 1.0, 0.0))
    sim = Simulation(world)
    follower = PathFollower()
    feeder = Node("plan_feeder")
    publisher = feeder.create_publisher(Path, "plan", 10)
    path = Path()
    for x in (0.8, 5.0):  # through the east wall at x = 3
        pose = PoseStamped()
        pose.pose.position.x, pose.pose.position.y = x, 1.0
        path.poses.append(pose)
    feeder.create_timer(0.5, lambda: publisher.publish(path))
    sim.run(20.0)
    assert sim.physics.collisions == [] and not follower.arrived
    front = sim.physics.pose.x + max(x for x, _ in RobotGeometry().footprint())
    assert 3.0 - front < follower.stop_at
    assert abs(sim.physics.twist[0]) < 1e-6  # stopped: it brakes to 0 at stop_at


def test_lookahead_point_runs_along_the_path_from_the_nearest_point() -> None:
    path = [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0)]
    assert lookahead_point(path, (0.5, 0.3), 0.5) == pytest.approx((1.0, 0.0))
    assert lookahead_point(path, (1.8, 0.0), 0.5) == pytest.approx((2.0, 0.3))  # round the corner
    assert lookahead_point(path, (2.1, 1.9), 0.5) == (2.0, 2.0)  # the end is nearer
    assert lookahead_point([(0.0, 0.0), (5.0, 0.0)], (0.43, 0.0), 0.5) == pytest.approx((0.93, 0.0))
