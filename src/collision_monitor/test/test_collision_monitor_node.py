"""collision_monitor_node on a private master, fed synthetic scans through tf (the Hokuyo upside
down, as on the robot): it stops a command into a wall and passes backing away and turning; a
silent laser stops linear motion, a silent Kinect is only reported; non-finite commands are dropped;
/diagnostics and ~state say why."""

import math
import threading
import time

import numpy as np
import pytest

from florence_common.processes import rosrun, stop_all, wait_for

pytestmark = pytest.mark.ros

WALL = 0.35  # [m] a wall across the robot's path, this far ahead of base_footprint
LASER_X = 0.06  # [m] the laser ahead of base_footprint


def transforms():
    import rospy
    from geometry_msgs.msg import TransformStamped

    from florence_common_ros.convert import transform_stamped

    odom = transform_stamped(rospy.Time(0), "odom", "base_footprint", 0.0, 0.0, 0.0)
    laser = TransformStamped()
    laser.header.frame_id, laser.child_frame_id = "base_footprint", "test_laser"
    laser.transform.translation.x, laser.transform.translation.z = LASER_X, 0.15
    laser.transform.rotation.x, laser.transform.rotation.w = 1.0, 0.0  # rolled by pi: upside down
    return [odom, laser]


def laser_scan(stamp, wall=WALL):
    """An upside-down laser's scan of a wall at x = ``wall`` (base frame) over -90..90 degrees."""
    from sensor_msgs.msg import LaserScan

    msg = LaserScan()
    msg.header.stamp, msg.header.frame_id = stamp, "test_laser"
    msg.angle_min, msg.angle_max = -math.pi / 2, math.pi / 2
    msg.angle_increment = math.pi / 360
    msg.range_min, msg.range_max = 0.02, 5.6
    a = msg.angle_min + msg.angle_increment * np.arange(361)
    # upside down, beam angle a points at -a in the base frame: a wall straight ahead is symmetric
    with np.errstate(divide="ignore"):
        r = np.where(np.cos(a) > 0.05, (wall - LASER_X) / np.cos(a), np.inf)
    msg.ranges = np.minimum(r, np.inf).tolist()
    return msg


@pytest.fixture(scope="module")
def monitor(ros_master, rospy_node):
    import rospy
    import tf2_ros
    from geometry_msgs.msg import Twist
    from sensor_msgs.msg import LaserScan

    from collision_monitor.msg import MonitorState

    for stale in ("/use_sim_time",):
        if rospy.has_param(stale):
            rospy.delete_param(stale)
    broadcaster = tf2_ros.StaticTransformBroadcaster()
    broadcaster.sendTransform(transforms())
    proc = rosrun(ros_master, "collision_monitor", "collision_monitor_node",
                  "cmd_vel_in:=/test_cm/in", "cmd_vel:=/test_cm/out",
                  "_sources:=[{name: laser, topic: /test_cm/scan, timeout: 0.5, required: true, self_range: 0.18}, "
                  "{name: kinect, topic: /test_cm/kinect_scan, timeout: 1.0, required: false}]")
    out, states = [], []
    subs = [rospy.Subscriber("/test_cm/out", Twist, lambda m: out.append((m.linear.x, m.angular.z))),
            rospy.Subscriber("/collision_monitor/state", MonitorState, states.append)]
    cmd = rospy.Publisher("/test_cm/in", Twist, queue_size=10)
    scans = rospy.Publisher("/test_cm/scan", LaserScan, queue_size=10)
    feeding = threading.Event()
    feeding.set()
    done = threading.Event()

    def feed():
        while not done.is_set():
            if feeding.is_set():
                scans.publish(laser_scan(rospy.Time.now()))
            time.sleep(0.1)

    feeder = threading.Thread(target=feed, daemon=True)
    feeder.start()
    try:
        wait_for(lambda: cmd.get_num_connections() and all(s.get_num_connections() for s in subs), 30,
                 what="connections to collision_monitor_node")
        yield rospy, cmd, out, states, feeding, proc
    finally:
        done.set()
        feeder.join()
        for handle in (*subs, cmd, scans):
            handle.unregister()
        stop_all(proc)


