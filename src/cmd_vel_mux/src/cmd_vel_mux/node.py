"""cmd_vel_mux_node: priority multiplexer of velocity commands in front of velocity_filter.

ROS Parameters:
    ~inputs (list, from config/cmd_vel_mux.yaml): the sources, each {name, topic,
        priority, timeout [s]}; see cmd_vel_mux.mux for the arbitration rules.
    ~check_rate (float, 50.0, Hz): how often silent inputs are expired.
    ~stop_on_idle (bool, true): publish one zero Twist when the active input times out
        and no other input is fresh.

Subscribers:
    <topic of each input> (geometry_msgs/Twist): the commands of that source.

Publishers:
    cmd_vel (geometry_msgs/Twist): the commands of the input in control (to velocity_filter).
    ~active (std_msgs/String, latched): name of the input in control, "idle" when none.
"""

import threading

import rospy
from geometry_msgs.msg import Twist
from std_msgs.msg import String

from cmd_vel_mux.mux import PriorityMux, parse_inputs

LOG = "cmd_vel_mux: "


class CmdVelMuxNode:
    def __init__(self):
        inputs = parse_inputs(rospy.get_param("~inputs", None))
        check_rate = float(rospy.get_param("~check_rate", 50.0))
        if not check_rate > 0:
            raise ValueError(f"~check_rate must be > 0 [Hz], got {check_rate}")
        self.stop_on_idle = bool(rospy.get_param("~stop_on_idle", True))
        self.mux = PriorityMux(inputs)
        self._lock = threading.Lock()
        self.pub = rospy.Publisher("cmd_vel", Twist, queue_size=10)
        self.active_pub = rospy.Publisher("~active", String, queue_size=1, latch=True)
        self.active_pub.publish(String(self.mux.active_name))
        self.subs = [
            rospy.Subscriber(rospy.resolve_name(m.topic if m.topic.startswith("/") else "~" + m.topic),
                             Twist, self.on_command, callback_args=m.name, queue_size=10)
            for m in inputs
        ]
        self.timer = rospy.Timer(rospy.Duration(1.0 / check_rate), self.on_timer)
        rospy.loginfo(LOG + "inputs: %s", ", ".join(f"{m.name} (priority {m.priority}, {m.timeout} s)"
                                                     for m in inputs))

    def _announce(self, before):
        if self.mux.active != before:
            rospy.loginfo(LOG + "active input: %s", self.mux.active_name)
            self.active_pub.publish(String(self.mux.active_name))

    def on_command(self, msg, name):
        with self._lock:
            before = self.mux.active
            forward = self.mux.offer(name, rospy.get_time())
            self._announce(before)
            if forward:
                self.pub.publish(msg)

    def on_timer(self, _event):
        with self._lock:
            before = self.mux.active
            went_idle = self.mux.update(rospy.get_time())
            self._announce(before)
            if went_idle and self.stop_on_idle:
                self.pub.publish(Twist())


def main():
    rospy.init_node("cmd_vel_mux")
    try:
        CmdVelMuxNode()
    except (ValueError, TypeError) as exc:
        rospy.logfatal(LOG + "bad configuration: %s", exc)
        raise SystemExit(1) from exc
    rospy.spin()
