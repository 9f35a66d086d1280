"""Obstacle points of one sensor with their short memory (collision_monitor.obstacles), and the
~sources list."""

import math

import numpy as np
import pytest
from collision_monitor.depth_memory import DepthMemory
from collision_monitor.obstacles import ObstacleMemory, Scan, camera_info_topic, make_memory, parse_sources

from florence_common import pose
from florence_common.params import ParamError
from florence_common.scan import scan_points

pytestmark = pytest.mark.unit

N = 181  # beams over -90..90 degrees, one a degree
ANGLE_MIN, INC = -math.pi / 2, math.pi / 180


def scan_of(targets, robot=(0.0, 0.0, 0.0), stamp=0.0, range_min=0.05, range_max=4.0, inverted=False):
    """A scan from a sensor at ``robot`` (x, y, yaw in the fixed frame) seeing point ``targets``
    [(x, y)] in the fixed frame (each on its nearest beam); +inf elsewhere."""
    ranges = np.full(N, np.inf)
    local = pose.transform_points(pose.inverse(robot), np.asarray(targets, dtype=float).reshape(-1, 2))
    for x, y in local:
        a = math.atan2(y, x) * (-1 if inverted else 1)
        i = round((a - ANGLE_MIN) / INC)
        if 0 <= i < N:
            ranges[i] = min(ranges[i], math.hypot(x, y))
    m = pose.planar_matrix(*robot)
    if inverted:  # rolled by pi about x: the scan runs clockwise
        m = m @ np.diag([1.0, -1.0, -1.0, 1.0])
    return Scan(ranges, ANGLE_MIN, INC, range_min, range_max, m, stamp)


def xy(memory):
    return {(round(p[0], 1), round(p[1], 1)) for p in memory.points}


def test_scan_points_of_an_inverted_sensor_land_right():
    scan = scan_of([(1.0, 0.5)], inverted=True)
    pts, beams = scan_points(scan.ranges, scan.angle_min, scan.angle_increment, 0.05, 4.0, scan.pose)
    assert len(pts) == 1 and pts[0, :2] == pytest.approx([1.0, 0.5], abs=0.02)
    assert scan.ranges[beams[0]] == pytest.approx(math.hypot(1.0, 0.5))


def test_points_are_replaced_by_each_scan():
    m = ObstacleMemory(memory=3.0)
    m.update(scan_of([(1.0, 0.0), (2.0, 1.0)]))
    assert xy(m) == {(1.0, 0.0), (2.0, 1.0)}
    m.update(scan_of([(2.0, 1.0)], stamp=0.1))  # the first one moved away: its beam sees through
    assert xy(m) == {(2.0, 1.0)}


def test_what_the_sensor_can_no_longer_see_is_remembered_for_a_while():
    m = ObstacleMemory(memory=3.0)
    m.update(scan_of([(0.5, 0.2), (1.0, 1.5)]))
    # the robot turned half a turn: both are behind it now
    assert m.update(scan_of([], robot=(0.0, 0.0, math.pi), stamp=1.0)) == 2
    assert xy(m) == {(0.5, 0.2), (1.0, 1.5)}
    m.update(scan_of([], robot=(0.0, 0.0, math.pi), stamp=3.5))
    assert xy(m) == set(), "forgotten after the memory time"


def test_too_near_to_see_and_hidden_are_remembered_seen_through_is_not():
    m = ObstacleMemory(memory=3.0)
    m.update(scan_of([(1.0, 0.0), (2.0, 0.5)], range_min=0.45))
    # 0.7 m on: the first is 0.3 m ahead, nearer than the Kinect's range_min; a person stepped in
    # front of the second
    m.update(scan_of([(1.5, 0.3)], robot=(0.7, 0.0, 0.0), stamp=0.5, range_min=0.45))
    assert xy(m) == {(1.0, 0.0), (2.0, 0.5), (1.5, 0.3)}
    # the person left: the second is seen again (from this scan), the first still too near
    m.update(scan_of([(2.0, 0.5)], robot=(0.7, 0.0, 0.0), stamp=0.6, range_min=0.45))
    assert xy(m) == {(1.0, 0.0), (2.0, 0.5)}
    assert len(m.points) == 2, "a point seen again is not kept twice"


