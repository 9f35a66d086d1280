"""The simulator's state as ROS messages: pure functions of the core's state, kept apart from the
node that publishes them (and tested without a ROS master)."""

import math

import numpy as np
from std_msgs.msg import Header

from florence_common import pose
from florence_common_ros.convert import array_to_image, pose_msg, quaternion_msg, transform_stamped
from florence_sim.sim import TILT_JOINT

# odometry covariance (x, y, z, roll, pitch, yaw) [m^2, rad^2]: planar, z and tilts unknown
ODOM_COVARIANCE = np.diag([1e-3, 1e-3, 1e6, 1e6, 1e6, 1e-3]).ravel().tolist()


class Messages:
    """The simulator's state as ROS messages (no publishing here: the node sends them)."""

    def __init__(self, sim):
        self.sim = sim

    @staticmethod
    def _odometry_msg(stamp, frame, xyyaw, v, w, covariance=None):
        """nav_msgs/Odometry of base_footprint at ``xyyaw`` (x, y, yaw) in ``frame``."""
        from nav_msgs.msg import Odometry

        msg = Odometry()
        msg.header.stamp = stamp
        msg.header.frame_id = frame
        msg.child_frame_id = "base_footprint"
        msg.pose.pose = pose_msg(*xyyaw)
        msg.twist.twist.linear.x, msg.twist.twist.angular.z = v, w
        if covariance is not None:
            msg.pose.covariance = msg.twist.covariance = covariance
        return msg

    def odometry(self, stamp):
        """``odom`` message and the tf odom -> base_footprint."""
        b = self.sim.base
        odom = self._odometry_msg(stamp, "odom", (b.ox, b.oy, b.oyaw), b.odom_v, b.odom_w, ODOM_COVARIANCE)
        return odom, transform_stamped(stamp, "odom", "base_footprint", b.ox, b.oy, b.oyaw)

    def map_to_odom(self, stamp):
        """tf map -> odom = truth * odom^-1 (fake localization)."""
        b = self.sim.base
        map_to_odom = pose.compose((b.x, b.y, b.yaw), pose.inverse((b.ox, b.oy, b.oyaw)))
        return transform_stamped(stamp, "map", "odom", *map_to_odom)

    def ground_truth(self, stamp):
        b = self.sim.base
        return self._odometry_msg(stamp, "map", (b.x, b.y, b.yaw), b.v, b.w)

    def gyro(self, stamp):
        from sensor_msgs.msg import Imu

        b = self.sim.base
        msg = Imu()
        msg.header.stamp = stamp
        msg.header.frame_id = "gyro_link"
        msg.orientation = quaternion_msg(b.oyaw)
        msg.orientation_covariance = [1e6, 0, 0, 0, 1e6, 0, 0, 0, 0.05]
        msg.angular_velocity.z = b.gyro_rate
        msg.angular_velocity_covariance = [1e6, 0, 0, 0, 1e6, 0, 0, 0, 0.05]
        msg.linear_acceleration_covariance = [-1, 0, 0, 0, 0, 0, 0, 0, 0]
        return msg

    def sensor_state(self, stamp):
        from turtlebot_node.msg import TurtlebotSensorState as S

        b = self.sim.base
        distance, angle = b.take_packet_deltas()
        msg = S()
        msg.header.stamp = stamp
        msg.bumps_wheeldrops = b.bumps
        msg.distance, msg.angle = distance, angle
        msg.oi_mode = S.OI_MODE_FULL
        msg.remote_opcode = S.REMOTE_NONE
        msg.charging_state = S.CHARGING_NOT_CHARGING
        msg.voltage, msg.current, msg.temperature = 16000, -800, 25
        msg.charge, msg.capacity = 2500, 3000
        msg.user_analog_input = max(0, min(1023, round(512 + math.degrees(b.gyro_rate) / 0.25 * 0.2)))
        vr = b.cmd_v + b.cmd_w * b.cfg.wheel_separation / 2
        vl = b.cmd_v - b.cmd_w * b.cfg.wheel_separation / 2
        msg.requested_velocity = round(b.cmd_v * 1000)
        msg.requested_radius = 32768 if abs(b.cmd_w) < 1e-9 else round(max(-2000, min(2000, b.cmd_v / b.cmd_w
                                                                                          * 1000)))
        msg.requested_right_velocity, msg.requested_left_velocity = round(vr * 1000), round(vl * 1000)
        return msg

    def scan(self, stamp, ranges):
        from sensor_msgs.msg import LaserScan

        laser = self.sim.laser
        msg = LaserScan()
        msg.header.stamp = stamp
        msg.header.frame_id = laser.cfg.frame_id
        msg.angle_min, msg.angle_max, msg.angle_increment = laser.angle_min, laser.angle_max, laser.increment
        msg.time_increment, msg.scan_time = laser.time_increment, laser.scan_time
        msg.range_min, msg.range_max = laser.range_min, laser.range_max
        msg.ranges = ranges.tolist()
        return msg

    def camera_info(self, stamp, frame):
        from sensor_msgs.msg import CameraInfo

        cam = self.sim.camera
        msg = CameraInfo()
        msg.header.stamp = stamp
        msg.header.frame_id = frame
        msg.width, msg.height = cam.cfg.width, cam.cfg.height
        msg.distortion_model = "plumb_bob"
        msg.D = [0.0] * 5
        msg.K = cam.K
        msg.R = [1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0]
        msg.P = [cam.fx, 0.0, cam.cx, 0.0, 0.0, cam.fy, cam.cy, 0.0, 0.0, 0.0, 1.0, 0.0]
        return msg

    def depth_image(self, stamp, depth):
        """32FC1 [m], NaN for no return (cv_bridge)."""
        return array_to_image(depth.astype(np.float32, copy=False), "32FC1",
                              Header(stamp=stamp, frame_id="camera_depth_optical_frame"))

    def rgb_image(self, stamp, rgb):
        """rgb8 (cv_bridge)."""
        return array_to_image(rgb, "rgb8", Header(stamp=stamp, frame_id="camera_rgb_optical_frame"))

    def points(self, stamp, depth, rgb):
        from sensor_msgs.msg import PointCloud2, PointField

        h, w = depth.shape
        xyz = self.sim.camera.points(depth).astype(np.float32)
        # PCL's packed rgb: 0x00RRGGBB in the bytes of a float32
        packed = (rgb[..., 0].astype(np.uint32) << 16) | (rgb[..., 1].astype(np.uint32) << 8) | rgb[..., 2]
        cloud = np.empty((h, w), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4")])
        cloud["x"], cloud["y"], cloud["z"], cloud["rgb"] = xyz[..., 0], xyz[..., 1], xyz[..., 2], packed
        msg = PointCloud2()
        msg.header.stamp = stamp
        msg.header.frame_id = "camera_rgb_optical_frame"
        msg.height, msg.width = h, w
        msg.fields = [PointField("x", 0, PointField.FLOAT32, 1), PointField("y", 4, PointField.FLOAT32, 1),
                      PointField("z", 8, PointField.FLOAT32, 1), PointField("rgb", 12, PointField.FLOAT32, 1)]
        msg.is_bigendian = False
        msg.point_step = 16
        msg.row_step = 16 * w
        msg.is_dense = False
        msg.data = cloud.tobytes()
        return msg

    def ground_truth_map(self, image):
        """nav_msgs/OccupancyGrid in frame map of a :mod:`florence_sim.mapgen` image of the world."""
        from nav_msgs.msg import OccupancyGrid

        from florence_sim.mapgen import FREE, OCCUPIED

        world = self.sim.world
        image = np.flipud(image)  # row 0 = lowest y, as OccupancyGrid wants
        grid = np.full(image.shape, -1, dtype=np.int8)
        grid[image == FREE] = 0
        grid[image == OCCUPIED] = 100
        msg = OccupancyGrid()
        msg.header.frame_id = "map"
        msg.info.resolution = world.resolution
        msg.info.height, msg.info.width = image.shape
        msg.info.origin.position.x, msg.info.origin.position.y = world.bounds[0]
        msg.info.origin.orientation.w = 1.0
        msg.data = grid.ravel().tolist()
        return msg

    def accelerometer(self, stamp):
        from sensor_msgs.msg import Imu

        msg = Imu()
        msg.header.stamp = stamp
        msg.header.frame_id = "camera_link"
        a = self.sim.accelerometer()
        msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = a
        msg.orientation_covariance = [-1, 0, 0, 0, 0, 0, 0, 0, 0]
        msg.angular_velocity_covariance = [-1, 0, 0, 0, 0, 0, 0, 0, 0]
        return msg

    def joint_states(self, stamp):
        from sensor_msgs.msg import JointState

        msg = JointState()
        msg.header.stamp = stamp
        msg.name = [TILT_JOINT]
        msg.position = [self.sim.tilt]
        return msg

    def people(self, stamp):
        from geometry_msgs.msg import Twist, Vector3

        from florence_sim.msg import People, PersonState

        msg = People()
        msg.header.stamp = stamp
        msg.header.frame_id = "map"
        for p in self.sim.people.values():
            msg.people.append(PersonState(p.id, pose_msg(p.x, p.y, p.yaw),
                                          Twist(Vector3(p.vx, p.vy, 0.0), Vector3()), p.posture, p.walking))
        return msg

    def markers(self, stamp):
        from visualization_msgs.msg import Marker, MarkerArray

        out = MarkerArray()
        out.markers.append(Marker(action=Marker.DELETEALL))
        for i, c in enumerate(cyl for p in self.sim.people.values() for cyl in p.primitives()):
            mk = Marker()
            mk.header.stamp = stamp
            mk.header.frame_id = "map"
            mk.ns, mk.id, mk.type, mk.action = "people", i, Marker.CYLINDER, Marker.ADD
            mk.pose.position.x, mk.pose.position.y, mk.pose.position.z = c.x, c.y, (c.z0 + c.z1) / 2
            mk.pose.orientation.w = 1.0
            mk.scale.x = mk.scale.y = 2 * c.radius
            mk.scale.z = c.z1 - c.z0
            mk.color.r, mk.color.g, mk.color.b = c.color
            mk.color.a = 1.0
            out.markers.append(mk)
        return out
