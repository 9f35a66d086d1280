"""approach_me_node on a private master, fed synthetic tracked_users, scans and tf (a robot that does
not move: no simulator): bad goals, nobody near and a pose inside an obstacle end ABORTED with a
reason at once; a goal drives (commands, feedback, the goal pose); cancel sends a zero command at
once; a person who vanishes, one who walks away, and a robot that makes no progress end ABORTED
with their reasons."""

import math
import threading
import time

import numpy as np
import pytest

from florence_common.processes import rosrun, stop_all, wait_for
from florence_harness.behaviours import assert_refused_at_once, finish

pytestmark = pytest.mark.ros

# the robot stands at (1, 2) in odom facing +y; the person 1.5 m ahead of it at (1, 3.5); a wall
# across at y = 4.2, 0.7 m beyond the person
ROBOT = (1.0, 2.0, math.pi / 2)
PERSON = (1.0, 3.5)
WALL_Y = 4.2


@pytest.fixture(scope="module")
def node(ros_master, rospy_node):
    import rospy
    import tf2_ros
    from approach_me.msg import ApproachMeAction
    from geometry_msgs.msg import Point, Twist, Vector3
    from sensor_msgs.msg import LaserScan
    from std_msgs.msg import String

    from florence_common_ros.actions import SimpleActionClient
    from florence_common_ros.convert import transform_stamped
    from user_tracker_ni.msg import TrackedUsers

    if rospy.has_param("/use_sim_time"):
        rospy.delete_param("/use_sim_time")
    tf2_ros.StaticTransformBroadcaster().sendTransform([
        transform_stamped(rospy.Time(0), "odom", "am_base", *ROBOT),
        transform_stamped(rospy.Time(0), "am_base", "am_laser", 0.0, 0.0, 0.0)])
    proc = rosrun(ros_master, "approach_me", "approach_me_node", "__name:=approach_me_node",
                  "tracked_users:=/am/users", "cmd_vel:=/am/cmd_vel", "_base_frame:=am_base", "_lost_timeout:=1.0",
                  "_stuck_timeout:=2.0",
                  "_sources:=[{name: laser, topic: /am/scan, timeout: 0.5, required: true}]")
    cmds, states = [], []
    subs = [rospy.Subscriber("/am/cmd_vel", Twist, lambda m: cmds.append((time.monotonic(), m.linear.x, m.angular.z))),
            rospy.Subscriber("/approach_me_node/state", String, lambda m: states.append(m.data))]
    users = rospy.Publisher("/am/users", TrackedUsers, queue_size=10)
    scans = rospy.Publisher("/am/scan", LaserScan, queue_size=10)
    people = {"now": {5: PERSON}}
    done = threading.Event()

    def feed():
        a = np.linspace(-math.pi / 2, math.pi / 2, 181)
        with np.errstate(divide="ignore"):  # the wall across, seen from the robot (facing +y)
            ranges = np.where(np.cos(a) > 0.1, (WALL_Y - ROBOT[1]) / np.cos(a), np.inf)
        while not done.is_set():
            now = rospy.Time.now()
            msg = TrackedUsers()
            msg.stamp, msg.frame_id = now, "odom"
            for pid, (x, y) in people["now"].items():
                msg.user_ids.append(pid)
                msg.user_ids_ni.append(pid)
                msg.positions.append(Point(x, y, 0.85))
                msg.velocities.append(Vector3())
                msg.last_seen.append(now)
            msg.num_users_tracked = len(people["now"])
            users.publish(msg)
            scan = LaserScan()
            scan.header.stamp, scan.header.frame_id = now, "am_laser"
            scan.angle_min, scan.angle_max, scan.angle_increment = -math.pi / 2, math.pi / 2, math.pi / 180
            scan.range_min, scan.range_max = 0.02, 5.6
            scan.ranges = ranges.tolist()
            scans.publish(scan)
            time.sleep(0.05)

    feeder = threading.Thread(target=feed, daemon=True)
    feeder.start()
    client = SimpleActionClient("approach_me", ApproachMeAction)
    try:
        assert client.wait_for_server(rospy.Duration(60)), f"no approach_me server:\n{proc.output()}"
        # (the obstacle source /am/scan is subscribed only while a goal runs)
        wait_for(lambda: all(s.get_num_connections() for s in subs) and users.get_num_connections(), 30,
                 what="connections")
        time.sleep(1.0)  # a fresh action client's first goal can be lost while connections settle
        people["scans"] = scans
        yield client, cmds, states, people
    finally:
        done.set()
        feeder.join()
        for handle in (*subs, users, scans):
            handle.unregister()
        stop_all(proc)


