"""The simulation core without ROS: base motion, collisions, laser and Kinect geometry, people."""

import math

import numpy as np
import pytest
from florence_sim.base import BUMP_LEFT, BUMP_RIGHT, BaseConfig, DiffDriveBase, clamp_to_wheels
from florence_sim.geometry import Box, Cylinder, Scene
from florence_sim.people import Person
from florence_sim.robot_model import RobotModel
from florence_sim.sensors import CameraConfig, DepthCamera, LaserConfig, UrgLaser, world_pose

pytestmark = pytest.mark.unit

DT = 0.01


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_xacro()


def room(size=4.0, thickness=0.1, height=2.4):
    """A square room [0, size]^2 whose inner wall faces are at 0 and ``size``."""
    t, s = thickness, size
    return [Box("south", s / 2, -t / 2, 0, s + 2 * t, t, 0, height), Box("north", s / 2, s + t / 2, 0, s + 2 * t, t, 0,
                                                                         height),
            Box("west", -t / 2, s / 2, 0, t, s, 0, height), Box("east", s + t / 2, s / 2, 0, t, s, 0, height)]


def make_base(**kw):
    cfg = BaseConfig(radius=0.1696, height=0.94, wheel_separation=0.26, **kw)
    return DiffDriveBase(cfg, 1.0, 1.0, 0.0)  # odometry starts at (0, 0, 0) there


def drive(base, scene, v, w, until, limit=30.0):
    t = 0.0
    while not until(base) and t < limit:
        base.command(v, w, t)
        base.step(DT, t, scene)
        t += DT
    return t


def test_straight_one_metre_by_odometry_ends_near_truth():
    base = make_base()
    scene = Scene(room(6.0))
    drive(base, scene, 0.3, 0.0, lambda b: math.hypot(b.ox, b.oy) >= 1.0)
    travelled = math.hypot(base.x - 1.0, base.y - 1.0)
    assert travelled == pytest.approx(1.0, abs=0.03)  # 1 % scale error and noise by default
    assert abs(base.yaw) < math.radians(2)


def test_ninety_degree_turn_by_gyro_ends_near_truth():
    base = make_base()
    scene = Scene(room(6.0))
    drive(base, scene, 0.0, 0.8, lambda b: b.oyaw >= math.pi / 2)
    assert base.yaw == pytest.approx(math.pi / 2, abs=math.radians(3))
    assert math.hypot(base.x - 1.0, base.y - 1.0) < 0.01


def test_error_free_odometry_matches_truth():
    base = make_base(odom_linear_scale_error=0.0, odom_linear_noise=0.0, gyro_scale_error=0.0, gyro_noise=0.0)
    drive(base, Scene(room(6.0)), 0.3, 0.4, lambda b: False, limit=5.0)
    assert base.odom_in_world() == pytest.approx((base.x, base.y, base.yaw), abs=1e-9)
    assert (base.ox, base.oy) != pytest.approx((base.x, base.y)), "odometry counts from zero"


def test_gyro_scale_error_shows_in_odometry_heading():
    base = make_base(gyro_scale_error=0.1, gyro_noise=0.0)
    drive(base, Scene(room(6.0)), 0.0, 0.5, lambda b: b.yaw >= 1.0)
    assert base.oyaw == pytest.approx(1.1 * base.yaw, rel=0.01)


@pytest.mark.parametrize(("yaw", "bits"), [(0.0, BUMP_LEFT | BUMP_RIGHT), (math.radians(45), BUMP_RIGHT),
                                           (math.radians(-45), BUMP_LEFT)])
def test_collision_stops_the_robot_and_sets_bumper_bits(yaw, bits):
    """A wall across x = 2.0, hit head-on, on the robot's right (heading north-east) or left."""
    scene = Scene([Box("wall", 2.05, 1.0, 0.0, 0.1, 6.0, 0.0, 2.4)])
    base = make_base()
    base.set_pose(1.0, 1.0, yaw)
    drive(base, scene, 0.3, 0.0, lambda b: False, limit=8.0)
    assert base.v == 0.0
    assert 2.0 - base.x >= base.cfg.radius - 1e-6, "the robot never enters the wall"
    assert 2.0 - base.x < base.cfg.radius + 0.02, "it stopped at the wall"
    assert base.collisions == 1
    assert base.bumps == bits


def test_robot_backs_away_from_a_wall_after_contact():
    scene = Scene([Box("wall", 2.05, 1.0, 0.0, 0.1, 6.0, 0.0, 2.4)])
    base = make_base()
    drive(base, scene, 0.3, 0.0, lambda b: b.bumps != 0)
    drive(base, scene, -0.2, 0.0, lambda b: False, limit=1.0)
    assert base.bumps == 0 and 2.0 - base.x > base.cfg.radius + 0.05


