"""Costmap2DROS against a private ROS master: map, tf (an upside-down laser), a scan, the
published OccupancyGrid.

Frames and topics carry a ``cmtest_`` prefix so nothing collides with other tests; nothing latched
is left behind (the map and tf are published until received, the costmap's publishers are
unregistered) and the shared tf buffer is cleared at the end.
"""

import contextlib
import math
import threading

import numpy as np
import pytest

pytestmark = pytest.mark.ros


NAME = "cmtest_costmap"
SEED_FOOTPRINT = [[-0.16, -0.16], [-0.16, 0.16], [0.19, 0.16], [0.24, 0.0], [0.19, -0.16]]


def set_params(rospy, **overrides):
    params = {
        "global_frame": "/cmtest_map",
        "robot_base_frame": "/cmtest_base",
        "transform_tolerance": 0.5,
        "update_frequency": 0.0,  # updates by update_now() only
        "publish_frequency": 50.0,
        "static_map": True,
        "map_topic": "cmtest_map",
        "footprint": SEED_FOOTPRINT,
        "footprint_padding": 0.01,
        "inflation_radius": 0.4,
        "observation_sources": "scan",
        "scan": {"data_type": "LaserScan", "topic": "cmtest_scan", "marking": True, "clearing": True},
    }
    params.update(overrides)
    if rospy.has_param(f"~{NAME}"):
        rospy.delete_param(f"~{NAME}")
    rospy.set_param(f"~{NAME}", params)


def make_tf(parent, child, xyz, quat):
    from geometry_msgs.msg import TransformStamped

    t = TransformStamped()
    t.header.frame_id, t.child_frame_id = parent, child
    t.transform.translation.x, t.transform.translation.y, t.transform.translation.z = xyz
    (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w) = quat
    return t


class TfPublisher:
    """map -> base at (1.0, 1.02), yaw 0 (off a cell border: the map's float32 resolution is
    0.0500000007 m); base -> laser 0.1 m ahead, 0.2 m up, upside down
    (rolled by pi); plus ``extra`` (parent, child, xyz, quaternion xyzw) transforms; published on
    /tf at 20 Hz with the current time."""

    def __init__(self, rospy, publisher, extra=()):
        from tf2_msgs.msg import TFMessage

        self.rospy = rospy
        self.pub = publisher("/tf", TFMessage)
        self.msg_class = TFMessage
        self.transforms = [
            make_tf("cmtest_map", "cmtest_base", (1.0, 1.02, 0.0), (0.0, 0.0, 0.0, 1.0)),
            make_tf("cmtest_base", "cmtest_laser", (0.1, 0.0, 0.2), (1.0, 0.0, 0.0, 0.0)),
            *(make_tf(*t) for t in extra),
        ]
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    def run(self):
        while not self.stop.is_set():
            stamp = self.rospy.Time.now()
            for t in self.transforms:
                t.header.stamp = stamp
            self.pub.publish(self.msg_class(transforms=self.transforms))
            self.stop.wait(0.05)

    def close(self):
        self.stop.set()
        self.thread.join(timeout=1.0)


def make_map():
    """3 x 2 m at 0.05 m, origin (0, 0), a wall in column 50 (x 2.50..2.55 m)."""
    from nav_msgs.msg import OccupancyGrid

    grid = np.zeros((40, 60), dtype=np.int8)
    grid[:, 50] = 100
    msg = OccupancyGrid()
    msg.header.frame_id = "cmtest_map"
    msg.info.resolution = 0.05
    msg.info.width, msg.info.height = 60, 40
    msg.info.origin.orientation.w = 1.0
    msg.data = grid.ravel().tolist()
    return msg


def make_scan(rospy, stamp):
    """Three beams in the laser frame: -90 deg 0.5 m, 0 deg nothing (range_max), +90 deg 0.8 m."""
    from sensor_msgs.msg import LaserScan

    scan = LaserScan()
    scan.header.frame_id = "cmtest_laser"
    scan.header.stamp = stamp
    scan.angle_min, scan.angle_max, scan.angle_increment = -math.pi / 2, math.pi / 2, math.pi / 2
    scan.range_min, scan.range_max = 0.02, 5.6
    scan.ranges = [0.5, 5.6, 0.8]
    return scan


@contextlib.contextmanager
def costmap_with_map(rospy, publisher, tf_buffer, extra_tf=(), **params):
    """A Costmap2DROS with ``params`` over set_params' and its map received; yields (cm, the
    TfPublisher); everything is shut down, unregistered and cleared at the end."""
    from move_base.costmap_ros import Costmap2DROS
    from nav_msgs.msg import OccupancyGrid

    from florence_common.processes import wait_for

    set_params(rospy, **params)
    tfp = TfPublisher(rospy, publisher, extra=extra_tf)
    cm = Costmap2DROS(NAME, tf_buffer)
    map_pub = publisher("cmtest_map", OccupancyGrid)
    map_msg = make_map()

    def map_arrived():
        map_pub.publish(map_msg)
        return cm.has_map()

    try:
        wait_for(map_arrived, 10.0, interval=0.2, what="the costmap to get its map")
        yield cm, tfp
    finally:
        cm.shutdown()
        tfp.close()
        rospy.delete_param(f"~{NAME}")
        tf_buffer.clear()