def send(rospy, cmd, out, states, v, w):
    """Publish (v, w) until the monitor answers it; returns (v out, w out, state message)."""
    from geometry_msgs.msg import Twist

    from florence_harness.topics import publish_until_answered

    msg = Twist()
    msg.linear.x, msg.angular.z = v, w
    state = publish_until_answered(cmd, msg, states, what="answer from collision_monitor_node")
    return state.output.linear.x, state.output.angular.z, state


def test_stops_into_a_wall_and_lets_the_robot_back_away_and_turn(monitor):
    rospy, cmd, out, states, _, _ = monitor
    # the scans of the upside-down laser must have arrived for the wall to be there
    wait_for(lambda: send(rospy, cmd, out, states, 0.3, 0.0)[2].state in ("slow", "stop"), 15,
             what="the wall 0.35 m ahead to slow the robot")
    v, w, state = send(rospy, cmd, out, states, 0.3, 0.0)
    assert 0 < v < 0.3 and state.state == "slow", state  # 0.17 m of clearance: slowed
    assert state.clearance == pytest.approx(WALL - 0.17, abs=0.01)
    assert state.nearest.x == pytest.approx(WALL, abs=0.01)
    v, w, state = send(rospy, cmd, out, states, 0.3, 0.3)
    assert 0 < v < 0.3 and w / v == pytest.approx(1.0), "slowed as a whole: the same path"
    v, w, state = send(rospy, cmd, out, states, -0.3, 0.0)
    assert (v, w, state.state) == (-0.3, 0.0, "clear")
    v, w, state = send(rospy, cmd, out, states, 0.0, 1.0)
    assert (v, w, state.state) == (0.0, 1.0, "turn")
    assert out[-1] == (0.0, 1.0), "the output topic carries what ~state says"
    # move_base keeps clear itself: the monitor only keeps it from touching (~input_stop_distances)
    from std_msgs.msg import String

    active = rospy.Publisher("/active_input", String, queue_size=1, latch=True)
    try:
        active.publish(String("move_base"))
        wait_for(lambda: send(rospy, cmd, out, states, 0.3, 0.0)[2].state == "clear", 10,
                 what="move_base's command passing")
        active.publish(String("teleop"))
        wait_for(lambda: send(rospy, cmd, out, states, 0.3, 0.0)[2].state == "slow", 10, what="teleop's slowed")
    finally:
        active.unregister()


def test_a_command_whose_sender_went_quiet_is_stopped_when_a_scan_shows_a_wall(ros_master, rospy_node):
    """A command older than ~recheck_window is not sent again slowed (that would restart velocity_filter's
    command timeout) but, while velocity_filter still drives it (~stale_window), a new scan that says it must
    slow stops it: move_base starved of CPU sent 0.49 m/s and went quiet, and the robot drove on into a person
    (bench/nav.py under load 10-22, 30 Nov). Its own node: ~stale_window 5 s, so that the test's waits are
    far from the window's ends on a loaded machine."""
    import rospy
    from geometry_msgs.msg import Twist
    from sensor_msgs.msg import LaserScan

    from collision_monitor.msg import MonitorState

    proc = rosrun(ros_master, "collision_monitor", "collision_monitor_node", "__name:=cm_stale",
                  "cmd_vel_in:=/test_cm2/in", "cmd_vel:=/test_cm2/out", "_stale_window:=5.0",
                  "_sources:=[{name: laser, topic: /test_cm2/scan, timeout: 5.0, required: true, self_range: 0.18}]")
    states = []
    sub = rospy.Subscriber("/cm_stale/state", MonitorState, states.append)
    cmd = rospy.Publisher("/test_cm2/in", Twist, queue_size=10)
    scans = rospy.Publisher("/test_cm2/scan", LaserScan, queue_size=10)
    wall = [3.0]
    done = threading.Event()

    def feed():
        while not done.is_set():
            scans.publish(laser_scan(rospy.Time.now(), wall[0]))
            time.sleep(0.1)

    feeder = threading.Thread(target=feed, daemon=True)
    try:
        wait_for(lambda: cmd.get_num_connections() and sub.get_num_connections() and scans.get_num_connections(), 30,
                 what="connections to the second collision_monitor_node")
        feeder.start()
        wait_for(lambda: send(rospy, cmd, [], states, 0.3, 0.0)[2].state == "clear", 15,
                 what="the wall 3 m ahead to leave the command clear")
        n = len(states)
        time.sleep(1.0)  # the sender quiet, the command older than ~recheck_window (0.3 s)
        assert len(states) == n, "nothing sent again while the way stays clear"
        wall[0] = WALL
        wait_for(lambda: len(states) > n, 3.5, what="a stop once the wall is 0.35 m ahead")
        state = states[n]
        assert state.state == "stop" and (state.output.linear.x, state.output.angular.z) == (0.0, 0.0), state
        assert "the last command" in state.reason and "s old" in state.reason, state.reason
        time.sleep(0.5)
        assert len(states) == n + 1, "stopped once"
    finally:
        done.set()
        if feeder.is_alive():
            feeder.join()
        for handle in (sub, cmd, scans):
            handle.unregister()
        stop_all(proc)