def goal(x=1.5, y=0.0, distance=0.0, p2r=0.0, r2p=0.0, speed=0.0, turn=0.0):
    from approach_me.msg import ApproachMeGoal

    return ApproachMeGoal(x=x, y=y, desired_distance=distance, desired_p2r_orientation=p2r,
                          desired_r2p_orientation=r2p, max_lin_speed=speed, max_ang_speed=turn)


def test_bad_goals_nobody_near_and_a_pose_in_a_wall_are_aborted_at_once(node):
    client, *_ = node
    cases = [(goal(x=math.nan), "x = nan"), (goal(distance=-0.5), "desired_distance = -0.5"),
             (goal(p2r=math.inf), "desired_p2r_orientation = inf"), (goal(turn=-1.0), "max_ang_speed = -1.0"),
             (goal(x=0.1), "the robot's own position"), (goal(distance=0.3), "below the robot's radius"),
             (goal(x=-2.0), "no tracked person within 0.60 m"),
             # behind the person, 0.7 m: in the wall 0.7 m beyond them
             (goal(distance=0.7, p2r=math.pi), "inside an obstacle")]
    assert_refused_at_once(client, cases)


def test_drives_gives_feedback_and_cancel_stops_at_once(node):
    from actionlib_msgs.msg import GoalStatus

    client, cmds, states, people = node
    scans = people["scans"]
    # no goal (the last test's ended): approach_me takes nothing from its obstacle sources (the publisher
    # counts a connection until its next message finds it closed)
    wait_for(lambda: scans.get_num_connections() == 0, 10, what="no subscriber to the obstacle source between goals")
    feedback = []
    client.send_goal(goal(p2r=math.pi / 2), feedback_cb=lambda fb: feedback.append((fb.x, fb.y)))
    wait_for(lambda: len(feedback) >= 5 and cmds and cmds[-1][2] != 0.0, 10, what="commands")
    assert scans.get_num_connections() == 1  # subscribed for the goal
    assert feedback[-1] == pytest.approx((1.5, 0.0), abs=0.01)
    # p2r = +90 degrees: counter-clockwise at the person from the line person -> robot (south), i.e.
    # east of the person: ahead-right of the robot, which turns right (REP 103: w < 0)
    assert cmds[-1][2] < 0 and "driving to the goal position" in states[-1]
    t_cancel = time.monotonic()
    client.cancel_goal()
    wait_for(lambda: cmds[-1][0] > t_cancel and cmds[-1][1:] == (0.0, 0.0), 5, what="a zero command after cancel")
    # wall time, the cancel's round trip: the zero leaves from the preempt callback at once (the
    # scenario test judges 0.2 s of simulated time)
    assert next(t for t, v, w in cmds if t > t_cancel and (v, w) == (0.0, 0.0)) - t_cancel < 0.5
    state, _, result = finish(client)
    assert state == GoalStatus.PREEMPTED and (result.x, result.y) == pytest.approx((1.5, 0.0), abs=0.01)
    wait_for(lambda: scans.get_num_connections() == 0, 10, what="the obstacle source unsubscribed after the goal")


@pytest.mark.parametrize("event, reason", [("vanish", "person lost"), ("walk", "the person moved away"),
                                           ("stay", "no progress for 2 s")])
def test_ends_with_the_reason(node, event, reason):
    from actionlib_msgs.msg import GoalStatus

    client, cmds, states, people = node
    time.sleep(0.3)  # the person back in the tracker's messages after the previous case
    client.send_goal(goal())
    wait_for(lambda: states and "driving" in states[-1], 10,
             what=f"driving ({client.get_state()}: {client.get_goal_status_text()})")
    if event == "vanish":
        people["now"] = {}
    elif event == "walk":
        people["now"] = {5: (2.3, 3.5)}  # 1.3 m aside: taken as them (the same id), but too far
    try:
        state, text, _ = finish(client, 15.0)
        assert state == GoalStatus.ABORTED and reason in text, text
        # the zero goes out before the result, on another connection: it may arrive after it
        wait_for(lambda: cmds[-1][1:] == (0.0, 0.0) and states[-1] == "idle", 5,
                 what="a zero command and idle")
    finally:
        people["now"] = {5: PERSON}


def test_the_manuals_python_example_reports_a_refused_approach(node, ros_master):
    """florence_bringup's examples/enablers_client.py approach, as the README runs it, with nobody
    where it says: ABORTED with the server's reason, exit status 1."""
    example = rosrun(ros_master, "florence_bringup", "enablers_client.py", "approach", "-2.0", "0.0")
    try:
        wait_for(lambda: example.proc.poll() is not None, 60, what="enablers_client.py approach to end")
    finally:
        out = example.output()
        example.stop()
    assert example.proc.returncode == 1 and "approach_me: ABORTED (no tracked person within" in out, out