@pytest.fixture
def ros_costmap(rospy_node, publisher, tf_buffer):
    from florence_common.processes import wait_for

    with costmap_with_map(rospy_node, publisher, tf_buffer) as (cm, _):
        yield rospy_node, cm, publisher, wait_for


def test_costmap_ros_map_scan_and_published_grid(ros_costmap):
    from nav_msgs.msg import OccupancyGrid
    from sensor_msgs.msg import LaserScan

    rospy, cm, publisher, wait_for = ros_costmap
    assert (cm.global_frame, cm.base_frame) == ("cmtest_map", "cmtest_base")
    c = cm.costmap
    assert (c.size_x, c.size_y, c.resolution) == (60, 40, pytest.approx(0.05))  # the map's geometry
    assert cm.inscribed_radius == pytest.approx(0.17)
    pose = wait_for(cm.get_robot_pose, 10.0, what="the robot pose")
    assert pose == pytest.approx((1.0, 1.02, 0.0), abs=1e-6)

    cm.start()  # accept sensor data (no loop: update_frequency 0)
    with cm.lock:
        cm.layered.obstacles.grid.costs[20, 40] = 254  # an old obstacle at (2.0, 1.02) on the clear beam
    scan_pub = publisher("cmtest_scan", LaserScan)

    def scan_arrived():  # queued by the callback, converted by the next update
        scan_pub.publish(make_scan(rospy, rospy.Time.now() - rospy.Duration(0.1)))
        return cm.queued("scan") > 0

    wait_for(scan_arrived, 10.0, interval=0.2, what="the costmap to take a scan")

    received = []
    sub = rospy.Subscriber(rospy.resolve_name(f"~{NAME}/costmap"), OccupancyGrid, received.append)
    try:
        assert cm.update_now()
        with cm.lock:
            # upside-down laser: its -90 deg beam points to the robot's left (+y), +90 deg to the right
            assert c.cost_at(1.1, 1.52) == 254
            assert c.cost_at(1.1, 0.22) == 254
            assert c.cost_at(1.1, 0.52) < 253  # where an upright laser would have put them
            assert c.cost_at(1.1, 1.82) < 253
            assert c.cost_at(2.02, 1.02) == 0  # cleared by the no-return beam
            assert c.cost_at(2.52, 1.02) == 254  # the static wall stays
            assert c.cost_at(2.47, 1.02) == 253  # 0.05 m from the wall
            assert c.cost_at(2.32, 1.02) == 186  # 0.20 m from the wall: int(252 * exp(-0.3))
        msg = wait_for(lambda: received[-1] if received else None, 10.0, what="the published costmap")
    finally:
        sub.unregister()
    assert msg.header.frame_id == "cmtest_map"
    assert (msg.info.width, msg.info.height, msg.info.resolution) == (60, 40, pytest.approx(0.05))
    data = np.asarray(msg.data, dtype=np.int8).reshape(40, 60)
    hit = c.world_to_map(1.1, 1.52)
    assert data[hit[1], hit[0]] == 100  # lethal
    assert data[20, 50] == 100  # wall
    assert data[20, 49] == 99  # inscribed
    assert data[20, 46] == 1 + (97 * 185) // 251  # 186 -> 72
    assert data[20, 40] == 0
    assert cm.is_current()


def test_costmap_ros_rejects_bad_parameters(rospy_node, tf_buffer):
    from move_base.costmap_ros import Costmap2DROS

    set_params(rospy_node, resolution=-0.05)
    try:
        with pytest.raises(ValueError, match="resolution"):
            Costmap2DROS(NAME, tf_buffer)
        set_params(rospy_node, scan={"data_type": "Sonar"})
        with pytest.raises(ValueError, match="data_type"):
            Costmap2DROS(NAME, tf_buffer)
    finally:
        rospy_node.delete_param(f"~{NAME}")