def test_table_top_blocks_the_robot_but_not_the_laser_plane():
    """The robot is 0.94 m tall: it cannot drive under a 0.75 m table top."""
    scene = Scene([Box("top", 2.6, 1.0, 0.0, 1.0, 1.0, 0.71, 0.75)])
    base = make_base()
    drive(base, scene, 0.3, 0.0, lambda b: False, limit=8.0)
    assert base.collisions == 1 and base.x < 2.1 - base.cfg.radius + 0.02


def test_nan_command_is_ignored_and_keeps_the_previous_one():
    base = make_base()
    assert base.command(0.2, 0.0, 0.0)
    assert not base.command(float("nan"), 0.0, 0.1)
    assert not base.command(0.1, float("inf"), 0.1)
    assert base.cmd_v == 0.2 and base.cmd_time == 0.0


def test_stale_command_stream_stops_the_robot():
    base = make_base()
    scene = Scene(room(6.0))
    base.command(0.3, 0.0, 0.0)
    t = 0.0
    while t < 0.5:
        base.step(DT, t, scene)
        t += DT
    assert base.v == pytest.approx(0.3)
    while t < 1.2:
        base.step(DT, t, scene)
        t += DT
    assert base.v == 0.0


@pytest.mark.parametrize(("v", "w", "expect"), [(1.0, 0.0, (0.5, 0.0)), (0.0, 10.0, (0.0, 1.0 / 0.26)),
                                                (0.5, 1.0, (0.5 * 0.5 / 0.63, 0.5 / 0.63)), (0.2, 0.5, (0.2, 0.5)),
                                                (-0.5, -1.0, (-0.5 * 0.5 / 0.63, -0.5 / 0.63))])
def test_wheel_speed_limit_of_the_create(v, w, expect):
    # (0.5 m/s, 1 rad/s) asks 0.63 m/s of the outer wheel: both wheels scaled by 0.5 / 0.63, the
    # turning radius v / w = 0.5 m kept
    assert clamp_to_wheels(v, w, 0.26, 0.5) == pytest.approx(expect, abs=1e-9)


@pytest.mark.parametrize(("v", "w"), [(0.5, 1.37), (0.42, -1.5), (0.3, 0.4), (-0.1, 2.0), (0.0, 5.0)])
def test_wheel_speed_limit_matches_the_driver(v, w):
    """The simulated base limits the wheels as the real driver does (turtlebot_node)."""
    from turtlebot_node.create_oi import twist_to_wheels

    from turtlebot_node import oi_spec

    right, left = twist_to_wheels(v, w, oi_spec.WHEEL_BASE)  # [mm/s], rounded
    sv, sw = clamp_to_wheels(v, w, oi_spec.WHEEL_BASE, oi_spec.MAX_WHEEL_SPEED / 1000.0)
    assert (sv + sw * oi_spec.WHEEL_BASE / 2) * 1000.0 == pytest.approx(right, abs=0.5)
    assert (sv - sw * oi_spec.WHEEL_BASE / 2) * 1000.0 == pytest.approx(left, abs=0.5)


def test_acceleration_is_limited():
    base = make_base(max_linear_acc=1.0)
    base.command(0.5, 0.0, 0.0)
    base.step(DT, 0.0, Scene(room(6.0)))
    assert base.v == pytest.approx(0.01)


# ---------------------------------------------------------------------------------------- laser
def _box_room_distance(x, y, heading, size):
    """Analytic distance from (x, y) along heading to the inside of the square room [0, size]^2."""
    c, s = math.cos(heading), math.sin(heading)
    ts = []
    if c > 1e-12:
        ts.append((size - x) / c)
    if c < -1e-12:
        ts.append(-x / c)
    if s > 1e-12:
        ts.append((size - y) / s)
    if s < -1e-12:
        ts.append(-y / s)
    return min(ts)


@pytest.mark.parametrize(("x", "y", "yaw"), [(2.0, 2.0, 0.0), (1.0, 2.5, 0.7), (3.1, 1.2, -2.5)])
def test_laser_ranges_match_analytic_distances(robot, x, y, yaw):
    mount = robot.pose("base_laser_link")
    laser = UrgLaser(mount, LaserConfig(min_ang=-2.1, max_ang=2.1, noise=0.0))
    ranges = laser.scan(Scene(room(4.0)), x, y, yaw)
    lx, ly = (world_pose(x, y, yaw) @ mount)[:2, 3]
    # inverted mounting: the laser's counter-clockwise angle alpha points at robot bearing -alpha
    expected = np.array([_box_room_distance(lx, ly, yaw - a, 4.0) for a in laser.angles])
    expected[expected > 5.6] = 0.0
    np.testing.assert_allclose(ranges, expected, atol=1e-4)


