"""turtlebot_teleop_key: drive the TurtleBot from the keyboard of a terminal (user manual 7.3).

The keys, the speeds and the timing are :mod:`turtlebot_teleop.keys`' (a key held drives, a key
released stops within ~key_timeout); the terminal is :mod:`turtlebot_teleop.terminal`'s. Without a
terminal on standard input it says so and exits with status 1. The terminal is restored whenever
it exits: a quit key, Ctrl-C, roslaunch stopping it, a hang-up, an error.

ROS Parameters: PARAMS below (rendered in the README).

ROS Publishers:
    cmd_vel (geometry_msgs/Twist): linear.x [m/s] and angular.z [rad/s] at ~rate while a key is
        held, zero ~stop_messages times on release, then nothing (the launch file remaps it to the
        multiplexer's teleop input, /cmd_vel_mux/input/teleop); one zero Twist on exit.
"""

import contextlib
import math
import signal
import sys
import time

import rospy
from geometry_msgs.msg import Twist

from florence_common.params import Param, ParamTable
from florence_common_ros.node import build, publish_stop, read_params
from turtlebot_teleop.keys import HELP, QUIT, SPEED, KeyboardTeleop, TeleopConfig
from turtlebot_teleop.terminal import KeyReader, NoTerminal, TerminalClosed

LOG = "turtlebot_teleop_key: "
D = TeleopConfig()
PARAMS = ParamTable(
    Param("speed", float, D.speed, "forward speed at start (q/z, w/x change it by 10 %)", unit="m/s", gt=0),
    Param("turn", float, D.turn, "turn rate at start (q/z, e/c change it by 10 %)", unit="rad/s", gt=0),
    Param("speed_limit", float, D.speed_limit, "highest forward speed the keys reach", unit="m/s", gt=0),
    Param("turn_limit", float, D.turn_limit, "highest turn rate the keys reach", unit="rad/s", gt=0),
    Param("rate", float, D.rate, "commands per second while a key is held", unit="Hz", gt=0, le=100),
    Param("key_timeout", float, D.key_timeout, "no key for this long while the terminal repeats the held key = "
          "released: the robot is told to stop", unit="s", gt=0),
    Param("repeat_delay", float, D.repeat_delay, "after a single key press, how long to wait for the terminal to "
          "start repeating it before it counts as released (the terminal's autorepeat delay, 0.25-0.66 s)",
          unit="s", ge=0),
    Param("stop_messages", int, D.stop_messages, "zero commands sent on release, at ~rate; then nothing, so the "
          "multiplexer hands the robot to the next input", ge=1),
)


class TeleopNode:
    def __init__(self):
        p = read_params(PARAMS)
        config = TeleopConfig(speed=p.speed, turn=p.turn, speed_limit=p.speed_limit, turn_limit=p.turn_limit,
                              rate=p.rate, key_timeout=p.key_timeout, repeat_delay=p.repeat_delay,
                              stop_messages=p.stop_messages)
        self.teleop = KeyboardTeleop(config)  # ValueError (fatal, exit 1) for inconsistent speeds
        self.pub = rospy.Publisher("cmd_vel", Twist, queue_size=5)
        # A hang-up (the terminal window closed, ssh gone) ends the loop like Ctrl-C, so the robot is
        # told to stop and the terminal put back, instead of the default: die on the spot.
        signal.signal(signal.SIGHUP, lambda *_: rospy.signal_shutdown("terminal hang-up"))

    def shutdown(self):
        publish_stop(self.pub, wait=0.05)

    def _publish(self, command):
        msg = Twist()
        msg.linear.x, msg.angular.z = command
        with contextlib.suppress(rospy.ROSException):  # shutting down
            self.pub.publish(msg)

    @staticmethod
    def _say(text):
        """Print to the terminal; a terminal that went away is no reason to fail."""
        with contextlib.suppress(OSError):
            sys.stdout.write(text + "\n")
            sys.stdout.flush()

    def run(self):
        """Read keys until quit, Ctrl-C or hang-up; returns the exit status."""
        try:
            keys = KeyReader(sys.stdin)
        except NoTerminal as exc:
            rospy.logfatal(LOG + "%s: it reads single keys from a terminal. Run it in one: `rosrun turtlebot_teleop "
                           "turtlebot_teleop_key cmd_vel:=/cmd_vel_mux/input/teleop`, or `roslaunch turtlebot_teleop "
                           "keyboard_teleop.launch` from a terminal (or with launch-prefix=\"xterm -e\").", exc)
            return 1
        teleop, status = self.teleop, 0
        try:
            with keys:
                self._say(HELP)
                self._say(teleop.status())
                while not rospy.is_shutdown():
                    wake = teleop.wake_time()
                    timeout = 0.1 if wake is None else min(0.1, max(0.0, wake - time.monotonic()))
                    key = keys.read(timeout)
                    now = time.monotonic()
                    if key is not None:
                        kind = teleop.press(key, now)
                        if kind == QUIT:
                            break
                        if kind == SPEED:
                            self._say(teleop.status())
                    command = teleop.poll(now)
                    if command is not None and all(math.isfinite(v) for v in command):
                        self._publish(command)
        except TerminalClosed as exc:
            rospy.logwarn(LOG + "the terminal closed (%s): robot stopped", exc)
            status = 1
        finally:
            teleop.stop()
            publish_stop(self.pub, wait=0.05)
        return status


def main():
    rospy.init_node("turtlebot_teleop_keyboard")
    node = build(TeleopNode, "turtlebot_teleop_keyboard")
    sys.exit(node.run())
