"""amcl in florence_sim's apartment with map_server and the shipped amcl_turtlebot_control.launch:
a short scripted tour compared with ground truth, initialpose resets the filter, global_localization
spreads the particles over the map."""

import math

import numpy as np
import pytest

from florence_common.maps import map_file
from florence_common.processes import ManagedProcess, wait_for

pytestmark = pytest.mark.scenario


START = (1.0, 2.5, 0.0)
SHORT_TOUR = [(1.2, 4.6), (2.45, 4.9), (2.45, 5.9)]  # living room -> corridor door, about 4.6 m


@pytest.fixture
def amcl_in_sim(rospy_node, ros_master, launch, tf_buffer, tmp_path):
    import rosgraph

    master = rosgraph.Master("/pytest")
    had_sim_time = master.hasParam("/use_sim_time")
    map_yaml = str(map_file("apartment", "apartment.yaml"))
    tf_buffer.clear()  # transforms of an earlier test's simulation, at later simulated times, must not mix in
    nobody = tmp_path / "nobody.yaml"
    nobody.write_text("people: []\n")
    sim = launch("florence_sim", "florence_sim.launch", f"people:={nobody}", "real_time_factor:=2.0", "seed:=3",
                 f"x:={START[0]}", f"y:={START[1]}", f"yaw:={START[2]}")
    # One roslaunch at a time: two starting together race for the master's run_id.
    wait_for(lambda: rosgraph.Master("/pytest").hasParam("/run_id") or not sim.running(), 60, what="florence_sim")
    assert sim.running(), sim.output()
    server = ManagedProcess(["rosrun", "map_server", "map_server", map_yaml], env=ros_master.env())
    amcl = launch("turtlebot_control", "amcl_turtlebot_control.launch", f"initial_pose_x:={START[0]}",
                  f"initial_pose_y:={START[1]}", f"initial_pose_a:={START[2]}")
    try:
        yield sim, amcl
    finally:
        server.stop()
        # florence_sim.launch set /use_sim_time on the session's master: nodes of later tests must not
        # wait for a /clock that nobody publishes any more.
        if not had_sim_time and master.hasParam("/use_sim_time"):
            master.deleteParam("/use_sim_time")
        # amcl's save_pose_rate stored its last estimate and covariance in /amcl/initial_pose_* and
        # /amcl/initial_cov_*; the launch file sets the pose but not the covariance, so a later amcl on
        # this master would start from the spread of global_localization (seen in the navigation tests)
        if master.hasParam("/amcl"):
            master.deleteParam("/amcl")
        # This simulation's map -> odom and robot frames (sim time) must not mix with later tests' data.
        tf_buffer.clear()


def test_amcl_follows_a_tour_and_resets(amcl_in_sim, tf_buffer):
    import rospy
    from florence_eval.amcl_recorder import TourRecorder
    from florence_eval.tour import estimate_errors, rms
    from geometry_msgs.msg import PoseArray, PoseWithCovarianceStamped
    from std_srvs.srv import Empty

    rec = TourRecorder()
    clouds = []
    rospy.Subscriber("particlecloud", PoseArray, clouds.append, queue_size=5)
    wait_for(lambda: rec.latest_truth() is not None, 120, what="ground truth from florence_sim")
    wait_for(lambda: len(rec.snapshot()[2]) > 0, 120, what="the first amcl_pose")
    # The simulator is on sim time; this process follows /clock (use_sim_time is set by the launch).
    assert rec.drive(SHORT_TOUR, timeout=120.0), "the robot did not complete the tour"
    truth_t, truth, est_t, est, durations = rec.snapshot()
    pos, yaw = estimate_errors(est_t, est, truth_t, truth)
    assert len(est) >= 10, f"only {len(est)} estimates on a 4.6 m tour (update_min_d 0.1 m)"
    assert rms(pos) < 0.1, f"position errors {np.round(pos, 3)}"
    assert math.degrees(rms(yaw)) < 3.0, f"yaw errors {np.round(np.degrees(yaw), 2)}"
    assert len(durations) > 0

    # map -> odom is on tf, post-dated by transform_tolerance (1 s in the launch file).
    t = tf_buffer.lookup_transform("map", "odom", rospy.Time(0), rospy.Duration(10.0))
    assert t.header.stamp.to_sec() > est_t[-1] + 0.5

    # initialpose resets the filter: a pose 1 m off becomes the estimate at once...
    here = rec.latest_truth()
    # not latched: a latched pose would outlive this test and reset the amcl of a later test on this master
    pub = rospy.Publisher("initialpose", PoseWithCovarianceStamped, queue_size=1)

    def publish_initial(x, y, yaw_):
        msg = PoseWithCovarianceStamped()
        msg.header.frame_id = "map"
        msg.header.stamp = rospy.Time.now()
        msg.pose.pose.position.x, msg.pose.pose.position.y = x, y
        msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(yaw_ / 2), math.cos(yaw_ / 2)
        msg.pose.covariance[0] = msg.pose.covariance[7] = 0.01
        msg.pose.covariance[35] = 0.01
        pub.publish(msg)

    def estimate_near(x, y, tol):
        e = rec.snapshot()[3]
        return len(e) and math.hypot(e[-1][0] - x, e[-1][1] - y) < tol

    wait_for(lambda: pub.get_num_connections() > 0, 30, what="amcl to subscribe to initialpose")
    publish_initial(here[0] - 1.0, here[1], here[2])
    rospy.ServiceProxy("request_nomotion_update", Empty)()
    wait_for(lambda: estimate_near(here[0] - 1.0, here[1], 0.3), 30, what="amcl_pose at the new initial pose")
    # ... and the true pose brings it back.
    publish_initial(*here)
    rospy.ServiceProxy("request_nomotion_update", Empty)()
    wait_for(lambda: estimate_near(here[0], here[1], 0.1), 30, what="amcl_pose back at the true pose")
    # rospy shares one publisher per topic in a process: left registered, this one would keep alive the latched
    # /initialpose a later test's session publishes, and that pose would reset every amcl started after it
    # (test_nav_sim's amcl started where test_enablers_sim last carried the robot)
    pub.unregister()

    # global_localization spreads max_particles over the whole free space and publishes the spread
    # set at once (the next scan update may already resample it towards the true pose).
    def extent(cloud):
        xs = np.array([p.position.x for p in cloud.poses])
        ys = np.array([p.position.y for p in cloud.poses])
        return len(xs), np.ptp(xs), np.ptp(ys)

    count = len(clouds)
    rospy.ServiceProxy("global_localization", Empty)()

    def spread():  # the clouds before the call sat at the true pose; the spread covers the 8 m x 10 m apartment
        return any(n >= 1000 and dx > 6.0 and dy > 8.0 for n, dx, dy in map(extent, clouds[count:]))

    wait_for(spread, 30, what="a particle cloud over the whole apartment after global_localization")