def test_rolling_costmap_places_the_map_through_tf(rospy_node, publisher, tf_buffer):
    """A local costmap in an odom frame with a static map in the map frame (the keep-out map of
    florence_sim): the map's wall lands where tf puts it, and moves when map -> odom does."""
    from florence_common.processes import wait_for

    half = 0.05  # odom at (0.5, 0.0) in map, turned by 0.1 rad
    odom = ("cmtest_map", "cmtest_odom", (0.5, 0.0, 0.0), (0.0, 0.0, math.sin(half), math.cos(half)))
    c, s = math.cos(0.1), math.sin(0.1)

    def in_odom(x, y):  # a map point in the odom frame
        return c * (x - 0.5) + s * y, -s * (x - 0.5) + c * y

    params = dict(global_frame="/cmtest_odom", rolling_window=True, width=4.0, height=4.0, observation_sources="")
    with costmap_with_map(rospy_node, publisher, tf_buffer, extra_tf=[odom], **params) as (cm, tfp):
        wait_for(cm.update_now, 10.0, what="a costmap update with the robot pose")
        with cm.lock:
            assert cm.costmap.cost_at(*in_odom(2.525, 1.02)) == 254  # the wall, through tf
            assert cm.costmap.cost_at(*in_odom(2.525, 0.2)) == 254
            assert cm.costmap.cost_at(2.525, 1.02) < 253  # not where the map's own numbers put it
        moved = ("cmtest_map", "cmtest_odom", (0.6, 0.0, 0.0), (0.0, 0.0, math.sin(half), math.cos(half)))
        tfp.transforms[-1] = make_tf(*moved)

        def wall_moved():
            cm.update_now()
            with cm.lock:
                return cm.costmap.cost_at(*in_odom(2.425, 1.02)) == 254

        wait_for(wall_moved, 10.0, interval=0.1, what="the wall to follow map -> odom")


# --- issue 21: a Kinect cloud in voxels, the keep-out map, people; bad input --------------------------
def make_cloud(rospy, stamp, points, frame="cmtest_laser", fields="xyz"):
    """A PointCloud2 of ``points`` (N, 3) in ``frame`` with float32 fields named by ``fields``."""
    from sensor_msgs import point_cloud2
    from sensor_msgs.msg import PointField
    from std_msgs.msg import Header

    header = Header(frame_id=frame, stamp=stamp)
    return point_cloud2.create_cloud(header, [PointField(n, 4 * i, PointField.FLOAT32, 1) for i, n in
                                              enumerate(fields)], [tuple(p) for p in points])


def test_voxel_costmap_takes_a_cloud_and_survives_bad_clouds(rospy_node, publisher, tf_buffer):
    """map_type voxel with a PointCloud2 source: a point marks its column (through the upside-down
    laser's frame: 0.1 m ahead, 0.2 m up, rolled); a cloud with NaNs marks its finite points; a cloud
    without z, one in a frame tf does not know and one too short are skipped with a warning."""
    from sensor_msgs.msg import PointCloud2

    from florence_common.processes import wait_for

    cloud = {"data_type": "PointCloud2", "topic": "cmtest_cloud", "marking": True, "clearing": True,
             "min_obstacle_height": 0.05, "max_obstacle_height": 1.0}
    params = dict(map_type="voxel", z_resolution=0.05, z_voxels=20, observation_sources="cloud", cloud=cloud,
                  static_map=False, width=3.0, height=2.0, origin_x=0.0, origin_y=0.0)
    set_params(rospy_node, **params)
    tfp = TfPublisher(rospy_node, publisher)
    from move_base.costmap_ros import Costmap2DROS

    cm = Costmap2DROS(NAME, tf_buffer)
    try:
        pub = publisher("cmtest_cloud", PointCloud2)
        cm.start()
        wait_for(cm.get_robot_pose, 10.0, what="the robot pose")
        # in the laser frame (rolled by pi): x ahead, y to the right, z down; 0.5 m ahead of the laser,
        # 0.1 m below it: (1.6, 1.02, 0.1) in the map. A NaN point rides along.
        good = [(0.5, 0.0, 0.1), (float("nan"), 0.0, 0.0)]

        def marked():
            pub.publish(make_cloud(rospy_node, rospy_node.Time.now() - rospy_node.Duration(0.05), good))
            cm.update_now()
            with cm.lock:
                return cm.layered.obstacles.grid.cost_at(1.62, 1.02) == 254

        wait_for(marked, 10.0, interval=0.2, what="the cloud's point in the voxel layer")
        with cm.lock:
            assert int(np.count_nonzero(cm.layered.obstacles.bits)) == 1
        for bad in [make_cloud(rospy_node, rospy_node.Time.now(), [(0.4, 0.3)], fields="xy"),  # no z
                    make_cloud(rospy_node, rospy_node.Time.now(), [(0.4, 0.3, 0.1)], frame="cmtest_nowhere")]:
            pub.publish(bad)
            wait_for(lambda: cm.queued("cloud") > 0, 10.0, what="the bad cloud queued")
            assert cm.update_now()  # no exception: skipped
        short = make_cloud(rospy_node, rospy_node.Time.now(), [(0.4, 0.3, 0.1)] * 4)
        short.data = short.data[:-1]
        pub.publish(short)
        wait_for(lambda: cm.queued("cloud") > 0, 10.0, what="the short cloud queued")
        assert cm.update_now()
        with cm.lock:
            assert cm.layered.obstacles.grid.cost_at(1.62, 1.02) == 254  # what was there stays
        assert {"reading_cloud"} <= set(cm._warned)  # the warnings (throttled per kind)
    finally:
        cm.shutdown()
        tfp.close()
        rospy_node.delete_param(f"~{NAME}")
        tf_buffer.clear()


