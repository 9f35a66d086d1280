"""The seed's driver includes start the real drivers; with emulator:=true they run against the
protocol emulators on pseudo-terminals, and odom, tf and the scan come out under the seed's names."""

import threading

import pytest

from florence_common.processes import wait_for

pytestmark = pytest.mark.protocol



def test_emulated_drivers_launch(launch, rospy_node, tmp_path):
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import LaserScan
    from std_msgs.msg import Float32MultiArray, UInt8

    from turtlebot_node.msg import TurtlebotSensorState

    got = {}
    lock = threading.Lock()

    def keep(key):
        def callback(msg):
            with lock:
                got[key] = msg
        return callback

    subs = [rospy_node.Subscriber("/scan", LaserScan, keep("scan")),
            rospy_node.Subscriber("/odom", Odometry, keep("odom")),
            rospy_node.Subscriber("/turtlebot_node/sensor_state", TurtlebotSensorState, keep("state")),
            rospy_node.Subscriber("/create_emulator/ground_truth", Odometry, keep("truth"))]
    bumper = rospy_node.Publisher("/create_emulator/bumper", UInt8, queue_size=1, latch=True)
    ranges = rospy_node.Publisher("/urg_emulator/ranges", Float32MultiArray, queue_size=1, latch=True)
    try:
        launch("turtlebot_control", "emulated_drivers.launch", f"port:={tmp_path}/ttyCreate",
               f"laser_port:={tmp_path}/ttyHokuyo")
        wait_for(lambda: len(got) == 4, 60.0, what="/scan, /odom, ~sensor_state and ground truth")
        with lock:
            scan, odom, state = got["scan"], got["odom"], got["state"]
        assert scan.header.frame_id == "base_laser_link" and len(scan.ranges) == 511
        assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_footprint")
        assert state.oi_mode == 3
        # What a simulator feeds the emulators reaches the drivers' topics.
        bumper.publish(UInt8(2))
        wait_for(lambda: got["state"].bumps_wheeldrops == 2, 10.0, what="bumper through the Create emulator")
        ranges.publish(Float32MultiArray(data=[1.5] * 769))
        wait_for(lambda: set(got["scan"].ranges) == {1.5}, 10.0, what="ranges through the URG emulator")
    finally:
        for sub in subs:
            sub.unregister()
        bumper.unregister()
        ranges.unregister()
