"""What the demo watches: every topic of RATES counted, the latest message of the topics it reads.

(rospy shares one connection per topic and process, so each topic gets one subscriber here.)
"""

import importlib
import threading

from florence_common_ros.convert import to_xyyaw

# topic -> (message module, class) whose rate the report gives
RATES = {
    "/clock": ("rosgraph_msgs.msg", "Clock"),
    "/odom": ("nav_msgs.msg", "Odometry"),
    "/imu/data": ("sensor_msgs.msg", "Imu"),
    "/scan": ("sensor_msgs.msg", "LaserScan"),
    "/camera/depth/image": ("sensor_msgs.msg", "Image"),
    "/camera/rgb/points": ("sensor_msgs.msg", "PointCloud2"),
    "/turtlebot_node/sensor_state": ("turtlebot_node.msg", "TurtlebotSensorState"),
    "/cur_tilt_angle": ("std_msgs.msg", "Float64"),
    "/base_pose_ground_truth": ("nav_msgs.msg", "Odometry"),
    "/people_ground_truth": ("florence_sim.msg", "People"),
    "/diagnostics": ("diagnostic_msgs.msg", "DiagnosticArray"),
}
# the topics whose content the scenario reads (the others, images and clouds, are counted undecoded)
CONTENT = ("/clock", "/odom", "/base_pose_ground_truth", "/turtlebot_node/sensor_state", "/cur_tilt_angle",
           "/people_ground_truth")


class Observer:
    def __init__(self, rospy):
        self.lock = threading.Lock()
        self.latest, self.count = {}, dict.fromkeys(RATES, 0)
        self.subs = []
        for topic, (module, name) in RATES.items():
            cls = getattr(importlib.import_module(module), name) if topic in CONTENT else rospy.AnyMsg
            self.subs.append(rospy.Subscriber(topic, cls, self._callback(topic), queue_size=100))

    def _callback(self, topic):
        def cb(msg):
            with self.lock:
                self.latest[topic] = msg
                self.count[topic] += 1

        return cb

    def get(self, topic):
        with self.lock:
            return self.latest.get(topic)

    def counts(self):
        with self.lock:
            return dict(self.count)

    def ready(self):
        """True once every topic of CONTENT has been heard."""
        return all(self.get(t) is not None for t in CONTENT)

    def now(self):
        """Simulated time [s] of the latest /clock."""
        clock = self.get("/clock")
        return clock.clock.to_sec() if clock else 0.0

    def odom(self):
        """(x, y, yaw) of the odometry in its own frame."""
        return to_xyyaw(self.get("/odom"))

    def truth(self):
        """(x, y, yaw) of the simulator's ground truth in the map frame."""
        return to_xyyaw(self.get("/base_pose_ground_truth"))

    def close(self):
        for sub in self.subs:
            sub.unregister()
