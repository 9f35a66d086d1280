"""cmd_vel_mux_node: priority multiplexer of velocity commands in front of velocity_filter.

ROS Parameters: PARAMS below (rendered in the README); ~inputs is checked by
cmd_vel_mux.mux.parse_inputs, which names the offending entry.

ROS Subscribers:
    <topic of each input> (geometry_msgs/Twist): the commands of that source.

ROS Publishers:
    cmd_vel (geometry_msgs/Twist): the commands of the input in control (to velocity_filter);
        one zero Twist on shutdown.
    ~active (std_msgs/String, latched): name of the input in control, "idle" when none.
    /diagnostics: the input in control and the messages each input sent.
"""

import threading
from collections import Counter

import rospy
from geometry_msgs.msg import Twist
from std_msgs.msg import String

from cmd_vel_mux.mux import IDLE, PriorityMux, parse_inputs
from florence_common.params import Param, ParamTable
from florence_common_ros.diagnostics import OK, Diagnostics
from florence_common_ros.node import publish_stop, read_params, run

LOG = "cmd_vel_mux: "
PARAMS = ParamTable(
    Param("inputs", list, None, "the sources, each {name, topic, priority, timeout [s]} (config/cmd_vel_mux.yaml); "
          "see cmd_vel_mux.mux for the arbitration rules", optional=True),
    Param("check_rate", float, 50.0, "how often silent inputs are expired", unit="Hz", gt=0),
    Param("stop_on_idle", bool, True, "publish one zero Twist when the active input times out and no other is fresh"),
)


class CmdVelMuxNode:
    def __init__(self):
        p = read_params(PARAMS)
        inputs = parse_inputs(p.inputs)
        self.stop_on_idle = p.stop_on_idle
        self.mux = PriorityMux(inputs)
        self.received = Counter()
        self._lock = threading.Lock()
        self.pub = rospy.Publisher("cmd_vel", Twist, queue_size=10)
        self.active_pub = rospy.Publisher("~active", String, queue_size=1, latch=True)
        self.active_pub.publish(String(self.mux.active_name))
        self.subs = [
            rospy.Subscriber(rospy.resolve_name(m.topic if m.topic.startswith("/") else "~" + m.topic),
                             Twist, self.on_command, callback_args=m.name, queue_size=10)
            for m in inputs
        ]
        self.diag = Diagnostics("cmd_vel_mux")
        self.diag.add("Active input", self._diagnose)
        self.timer = rospy.Timer(rospy.Duration(1.0 / p.check_rate), self.on_timer)
        rospy.loginfo(LOG + "inputs: %s", ", ".join(f"{m.name} (priority {m.priority}, {m.timeout} s)"
                                                     for m in inputs))

    def _announce(self, before):
        if self.mux.active != before:
            rospy.loginfo(LOG + "active input: %s", self.mux.active_name)
            self.active_pub.publish(String(self.mux.active_name))

    def on_command(self, msg, name):
        with self._lock:
            self.received[name] += 1
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


    def _diagnose(self, stat):
        with self._lock:
            active = self.mux.active_name
            received = dict(self.received)
        stat.summary(OK, f"in control: {active}" if active != IDLE else "idle: no input in control")
        for name in self.mux.inputs:
            stat.add(f"messages from {name}", received.get(name, 0))
        return stat

    def shutdown(self):
        """A safe state on the way out: one zero Twist to velocity_filter."""
        self.timer.shutdown()
        publish_stop(self.pub, wait=0.0)


def main():
    run(CmdVelMuxNode, "cmd_vel_mux")