def test_keepout_map_of_another_size_is_placed_and_warned_about(rospy_node, publisher, tf_buffer):
    from nav_msgs.msg import OccupancyGrid

    from florence_common.processes import wait_for

    keep = OccupancyGrid()
    keep.header.frame_id = "cmtest_map"
    keep.info.resolution, keep.info.width, keep.info.height = 0.1, 10, 10  # 1 x 1 m at 0.1 m
    keep.info.origin.orientation.w = 1.0
    grid = np.zeros((10, 10), dtype=np.int8)
    grid[5, 5] = 100  # x 0.5..0.6, y 0.5..0.6
    keep.data = grid.ravel().tolist()
    with costmap_with_map(rospy_node, publisher, tf_buffer, keepout_map_topic="cmtest_keepout",
                          observation_sources="") as (cm, _):
        pub = publisher("cmtest_keepout", OccupancyGrid)

        def placed():
            pub.publish(keep)
            return cm.layered.keepout.has_map

        wait_for(placed, 10.0, interval=0.2, what="the keep-out map")
        wait_for(cm.update_now, 10.0, what="an update")
        with cm.lock:
            assert cm.costmap.cost_at(0.55, 0.55) == 254
            assert cm.costmap.cost_at(0.7, 0.55) < 254
        # another size and resolution than the map: said so (by the subscriber's thread, just after it placed
        # the map: wait for it)
        wait_for(lambda: "keepout_geometry" in cm._warned, 10.0, what="the warning about the keep-out map's size")
        bad = OccupancyGrid()
        bad.info.width, bad.info.height, bad.info.resolution = 4, 4, float("nan")
        bad.data = [0] * 16
        pub.publish(bad)
        wait_for(lambda: "keepout" in cm._warned, 10.0, what="the bad keep-out map's warning")
        with cm.lock:
            assert cm.layered.keepout.grid.size_x == 10  # the good one stays


def test_people_costs_lapse_when_the_track_is_gone(rospy_node, publisher, tf_buffer):
    """A proxemic layer on a TrackedUsers topic: a person 0.8 m ahead of the robot raises the costs
    round them; a person at a NaN position is left out with a warning; once the tracker's messages
    no longer hold the person, their cost lapses keep_time after they were last seen."""
    from geometry_msgs.msg import Point, Vector3

    from florence_common.processes import wait_for
    from user_tracker_ni.msg import TrackedUsers

    def users(xy, seen):
        msg = TrackedUsers()
        msg.stamp = rospy_node.Time.now()
        msg.frame_id = "cmtest_map"
        for i, (x, y) in enumerate(xy):
            msg.user_ids.append(i + 1)
            msg.user_ids_ni.append(i + 1)
            msg.positions.append(Point(x, y, 0.85))
            msg.velocities.append(Vector3(0.0, 0.0, 0.0))
            msg.last_seen.append(seen)
        msg.num_users_tracked = len(xy)
        return msg

    with costmap_with_map(rospy_node, publisher, tf_buffer, people_topic="cmtest_people",
                          proxemic={"keep_time": 1.0, "lethal_radius": 0.2}, observation_sources="") as (cm, _):
        pub = publisher("cmtest_people", TrackedUsers)

        def person_in_costmap():
            pub.publish(users([(1.8, 1.02), (float("nan"), 1.0)], rospy_node.Time.now()))
            cm.update_now()
            with cm.lock:
                return cm.costmap.cost_at(1.82, 1.02) == 254 and 0 < cm.costmap.cost_at(1.82, 1.62) < 253

        wait_for(person_in_costmap, 10.0, interval=0.2, what="the person's costs")
        assert "people_nan" in cm._warned
        seen = rospy_node.Time.now()

        def lapsed():
            pub.publish(users([], seen))  # the tracker lost them
            cm.update_now()
            with cm.lock:
                return cm.costmap.cost_at(1.82, 1.62) == 0 and cm.costmap.cost_at(1.82, 1.02) < 253

        with cm.lock:
            assert cm.costmap.cost_at(1.82, 1.62) > 0  # still there right after the track went
        wait_for(lapsed, 10.0, interval=0.2, what="the person's costs to lapse")
        assert (rospy_node.Time.now() - seen).to_sec() >= 0.9
