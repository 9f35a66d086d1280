"""Closed-loop moves on odometry through the multiplexer's teleop input, as a person at the
keyboard (turtlebot_teleop) would drive: above move_base, through velocity_filter."""

import math
import time

from florence_common import angles
from florence_common.processes import ProcessError, wait_for

TELEOP = "/cmd_vel_mux/input/teleop"
PERIOD = 0.05  # [s, wall] between commands (20 Hz)


class Teleop:
    def __init__(self, rospy, observer, timeout):
        from geometry_msgs.msg import Twist

        self.obs = observer
        self.timeout = timeout  # [s, wall] for any one move
        self.Twist = Twist
        self.pub = rospy.Publisher(TELEOP, Twist, queue_size=1)
        wait_for(lambda: self.pub.get_num_connections() > 0, timeout, what="cmd_vel_mux on its teleop input")

    def _run(self, command, done, sim_limit):
        """Publish ``command()`` -> (v [m/s], w [rad/s]) until ``done()`` or ``sim_limit`` [s, sim]; then stop."""
        start, deadline = self.obs.now(), time.monotonic() + self.timeout
        cmd = self.Twist()
        while not done() and self.obs.now() - start < sim_limit:
            if time.monotonic() > deadline:
                raise ProcessError(f"a move did not finish in {self.timeout:.0f} s")
            cmd.linear.x, cmd.angular.z = command()
            self.pub.publish(cmd)
            time.sleep(PERIOD)
        self.stop()

    def stop(self):
        """Zero command, then 0.3 s of simulated time for the base to settle."""
        self.pub.publish(self.Twist())
        start = self.obs.now()
        wait_for(lambda: self.obs.now() > start + 0.3, self.timeout, what="the robot to stop")

    def straight(self, distance, speed=0.3, until=None):
        """Drive ``distance`` [m] by odometry (negative: backwards), slowing down near the end;
        ``until()`` true ends the move early."""
        x0, y0, _ = self.obs.odom()

        def remaining():
            x, y, _ = self.obs.odom()
            return abs(distance) - math.hypot(x - x0, y - y0)

        def command():
            return math.copysign(min(speed, max(0.05, remaining())), distance), 0.0

        self._run(command, lambda: remaining() <= 0.005 or (until is not None and until()),
                  sim_limit=abs(distance) / 0.05 + 5.0)

    def turn(self, angle, rate=0.8):
        """Turn ``angle`` [rad] (positive: counter-clockwise) by the odometry heading."""
        yaw0 = self.obs.odom()[2]

        def remaining():
            return abs(angle) - abs(angles.diff(self.obs.odom()[2], yaw0))

        def command():
            return 0.0, math.copysign(min(rate, max(0.1, 1.5 * remaining())), angle)

        self._run(command, lambda: remaining() <= math.radians(0.5), sim_limit=abs(angle) / 0.1 + 5.0)
