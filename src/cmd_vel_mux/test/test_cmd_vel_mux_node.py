"""cmd_vel_mux_node against a private master: priority take-over, timeout hand-back, idle
stop; and the launch files wiring every producer into it."""

import time

import pytest
import roslaunch.config
import roslaunch.xmlloader

from florence_common.processes import roslaunch as start_roslaunch
from florence_common.processes import stop_all, wait_for
from florence_harness import workspace

TELEOP_TIMEOUT = 0.5  # [s] config/cmd_vel_mux.yaml


def stream(rospy, pub, value, hz=20.0):
    """Publish linear.x = ``value`` at ``hz`` from a rospy timer; returns (timer, record of the last send)."""
    from geometry_msgs.msg import Twist

    msg, sent = Twist(), {}
    msg.linear.x = value

    def tick(_event):
        pub.publish(msg)
        sent["last"] = time.monotonic()

    return rospy.Timer(rospy.Duration(1.0 / hz), tick), sent


def stop(timer):
    timer.shutdown()
    timer.join()


@pytest.mark.ros
def test_priority_take_over_timeout_hand_back_and_idle_stop(ros_master, rospy_node):
    rospy = rospy_node
    from geometry_msgs.msg import Twist
    from std_msgs.msg import String

    proc = start_roslaunch(ros_master, "cmd_vel_mux", "cmd_vel_mux.launch")
    out, active = [], []
    sub = rospy.Subscriber("/cmd_vel", Twist, lambda m: out.append((time.monotonic(), m.linear.x)))
    sub_active = rospy.Subscriber("/cmd_vel_mux/active", String, lambda m: active.append((time.monotonic(), m.data)))
    nav = rospy.Publisher("/cmd_vel_mux/input/move_base", Twist, queue_size=10)
    teleop = rospy.Publisher("/cmd_vel_mux/input/teleop", Twist, queue_size=10)
    streams = []
    try:
        wait_for(lambda: active and active[-1][1] == "idle", 30.0, what="latched 'idle' at start")
        wait_for(lambda: nav.get_num_connections() and teleop.get_num_connections() and sub.get_num_connections(),
                 30.0, what="connections")
        streams.append(stream(rospy, nav, 0.1)[0])
        wait_for(lambda: out and out[-1][1] == 0.1 and active[-1][1] == "move_base", 10.0, what="move_base forwarded")

        teleop_timer, teleop_sent = stream(rospy, teleop, 0.3)
        streams.append(teleop_timer)
        wait_for(lambda: active[-1][1] == "teleop", 10.0, what="teleop takes over")
        took_over = active[-1][0]
        wait_for(lambda: len([1 for t, _ in out if t > took_over]) >= 10, 10.0, what="teleop forwarded")
        # While teleop is fresh, move_base (still streaming) is not forwarded.
        assert {v for t, v in out if t > took_over + 0.05} == {0.3}

        stop(teleop_timer)
        silent_from = teleop_sent["last"]
        wait_for(lambda: active[-1][1] == "move_base", 10.0, what="hand-back to move_base")
        handed_back = active[-1][0]
        assert TELEOP_TIMEOUT - 0.05 <= handed_back - silent_from <= TELEOP_TIMEOUT + 0.3
        wait_for(lambda: out[-1][1] == 0.1, 5.0, what="move_base forwarded again")

        stop(streams[0])
        wait_for(lambda: active[-1][1] == "idle", 10.0, what="idle after move_base stops")
        wait_for(lambda: out[-1][1] == 0.0, 5.0, what="one zero Twist when idle")
    finally:
        for timer in streams:
            stop(timer)
        for handle in (sub, sub_active, nav, teleop):
            handle.unregister()
        stop_all(proc)


def load(relative):
    config = roslaunch.config.ROSLaunchConfig()
    loader = roslaunch.xmlloader.XmlLoader()
    loader.ignore_unset_args = False
    loader.load(str(workspace.root() / relative), config, verbose=False)
    return {n.name: n for n in config.nodes}


@pytest.mark.unit
def test_launch_files_wire_every_producer_through_the_mux_and_the_filter():
    minimal = load("src/turtlebot_control/launch/minimal_control.launch")
    assert minimal["cmd_vel_mux"].package == "cmd_vel_mux"
    assert "cmd_vel" not in dict(minimal["velocity_filter_node"].remap_args)  # subscribes to the mux's cmd_vel
    assert dict(minimal["turtlebot_node"].remap_args)["cmd_vel"] == "filtered_cmd_vel"
    nav = load("src/turtlebot_control/config/move_base_turtlebot_control.launch")
    assert dict(nav["move_base"].remap_args)["cmd_vel"] == "cmd_vel_mux/input/move_base"
    components = load("src/florence_bringup/launch/florence_components.launch")
    assert dict(components["follow_me_node"].remap_args)["cmd_vel"] == "cmd_vel_mux/input/follow_me"
    assert dict(components["approach_me_node"].remap_args)["cmd_vel"] == "cmd_vel_mux/input/approach_me"