def test_urg_geometry_and_no_return(robot):
    laser = UrgLaser(robot.pose("base_laser_link"), LaserConfig(min_ang=-3.0, max_ang=3.0))
    assert laser.increment == pytest.approx(2 * math.pi / 1024)
    assert laser.angle_min == pytest.approx(-2.0862, abs=1e-4) and laser.angle_max == pytest.approx(2.0862, abs=1e-4)
    assert len(laser.angles) == 681
    default = UrgLaser(robot.pose("base_laser_link"), LaserConfig())
    assert default.angle_min == pytest.approx(-math.pi / 2) and len(default.angles) == 513
    ranges = laser.scan(Scene(room(20.0)), 10.0, 10.0, 0.0)  # walls 10 m away: beyond 5.6 m
    assert np.all(np.isposinf(ranges)), "no echo is +inf, as hokuyo_node publishes it"


def test_inverted_laser_sees_a_left_wall_at_negative_angles(robot):
    """Upside down, the URG's own left (+angles) is the robot's right."""
    scene = Scene([Box("left_wall", 2.0, 2.0, 0.0, 12.0, 0.1, 0.0, 2.4)])  # 1.95 m left of a robot at (2, 0)
    laser = UrgLaser(robot.pose("base_laser_link"), LaserConfig(noise=0.0))
    ranges = laser.scan(scene, 2.0, 0.0, 0.0)
    left = ranges[laser.angles < -0.6]
    right = ranges[laser.angles > 0.2]
    assert np.all(np.isfinite(left)) and np.all(np.isposinf(right))
    assert ranges[0] == pytest.approx(1.95, abs=1e-4)  # angle_min = -pi/2: straight to the robot's left


def test_laser_range_noise_is_centred(robot):
    laser = UrgLaser(robot.pose("base_laser_link"), LaserConfig(noise=0.01))
    exact = UrgLaser(robot.pose("base_laser_link"), LaserConfig(noise=0.0))
    diffs = np.concatenate([laser.scan(Scene(room(4.0)), 2.0, 2.0, 0.0) - exact.scan(Scene(room(4.0)), 2.0, 2.0, 0.0)
                            for _ in range(20)])
    assert abs(diffs.mean()) < 0.002 and 0.005 < diffs.std() < 0.03


# ---------------------------------------------------------------------------------------- Kinect
def _camera_pose(robot, x, y, yaw, tilt=0.0):
    return world_pose(x, y, yaw) @ robot.pose("camera_depth_optical_frame", {"camera_tilt_joint": tilt})