def test_what_is_too_near_to_see_in_front_is_kept_while_the_robot_stands_before_it():
    m = ObstacleMemory(memory=3.0)
    m.update(scan_of([(1.0, 0.0)], range_min=0.45))
    for k in range(1, 200):  # 20 s standing 0.3 m before it
        m.update(scan_of([], robot=(0.7, 0.0, 0.0), stamp=0.1 * k, range_min=0.45))
    assert xy(m) == {(1.0, 0.0)}
    m.update(scan_of([], robot=(0.7, 0.0, math.pi), stamp=20.0, range_min=0.45))  # turned away
    m.update(scan_of([], robot=(0.7, 0.0, math.pi), stamp=23.5, range_min=0.45))
    assert xy(m) == set()


def test_returns_of_the_robot_itself_are_dropped():
    m = ObstacleMemory(self_range=0.18)
    m.update(scan_of([(0.13, 0.05), (0.6, 0.0)]))
    assert xy(m) == {(0.6, 0.0)}


def test_error_readings_tell_nothing():
    m = ObstacleMemory(memory=3.0)
    m.update(scan_of([(1.0, 0.0)]))
    scan = scan_of([], stamp=0.5)
    scan.ranges[:] = np.nan  # every beam an error
    m.update(scan)
    assert xy(m) == {(1.0, 0.0)}


def test_parse_sources():
    good = parse_sources([{"name": "laser", "topic": "/scan", "required": True},
                          {"name": "kinect", "topic": "/kinect_scan", "timeout": 1.0, "required": False}])
    assert [s.name for s in good] == ["laser", "kinect"]
    assert good[0].timeout == 0.5 and good[0].memory == 3.0 and not good[1].required
    cases = [(None, "non-empty list"), ([], "non-empty list"), (["scan"], r"sources\[0\] must be a mapping"),
             ([{"topic": "/scan"}], "name must be a non-empty"),
             ([{"name": "a", "topic": "/scan", "timeout": -1}], r"sources\[0\] \(a\): timeout must be > 0"),
             ([{"name": "a", "topic": "/scan", "colour": 1}], "unknown parameter"),
             ([{"name": "a", "topic": "/s1"}, {"name": "a", "topic": "/s2"}], "names must be unique"),
             ([{"name": "a", "topic": "/s", "type": "cloud"}], r"type must be one of 'scan', 'depth'"),
             ([{"name": "a", "topic": "/s", "blind_range": 0.6}], r"\(a\): blind_range only apply to type depth"),
             ([{"name": "a", "topic": "/i", "type": "depth", "min_height": 1.0, "max_height": 0.5}],
              "min_height 1.0 > max_height 0.5"),
             ([{"name": "a", "topic": "/i", "type": "depth", "target_width": 0}], "target_width must be >= 1"),
             ([{"name": "a", "topic": "/i", "type": "depth", "resolution": 0.0}], "resolution must be > 0")]
    for raw, message in cases:
        with pytest.raises(ParamError, match=message):
            parse_sources(raw)


def test_depth_sources_get_a_depth_memory_and_their_camera_info():
    scan, depth, named = parse_sources([
        {"name": "laser", "topic": "/scan"},
        {"name": "kinect", "topic": "/camera/depth/image", "type": "depth", "blind_range": 0.6, "padding": 0.02},
        {"name": "other", "topic": "image", "type": "depth", "camera_info": "/cam/info"}])
    assert isinstance(make_memory(scan), ObstacleMemory)
    memory = make_memory(depth)
    assert isinstance(memory, DepthMemory) and memory.blind_range == 0.6 and memory.max_range == 3.0
    assert (memory.min_height, memory.max_height, memory.target_width) == (0.05, 1.0, 160)
    assert camera_info_topic(depth) == "/camera/depth/camera_info"
    assert camera_info_topic(named) == "/cam/info"
    assert camera_info_topic(parse_sources([{"name": "a", "topic": "image", "type": "depth"}])[0]) == "camera_info"