def test_a_silent_laser_stops_linear_motion_a_silent_kinect_is_reported(monitor):
    rospy, cmd, out, states, feeding, _ = monitor
    v, w, state = send(rospy, cmd, out, states, -0.2, 0.0)
    assert state.state == "clear" and "no scan from kinect (optional)" in state.reason
    feeding.clear()
    try:
        wait_for(lambda: send(rospy, cmd, out, states, -0.2, 0.3)[2].state == "blind", 10,
                 what="the silent laser to stop the robot")
        v, w, state = send(rospy, cmd, out, states, -0.2, 0.3)
        assert (v, w) == (0.0, 0.3) and "laser silent" in state.reason
        v, w, state = send(rospy, cmd, out, states, 0.0, -0.4)
        assert (v, w, state.state) == (0.0, -0.4, "turn")
    finally:
        feeding.set()
    wait_for(lambda: send(rospy, cmd, out, states, -0.2, 0.0)[2].state == "clear", 10, what="the laser back")


def test_non_finite_commands_are_dropped_and_diagnostics_explain(monitor):
    rospy, cmd, out, states, _, proc = monitor
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import Twist

    send(rospy, cmd, out, states, 0.3, 0.0)  # slowed by the wall
    n = len(states)
    bad = Twist()
    bad.linear.x = math.nan
    for _ in range(5):
        cmd.publish(bad)
        time.sleep(0.05)
    send(rospy, cmd, out, states, 0.0, 0.2)
    assert all(math.isfinite(s.output.linear.x) for s in states[n:])
    wait_for(lambda: "dropped a non-finite command" in proc.output(), 10, what="the warning")

    def status():
        msg = rospy.wait_for_message("/diagnostics", DiagnosticArray, 10)
        return next((s for s in msg.status if "Collision monitor" in s.name), None)

    wait_for(lambda: (s := status()) is not None and any(v.key == "non-finite commands dropped" and v.value != "0"
                                                          for v in s.values), 15, what="diagnostics")
    values = {v.key: v.value for v in status().values}
    assert "judge time p50 / p99 (ms)" in values
    assert any(k.startswith("source laser (/test_cm/scan, required)") for k in values)


def test_an_optional_source_once_heard_from_is_needed(monitor):
    """The Kinect that published and fell silent stops linear motion (no table top is seen any more);
    last in this module: the Kinect stays silent after it."""
    import rospy as rp
    from sensor_msgs.msg import LaserScan

    rospy, cmd, out, states, _, _ = monitor
    kinect = rp.Publisher("/test_cm/kinect_scan", LaserScan, queue_size=10)
    try:
        wait_for(kinect.get_num_connections, 10, what="the kinect source's subscriber")
        scan = laser_scan(rp.Time.now())
        for _ in range(5):
            scan.header.stamp = rp.Time.now()
            kinect.publish(scan)
            time.sleep(0.1)
        v, w, state = send(rospy, cmd, out, states, -0.2, 0.0)
        assert state.state == "clear" and "kinect" not in state.reason, state
        wait_for(lambda: send(rospy, cmd, out, states, -0.2, 0.0)[2].state == "blind", 10,
                 what="the silent kinect to stop the robot")
        v, w, state = send(rospy, cmd, out, states, -0.2, 0.5)
        assert (v, w) == (0.0, 0.5) and "kinect silent" in state.reason
    finally:
        kinect.unregister()