@pytest.mark.parametrize("tilt", [0.0, 0.3, -0.4])
def test_depth_matches_analytic_planes(robot, tilt):
    """A wall ahead and the floor: depth (optical z) equals the analytic plane intersection."""
    scene = Scene([Box("wall", 3.05, 0.0, 0.0, 0.1, 20.0, 0.0, 9.0)])  # face at x = 3.0, higher than seen
    cam = DepthCamera(CameraConfig(width=64, height=48, depth_noise=0.0, max_range=10.0))
    pose = _camera_pose(robot, 0.0, 0.0, 0.0, tilt)
    depth, _ = cam.render(scene, pose)
    rays = cam.rays @ pose[:3, :3].T
    o = pose[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_wall = np.where(rays[:, 0] > 0, (3.0 - o[0]) / rays[:, 0], np.inf)
        t_floor = np.where(rays[:, 2] < 0, -o[2] / rays[:, 2], np.inf)
    expected = np.minimum(t_wall, t_floor)
    expected[(expected < 0.55) | (expected > 10.0)] = np.nan
    np.testing.assert_allclose(depth.ravel(), expected, atol=1e-4, equal_nan=True)
    assert np.isfinite(depth).mean() > 0.9


def test_depth_range_limits_give_nan(robot):
    cam = DepthCamera(CameraConfig(width=32, height=24, depth_noise=0.0))
    near = Scene([Box("wall", 0.45, 0.0, 0.0, 0.1, 4.0, 0.0, 2.4)])  # 0.4 m ahead of the camera
    depth, _ = cam.render(near, _camera_pose(robot, 0.0, 0.0, 0.0))
    assert np.isnan(depth[: 12]).all()  # upper half sees only the too-near wall
    depth, _ = cam.render(Scene([]), _camera_pose(robot, 0.0, 0.0, 0.0, tilt=0.5))
    assert np.isnan(depth[0]).all()  # looking up at nothing: no return


def test_table_is_seen_by_the_kinect_and_not_by_the_laser(robot):
    """Table 1.2 m ahead between the legs: the laser passes under it, the Kinect sees the top."""
    table = [Box("table/top", 2.0, 0.0, 0.0, 0.8, 1.2, 0.71, 0.75), Box("wall", 5.05, 0.0, 0.0, 0.1, 10.0, 0.0, 2.4)]
    legs = [Cylinder(f"table/leg{i}", 2.0 + dx, dy, 0.025, 0.0, 0.71) for i, (dx, dy) in
            enumerate([(0.35, 0.55), (-0.35, 0.55), (0.35, -0.55), (-0.35, -0.55)])]
    scene = Scene(table, legs)
    laser = UrgLaser(robot.pose("base_laser_link"), LaserConfig(noise=0.0))
    ranges = laser.scan(scene, 0.0, 0.0, 0.0)
    front = ranges[np.abs(laser.angles) < 0.1]
    assert np.all(front > 4.5), "the laser passes under the table top to the far wall"
    assert np.any(np.abs(ranges - math.hypot(1.65, 0.55)) < 0.1), "it sees a leg"

    cam = DepthCamera(CameraConfig(depth_noise=0.0))
    pose = world_pose(0.0, 0.0, 0.0) @ robot.pose("camera_depth_optical_frame")
    depth, _ = cam.render(scene, pose)
    upper = depth[: cam.cfg.height // 2, cam.cfg.width // 2 - 10: cam.cfg.width // 2 + 10]
    cam_x = pose[0, 3]
    on_table = np.abs(upper - (1.6 - cam_x)) < 0.05  # front face of the top at x = 1.6
    assert on_table.sum() > 10, "the Kinect sees the table's top edge"


def test_camera_intrinsics_and_groups_cover_every_pixel():
    cam = DepthCamera(CameraConfig(width=640, height=480))
    assert math.degrees(2 * math.atan(320 / cam.fx)) == pytest.approx(58.0)
    assert 44 < math.degrees(2 * math.atan(240 / cam.fy)) < 46
    assert sorted(cam.order.tolist()) == list(range(640 * 480))
    assert [g.stop - g.start for g in cam.groups] == [80 * 480] * 8


def test_grouped_and_ungrouped_casting_agree(robot):
    rng = np.random.default_rng(3)
    boxes = [Box(f"b{i}", *rng.uniform(0, 6, 2), rng.uniform(0, 3), *rng.uniform(0.1, 1.5, 2),
                 0.0 if i % 2 else 0.6, rng.uniform(0.3, 2.4)) for i in range(25)]
    cyls = [Cylinder(f"c{i}", *rng.uniform(0, 6, 2), 0.1, 0.0, 1.7) for i in range(6)]
    scene = Scene(boxes, cyls, ceiling=2.4)
    cam = DepthCamera(CameraConfig(width=80, height=60))
    pose = world_pose(3.0, 3.0, 0.4) @ robot.pose("camera_depth_optical_frame", {"camera_tilt_joint": 0.2})
    dirs = cam.rays @ pose[:3, :3].T
    t1, o1 = scene.cast_3d(pose[:3, 3], dirs, 4.0)
    t2, o2 = scene.cast_3d(pose[:3, 3], dirs, 4.0, cam.groups)
    np.testing.assert_array_equal(t1, t2)
    np.testing.assert_array_equal(o1, o2)


def _level_camera(x, z):
    """4x4 pose of an optical frame at (x, 0, z) [m] looking along +x, level (z forward, x right, y down)."""
    pose = np.eye(4)
    pose[:3, :3] = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]
    pose[0, 3], pose[2, 3] = x, z
    return pose


def test_depth_noise_default_is_about_4_cm_at_5_m():
    """std = 0.0016 * d^2 (Khoshelham and Elberink 2012): 4 cm at 5 m, on a wall 5 m ahead filling the image."""
    assert CameraConfig().depth_noise == 0.0016
    scene = Scene([Box("wall", 5.05, 0.0, 0.0, 0.1, 20.0, 0.0, 9.0)])  # face at x = 5
    cam = DepthCamera(CameraConfig(max_range=6.0), rng=np.random.default_rng(7))
    depth, _ = cam.render(scene, _level_camera(0.0, 3.0))
    assert np.isfinite(depth).all(), "a plane has no edges to drop"
    err = depth - 5.0
    assert abs(err.mean()) < 0.002 and err.std() == pytest.approx(0.04, rel=0.05)
    exact, _ = cam.render(scene, _level_camera(0.0, 3.0), noise=False)
    np.testing.assert_allclose(exact, 5.0, atol=1e-5)


def _person_before_wall(edge_dropout, person_x=1.5, wall_x=3.5):
    """Noiseless depth of a person facing a level camera at 0.54 m, before a wall: (with the
    person, without) and the person's pixels."""
    wall = Scene([Box("wall", wall_x + 0.05, 0.0, 0.0, 0.1, 20.0, 0.0, 2.4)])
    person = Person("a", x=person_x, y=0.0, yaw=math.pi)
    cam = DepthCamera(CameraConfig(depth_noise=0.0, edge_dropout=edge_dropout))
    depth, _ = cam.render(wall.with_cylinders(person.primitives()), _level_camera(0.0, 0.54))
    bare, _ = DepthCamera(CameraConfig(depth_noise=0.0, edge_dropout=0)).render(wall, _level_camera(0.0, 0.54))
    return depth, bare


def test_kinect_loses_depth_along_a_persons_silhouette_not_inside_it():
    off, bare = _person_before_wall(0)
    assert np.isfinite(off).all() and np.isfinite(bare).all(), "without edge dropout every pixel has depth"
    body = off < bare - 1e-3  # the person's pixels: nearer than the bare wall and floor
    on, _ = _person_before_wall(1)
    lost = np.isnan(on)
    assert lost.any() and not (lost & body).any(), "the person keeps every pixel: the far side of an edge is lost"
    # every lost pixel lies at most 5 columns (the shadow) or 1 row from the person
    near = body.copy()
    for k in range(1, 6):
        near[:, :-k] |= body[:, k:]
        near[:, k:] |= body[:, :-k]
    near[1:] |= body[:-1]
    near[:-1] |= body[1:]
    assert not (lost & ~near).any(), "depth lost away from the person (middle of the wall or floor)"
    # torso rows: the projector (7.5 cm to the camera's right) casts its shadow on the wall left
    # of the person: b * fx * (1/1.32 - 1/3.5) = 5 px; on the right only the one mixed pixel
    cam = DepthCamera(CameraConfig())
    spans = [np.nonzero(row)[0] for row in body]
    rows = [r for r, cols in enumerate(spans) if len(cols) > 25 and cols[-1] - cols[0] + 1 == len(cols)]  # torso
    assert len(rows) > 10
    for r in rows:
        left, right = spans[r][0], spans[r][-1]
        width = 0.075 * cam.fx * (1 / (1.5 - 0.18) - 1 / 3.5)
        assert lost[r, left - round(width) + 1: left].all() and not lost[r, left - round(width) - 2], r
        assert lost[r, right + 1] and not lost[r, right + 2], r
        assert np.isfinite(on[r, left:right + 1]).all()


def test_edge_dropout_width_widens_the_mixed_band():
    on, _ = _person_before_wall(2)
    off, bare = _person_before_wall(0)
    body = off < bare - 1e-3
    r = int(np.nonzero(body.sum(axis=1) > 25)[0][0]) + 5
    right = np.nonzero(body[r])[0].max()
    assert np.isnan(on[r, right + 1: right + 3]).all() and np.isfinite(on[r, right + 3])
    with pytest.raises(ValueError, match="edge_dropout"):
        CameraConfig(edge_dropout=-1).validate()
    with pytest.raises(ValueError, match="edge_dropout"):
        CameraConfig(edge_dropout=True).validate()


def test_edge_dropout_keeps_a_steep_floor_at_low_resolution(robot):
    """Far ahead the floor's depth grows by more than 10 % a row at 64x48, but it is one surface:
    no jump between primitives, nothing lost."""
    cam = DepthCamera(CameraConfig(width=64, height=48, depth_noise=0.0, max_range=10.0))
    depth, _ = cam.render(Scene([]), _camera_pose(robot, 0.0, 0.0, 0.0))
    floor = depth[cam.cfg.height // 2 + 1:]
    with np.errstate(invalid="ignore"):
        assert np.nanmax(floor[:-1] / floor[1:]) > 1.1  # the steep part is in view
    assert np.isfinite(floor[np.isfinite(depth[cam.cfg.height // 2 + 1:])]).all()
    ref, _ = DepthCamera(CameraConfig(width=64, height=48, depth_noise=0.0, max_range=10.0,
                                      edge_dropout=0)).render(Scene([]), _camera_pose(robot, 0.0, 0.0, 0.0))
    np.testing.assert_array_equal(depth, ref)


# ---------------------------------------------------------------------------------------- people
def _walk(person, seconds):
    for _ in range(round(seconds / DT)):
        person.step(DT)


def test_person_walks_the_path_at_its_speed():
    p = Person("a", path=[(0.0, 0.0), (2.0, 0.0), (2.0, 1.0)], speed=0.5, mode="once")
    _walk(p, 2.0)
    assert (p.x, p.y) == pytest.approx((1.0, 0.0), abs=1e-6)
    assert p.yaw == pytest.approx(0.0) and p.vx == pytest.approx(0.5)
    _walk(p, 3.0)
    assert (p.x, p.y) == pytest.approx((2.0, 0.5), abs=1e-6)
    assert p.yaw == pytest.approx(math.pi / 2)
    _walk(p, 10.0)
    assert (p.x, p.y) == pytest.approx((2.0, 1.0)) and not p.walking


@pytest.mark.parametrize(("mode", "after", "where"), [("loop", 9.0, (0.5, 1.0)), ("back_and_forth", 9.0, (1.5, 0.0))])
def test_person_path_modes(mode, after, where):
    # 4.5 m at 0.5 m/s along a path of 2 + 1 m (a loop: 2 + 1 + 2 + 1 m)
    p = Person("a", path=[(0.0, 0.0), (2.0, 0.0), (2.0, 1.0)], speed=0.5, mode=mode)
    if mode == "loop":
        p.path = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (0.0, 1.0)]
    _walk(p, after)
    assert (p.x, p.y) == pytest.approx(where, abs=1e-6)


def test_person_pauses_at_waypoints():
    p = Person("a", path=[(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], speed=1.0, mode="once", pause=1.0)
    _walk(p, 1.5)
    assert (p.x, p.y) == pytest.approx((1.0, 0.0), abs=1e-6) and p.vx == 0.0
    _walk(p, 1.0)
    assert (p.x, p.y) == pytest.approx((1.0, 0.5), abs=1e-6)


def test_people_are_seen_by_laser_legs_and_camera_shirt(robot):
    p = Person("a", x=2.0, y=0.0, yaw=math.pi, shirt=(0.0, 1.0, 0.0))
    static = Scene([Box("wall", 5.05, 0.0, 0.0, 0.1, 10.0, 0.0, 2.4)])
    scene = static.with_cylinders(p.primitives())
    laser = UrgLaser(robot.pose("base_laser_link"), LaserConfig(noise=0.0))
    ranges = laser.scan(scene, 0.0, 0.0, 0.0)
    legs = ranges[(ranges > 0) & (ranges < 2.5)]
    assert len(legs) > 3 and np.all(np.abs(legs - 1.9) < 0.1)
    cam = DepthCamera(CameraConfig(depth_noise=0.0))
    depth, rgb = cam.render(scene, world_pose(0, 0, 0) @ robot.pose("camera_rgb_optical_frame"))
    green = (rgb[..., 1] > 100) & (rgb[..., 0] < 50) & (rgb[..., 2] < 50)
    assert green.sum() > 50
    assert np.nanmedian(depth[green]) == pytest.approx(2.0 - 0.18 + 0.087, abs=0.1)


def test_person_waits_while_the_robot_is_in_the_way():
    p = Person("a", path=[(0.0, 0.0), (4.0, 0.0)], speed=1.0, mode="once")
    robot = (2.0, 0.0, 0.17)
    for _ in range(400):
        p.step(DT, keep_clear=robot)
    assert p.x == pytest.approx(2.0 - 0.17 - 0.20 - 0.15, abs=0.02) and p.vx == 0.0
    for _ in range(400):  # the robot leaves: the walk goes on
        p.step(DT, keep_clear=(2.0, 3.0, 0.17))
    assert p.x == pytest.approx(4.0)


def test_a_person_walks_on_past_the_robot_beside_their_way():
    """Only a step that heads at the robot waits: one beside the way (here 0.5 m off it, nearer
    than radius + radius + GAP as they pass) is walked on, also a last centimetre to a waypoint
    that comes nearer the robot (the case that stood for ever in a doorway)."""
    p = Person("a", path=[(0.0, 0.0), (4.0, 0.0)], speed=1.0, mode="once")
    for _ in range(400):
        p.step(DT, keep_clear=(2.0, 0.5, 0.17))
    assert p.x == pytest.approx(4.0)
    q = Person("b", path=[(0.0, 0.0), (0.0, 0.5), (0.0, -3.0)], speed=1.0, mode="once")
    q.y = 0.49
    robot = (-0.45, 0.71, 0.17)
    assert math.hypot(q.x - robot[0], q.y - robot[1]) < robot[2] + q.radius + 0.15
    for _ in range(400):
        q.step(DT, keep_clear=robot)
    assert q.finished and q.y == pytest.approx(-3.0)
    r = Person("c", path=[(0.0, 0.0), (4.0, 0.0)], speed=1.0, mode="once")
    for _ in range(400):  # 0.4 m off the way: heads at the robot when it comes near, and waits
        r.step(DT, keep_clear=(2.0, 0.4, 0.17))
    assert r.x < 2.0 and r.vx == 0.0


def test_a_person_never_steps_into_the_robot_beside_them():
    """A robot that came to stand just beside a walking person's way, outside their WAIT_CONE (72
    deg off their heading when they would come within TOUCH_GAP of it): they wait rather than walk
    into its side, and walk on once it has gone."""
    from florence_sim.people import TOUCH_GAP, WAIT_CONE

    p = Person("a", path=[(1.8, 0.0), (4.0, 0.0)], speed=1.0, mode="once")
    robot = (2.0, 0.4, 0.17)
    assert math.atan2(robot[1], robot[0] - p.x) > WAIT_CONE  # not heading at it from the start
    least = math.inf
    for _ in range(200):
        p.step(DT, keep_clear=robot)
        least = min(least, math.hypot(p.x - robot[0], p.y - robot[1]))
    assert least >= robot[2] + p.radius + TOUCH_GAP - 1e-9
    assert p.x < 2.0 and p.vx == 0.0
    for _ in range(400):
        p.step(DT, keep_clear=(2.0, 3.0, 0.17))
    assert p.x == pytest.approx(4.0)


@pytest.mark.parametrize("mode", ["back_and_forth", "loop"])
def test_a_person_kept_waiting_turns_back_after_their_patience(mode):
    """Head-on with a robot that does not move, a person waits PATIENCE seconds, then walks their
    route the other way (a loop backwards); one walking ``once`` waits on."""
    from florence_sim.people import PATIENCE

    path = [(0.0, 0.0), (4.0, 0.0), (4.0, 2.0)]
    p = Person("a", path=path, speed=1.0, mode=mode)
    robot = (2.0, 0.0, 0.17)
    waited = 0.0
    while p.vx >= 0.0 and waited < PATIENCE + 5.0:
        p.step(DT, keep_clear=robot)
        waited += DT if p.vx == 0.0 else 0.0
    assert p.vx < 0.0 and waited == pytest.approx(PATIENCE, abs=2 * DT)
    start = p.x
    for _ in range(100):  # 1 m back toward the first waypoint
        p.step(DT, keep_clear=robot)
    assert p.x == pytest.approx(start - 1.0, abs=0.02) and p.y == 0.0
    for _ in range(150):  # then on the other way: back and forth toward the robot again, a loop to (4, 2)
        p.step(DT, keep_clear=robot)
    assert (p.x > 0.5 and p.vx > 0.0) if mode == "back_and_forth" else (p.y > 0.2 and p.vy > 0.0)
    once = Person("b", path=path, speed=1.0, mode="once")
    for _ in range(int((PATIENCE + 5.0) / DT)):
        once.step(DT, keep_clear=robot)
    assert once.x == pytest.approx(2.0 - 0.17 - 0.20 - 0.15, abs=0.02) and once.vx == 0.0


def test_sitting_and_standing_bodies():
    standing = Person("a", x=1.0, y=0.0)
    sitting = Person("b", x=1.0, y=0.0, posture="sitting")
    assert max(c.z1 for c in standing.primitives()) == pytest.approx(1.72)
    assert max(c.z1 for c in sitting.primitives()) == pytest.approx(1.32)
    legs = [c for c in standing.primitives() if c.z0 == 0.0]
    assert len(legs) == 2 and all(c.z1 > 0.5 for c in legs), "two legs cross the laser plane"
    sitting.step(1.0)
    assert (sitting.x, sitting.y) == (1.0, 0.0) and not sitting.walking


def test_outputs_fall_due_at_their_exact_average_rates(robot):
    from florence_sim.base import BaseConfig
    from florence_sim.sim import SimConfig, Simulator
    from florence_sim.world import World

    world = World("w", "w", Scene(room(6.0)), 0.05, ((0, 0), (6, 6)))
    sim = Simulator(world, robot, BaseConfig(radius=0.17, height=0.94, wheel_separation=0.26), SimConfig(),
                    start=(3.0, 3.0, 0.0))
    counts = {}
    for _ in range(1000):  # 10 s
        for name in sim.step():
            counts[name] = counts.get(name, 0) + 1
    assert sim.time == pytest.approx(10.0)
    # due at t = 0 (the first step) and then every period up to t = 10 s inclusive
    assert counts == {"laser": 101, "camera": 151, "odom": 301, "sensor_state": 101, "kinect_aux": 101,
                      "people": 101, "diagnostics": 11}


def test_laser_self_hits_see_the_standoffs_only_when_asked(robot):
    """The inverted Hokuyo under plate_1 sees the two front standoffs of plate_0 at about +-85 deg."""
    cyls = robot.vertical_cylinders()
    mount = robot.pose("base_laser_link")
    plain = UrgLaser(mount, LaserConfig(noise=0.0), robot_cylinders=cyls)
    seeing = UrgLaser(mount, LaserConfig(noise=0.0, self_hits=True), robot_cylinders=cyls)
    assert sorted(c[0] for c in seeing.robot_cylinders) == [f"plate_0_standoff_{i}_link" for i in range(4)]
    scene = Scene(room(6.0))
    near = seeing.scan(scene, 3.0, 3.0, 0.3)
    assert np.all(plain.scan(scene, 3.0, 3.0, 0.3) > 0.5)
    hits = np.abs(seeing.angles[(near > 0) & (near < 0.3)])
    assert len(hits) >= 2 and np.all((hits > 1.3) & (hits < 1.571)), np.degrees(hits)
    assert np.all(near[(near > 0) & (near < 0.3)] > 0.12)


def test_height_scales_every_height_and_the_forward_reach():
    default, tall = Person("a", x=1.0, y=0.0), Person("a", x=1.0, y=0.0, height=1.90)
    assert max(c.z1 for c in tall.primitives()) == pytest.approx(1.90)  # the head's top
    k = 1.90 / 1.72
    for d, t in zip(default.primitives(), tall.primitives(), strict=True):
        assert (t.z0, t.z1) == pytest.approx((d.z0 * k, d.z1 * k)) and t.radius == d.radius
        assert (t.x, t.y) == pytest.approx((d.x, d.y))  # standing still: no forward offsets
    sitting = Person("b", x=1.0, y=0.0, posture="sitting", height=1.55)
    legs, torso, head = sitting.primitives()
    k = 1.55 / 1.72
    assert head.z1 == pytest.approx(1.32 * k) and torso.z0 == pytest.approx(0.50 * k)
    assert legs.z1 == pytest.approx(0.50 * k) and legs.x == pytest.approx(1.0 + 0.15 * k)  # thighs forward
    # walking: the legs swing SWING * height / 1.72 and a stride is as much longer
    walkers = [Person("w", path=[(0.0, 0.0), (9.0, 0.0)], height=h) for h in (1.72, 2.0)]
    swings = []
    for p in walkers:
        _walk(p, 0.6 * p.height / 1.72)  # a quarter stride at 0.5 m/s: the legs furthest apart
        left, right = p.primitives()[:2]
        swings.append(left.x - right.x)
    assert swings == pytest.approx([2 * 0.12, 2 * 0.12 * 2.0 / 1.72], abs=1e-3)


def test_build_scales_radii_and_widths_not_heights():
    default, broad = Person("a", x=1.0, y=0.0), Person("a", x=1.0, y=0.0, build=1.2)
    for d, b in zip(default.primitives(), broad.primitives(), strict=True):
        assert b.radius == pytest.approx(1.2 * d.radius) and (b.z0, b.z1) == (d.z0, d.z1)
        assert b.y == pytest.approx(1.2 * d.y)  # the legs further apart
    torso = broad.primitives()[2]
    assert torso.name == "person/a/torso" and torso.radius == pytest.approx(1.2 * 0.18)
    seated = Person("b", posture="sitting", build=0.8).primitives()
    assert [c.radius for c in seated] == pytest.approx([0.8 * 0.15, 0.8 * 0.17, 0.8 * 0.10])
    # the footprint is 0.20 m until the torso is wider
    assert [Person("c", build=b).radius for b in (0.8, 1.0, 1.1)] == [0.2, 0.2, 0.2]
    assert Person("c", build=1.3).radius == pytest.approx(0.18 * 1.3)


def test_a_broad_person_needs_more_room_on_a_path_and_keeps_further_from_the_robot():
    from florence_sim.people import check_path
    from florence_sim.world import WorldError

    scene = Scene([Box("wall", 0.0, 1.05, 0.0, 10.0, 0.1, 0.0, 2.4)])  # face at y = 1.0
    path = [(0.0, 0.78), (3.0, 0.78)]  # 0.22 m from the wall
    check_path(Person("a", path=path), scene)
    check_path(Person("a", path=path, build=1.2), scene)  # torso 0.216 m
    with pytest.raises(WorldError, match=r"person b: path segment 0 .*'wall'.*needs 0\.234 m"):
        check_path(Person("b", path=path, build=1.3), scene)
    p = Person("b", path=[(0.0, 0.0), (4.0, 0.0)], speed=1.0, mode="once", build=1.3)
    for _ in range(400):
        p.step(DT, keep_clear=(2.0, 0.0, 0.17))
    assert p.x == pytest.approx(2.0 - 0.17 - 0.18 * 1.3 - 0.15, abs=0.02)
