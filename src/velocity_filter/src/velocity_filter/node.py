"""velocity_filter_node: the last node before the motors (seed 3.6, Table 8).

ROS Parameters:
    ~max_linear_acc (float, 1.0, m/s^2): largest change of the forward speed per second.
    ~max_angular_acc (float, 1.0, rad/s^2): largest change of the turn rate per second.
    ~publishing_rate (float, 50, Hz): fixed rate of the output.
    ~command_timeout (float, 1.0, s): a command this old counts as zero velocity; the
        output then ramps to zero at the acceleration limits.
    ~max_linear_vel (float, 0.5, m/s): absolute cap of |linear.x| in and out.
    ~max_angular_vel (float, 2.0, rad/s): absolute cap of |angular.z| in and out.

Subscribers:
    cmd_vel (geometry_msgs/Twist): desired velocity (linear.x, angular.z; the other
        components are ignored: the base is a differential drive). Commands with a NaN or
        infinite component are rejected with a throttled warning.

Publishers:
    filtered_cmd_vel (geometry_msgs/Twist): the limited velocity, at ~publishing_rate,
        always (zero when idle), so a base with its own command timeout stays stopped.
"""

import contextlib
import threading
import warnings

import rospy
from geometry_msgs.msg import Twist

from velocity_filter.limiter import Limits, VelocityFilter

LOG = "velocity_filter: "


class VelocityFilterNode:
    def __init__(self):
        defaults = Limits()
        limits = Limits(**{name: float(rospy.get_param(f"~{name}", getattr(defaults, name)))
                           for name in defaults.__dataclass_fields__})
        problems = limits.problems()
        if problems:
            raise ValueError("; ".join(problems))
        self.filter = VelocityFilter(limits)
        self._lock = threading.Lock()
        # Synchronous publishing (queue_size=None) without Nagle: the motor command leaves in
        # the timer thread itself, one thread hop less of period jitter (bench/filters.py).
        # rospy warns about queue_size=None on principle; here it is deliberate.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SyntaxWarning)
            self.pub = rospy.Publisher("filtered_cmd_vel", Twist, queue_size=None, tcp_nodelay=True)
        self.sub = rospy.Subscriber("cmd_vel", Twist, self.on_cmd_vel, queue_size=1)
        self.timer = rospy.Timer(rospy.Duration(1.0 / limits.publishing_rate), self.on_timer)
        rospy.loginfo(LOG + "%s", limits)

    def on_cmd_vel(self, msg):
        with self._lock:
            accepted = self.filter.command(msg.linear.x, msg.angular.z, rospy.get_time())
        if not accepted:
            rospy.logwarn_throttle(5.0, LOG + f"rejected a non-finite command "
                                   f"(linear.x={msg.linear.x}, angular.z={msg.angular.z}); keeping the previous one")

    def on_timer(self, _event):
        with self._lock:
            linear, angular = self.filter.step(rospy.get_time())
        out = Twist()
        out.linear.x = linear
        out.angular.z = angular
        try:
            self.pub.publish(out)
        except rospy.ROSException as exc:  # shutting down
            rospy.logdebug(LOG + "publish failed: %s", exc)

    def stop(self):
        """On shutdown, command a safe state once: zero velocity."""
        self.timer.shutdown()
        with contextlib.suppress(rospy.ROSException):
            self.pub.publish(Twist())


def main():
    rospy.init_node("velocity_filter_node")
    try:
        node = VelocityFilterNode()
    except (ValueError, TypeError) as exc:
        rospy.logfatal(LOG + "bad parameters: %s", exc)
        raise SystemExit(1) from exc
    rospy.on_shutdown(node.stop)
    rospy.spin()
