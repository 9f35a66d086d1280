"""Drive the simulated robot along a tour and record amcl_pose and ground truth (tests and bench).

Runs inside a rospy node (the caller initialised it) against a private master where
florence_sim, map_server and amcl run. Times are simulated time.
"""

import threading

import numpy as np
import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped, Twist
from nav_msgs.msg import Odometry
from std_msgs.msg import Float64

from florence_common_ros.convert import yaw_of
from florence_eval.tour import follow


class TourRecorder:
    """Subscribes to ground truth, amcl_pose and amcl's update durations; drives with cmd_vel."""

    def __init__(self, ns="", amcl_node="amcl"):
        self.lock = threading.Lock()
        self.truth_t, self.truth = [], []
        self.est_t, self.est, self.cov = [], [], []
        self.durations = []
        self.reached = 0  # waypoints reached by the last drive()
        self.cmd = rospy.Publisher(ns + "cmd_vel", Twist, queue_size=1)
        self.subs = [
            rospy.Subscriber(ns + "base_pose_ground_truth", Odometry, self._on_truth, queue_size=50),
            rospy.Subscriber(ns + "amcl_pose", PoseWithCovarianceStamped, self._on_pose, queue_size=50),
            rospy.Subscriber(f"{ns}{amcl_node}/update_duration", Float64, self._on_duration, queue_size=100),
        ]

    def _on_truth(self, msg):
        p = msg.pose.pose
        with self.lock:
            self.truth_t.append(msg.header.stamp.to_sec())
            self.truth.append((p.position.x, p.position.y, yaw_of(p.orientation)))

    def _on_pose(self, msg):
        p = msg.pose.pose
        with self.lock:
            self.est_t.append(msg.header.stamp.to_sec())
            self.est.append((p.position.x, p.position.y, yaw_of(p.orientation)))
            self.cov.append(list(msg.pose.covariance))

    def _on_duration(self, msg):
        with self.lock:
            self.durations.append(msg.data)

    def latest_truth(self):
        with self.lock:
            return np.array(self.truth[-1]) if self.truth else None

    def snapshot(self):
        """(truth_t, truth [N, 3], est_t, est [M, 3], durations) as arrays."""
        with self.lock:
            return (np.array(self.truth_t), np.array(self.truth).reshape(-1, 3), np.array(self.est_t),
                    np.array(self.est).reshape(-1, 3), np.array(self.durations))

    def clear_estimates(self):
        with self.lock:
            self.est_t.clear()
            self.est.clear()
            self.cov.clear()
            self.durations.clear()

    def stop(self):
        self.cmd.publish(Twist())

    def drive(self, waypoints, timeout, v_max=0.3, stop_when=None, rate_hz=20.0):
        """Follow the waypoints using ground truth; ``timeout`` [s] of sim time. Returns True if all reached.

        ``stop_when()`` (optional) is checked every cycle and ends the drive early when true.
        """
        rate = rospy.Rate(rate_hz)
        start = rospy.Time.now()
        index = self.reached = 0
        try:
            while index < len(waypoints) and not rospy.is_shutdown():
                if (rospy.Time.now() - start).to_sec() > timeout:
                    return False
                if stop_when is not None and stop_when():
                    return True
                pose = self.latest_truth()
                if pose is None:
                    rate.sleep()
                    continue
                v, w, reached = follow(pose, waypoints[index], v_max=v_max)
                if reached:
                    index += 1
                    self.reached = index
                    continue
                cmd = Twist()
                cmd.linear.x, cmd.angular.z = v, w
                self.cmd.publish(cmd)
                rate.sleep()
            return index >= len(waypoints)
        finally:
            self.stop()
