"""velocity_filter_node: the last node before the motors (seed 3.6, Table 8).

ROS Parameters: PARAMS below (rendered in the README); non-positive or non-finite values are
a fatal error at start-up.

ROS Subscribers:
    cmd_vel (geometry_msgs/Twist): desired velocity (linear.x, angular.z; the other
        components are ignored: the base is a differential drive). Commands with a NaN or
        infinite component are rejected with a throttled warning.

ROS Publishers:
    filtered_cmd_vel (geometry_msgs/Twist): the limited velocity, at ~publishing_rate,
        always (zero when idle), so a base with its own command timeout stays stopped; one
        zero Twist on shutdown.
    /diagnostics: output rate, whether the input timed out, rejected commands.
"""

import threading
import warnings

import rospy
from geometry_msgs.msg import Twist

from florence_common.params import Param, ParamTable
from florence_common_ros.diagnostics import OK, WARN, Diagnostics
from florence_common_ros.node import publish_stop, read_params, run
from velocity_filter.limiter import Limits, VelocityFilter

LOG = "velocity_filter: "
PARAMS = ParamTable(
    Param("max_linear_acc", float, Limits.max_linear_acc, "largest change of the forward speed per second (seed)",
          unit="m/s^2", gt=0),
    Param("max_angular_acc", float, Limits.max_angular_acc, "largest change of the turn rate per second (seed)",
          unit="rad/s^2", gt=0),
    Param("publishing_rate", float, Limits.publishing_rate, "fixed rate of the output (seed)", unit="Hz", gt=0),
    Param("command_timeout", float, Limits.command_timeout,
          "a command this old counts as zero velocity; the output then ramps to zero (seed)", unit="s", gt=0),
    Param("max_linear_vel", float, Limits.max_linear_vel,
          "absolute cap of |linear.x| in and out (the Create's top speed)", unit="m/s", gt=0),
    Param("max_angular_vel", float, Limits.max_angular_vel, "absolute cap of |angular.z| in and out", unit="rad/s",
          gt=0),
)


class VelocityFilterNode:
    def __init__(self):
        limits = Limits(**read_params(PARAMS))
        self.filter = VelocityFilter(limits)
        self._lock = threading.Lock()
        self.rejected = 0
        # Synchronous publishing (queue_size=None) without Nagle: the motor command leaves in
        # the timer thread itself, one thread hop less of period jitter (bench/filters.py).
        # rospy warns about queue_size=None on principle; here it is deliberate.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SyntaxWarning)
            self.pub = rospy.Publisher("filtered_cmd_vel", Twist, queue_size=None, tcp_nodelay=True)
        self.diag = Diagnostics("velocity_filter")
        rate = limits.publishing_rate
        self.out_rate = self.diag.frequency("Output rate", 0.9 * rate, 1.1 * rate)
        self.diag.add("Commands", self._diagnose)
        self.sub = rospy.Subscriber("cmd_vel", Twist, self.on_cmd_vel, queue_size=1)
        self.timer = rospy.Timer(rospy.Duration(1.0 / rate), self.on_timer)
        rospy.loginfo(LOG + "%s", limits)

    def on_cmd_vel(self, msg):
        with self._lock:
            accepted = self.filter.command(msg.linear.x, msg.angular.z, rospy.get_time())
            self.rejected += not accepted
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
            self.out_rate.tick()
        except rospy.ROSException as exc:  # shutting down
            rospy.logdebug(LOG + "publish failed: %s", exc)

    def _diagnose(self, stat):
        with self._lock:
            timed_out = self.filter.timed_out(rospy.get_time())
            linear, angular = self.filter.linear, self.filter.angular
        stat.summary(WARN if self.rejected else OK,
                     ("no command within the timeout: ramping to zero" if timed_out else "following commands")
                     + (f"; {self.rejected} non-finite command(s) rejected" if self.rejected else ""))
        stat.add("input timed out", timed_out)
        stat.add("output linear.x (m/s)", f"{linear:.3f}")
        stat.add("output angular.z (rad/s)", f"{angular:.3f}")
        stat.add("rejected commands", self.rejected)
        return stat

    def shutdown(self):
        """On shutdown, command a safe state once: zero velocity."""
        self.timer.shutdown()
        publish_stop(self.pub, wait=0.0)


def main():
    run(VelocityFilterNode, "velocity_filter_node")
