"""florence_sim node: the simulator on ROS, standing in for turtlebot_node, hokuyo_node,
the Kinect camera and kinect_aux with their topics, frames and conventions.

ROS Parameters:
    ~world (str, maps/apartment/apartment.world.yaml): world file
    ~people_file (str, ""): people file ("" for nobody)
    ~real_time_factor (float, 1.0): simulated seconds per wall second; 0 runs unthrottled
    ~paused (bool, false): start paused (use ~unpause or ~step)
    ~physics_step (float, 0.01, s): fixed physics step
    ~x, ~y (float, 1.0, 2.5, m), ~yaw (float, 0.0, rad): robot start pose in the map frame
    ~fake_localization (bool, false): publish tf map->odom from ground truth (no amcl needed)
    ~seed (int, 0): random seed of every noise source
    ~min_ang, ~max_ang (float, -pi/2, pi/2, rad): requested scan span, as hokuyo_node's
        parameters (clipped to the URG-04LX's +-2.0862 rad, rounded to its steps)
    ~laser_noise (float, 0.01, m): range noise std below 1 m (1 % of the range beyond)
    ~laser_self_hits (bool, false): the scan also sees the robot's own standoffs at laser height,
        as the real inverted Hokuyo does (laser_filter drops such readings)
    ~laser_rate (float, 10, Hz), ~camera_rate (float, 15, Hz), ~odom_rate (float, 30, Hz)
    ~camera_width, ~camera_height (int, 160, 120, px): Kinect image size (up to 640x480)
    ~depth_noise (float, 0.0012, 1/m): depth noise std = depth_noise * depth^2
    ~render_without_subscribers (bool, false): render the Kinect even when nobody listens
    ~cmd_vel_timeout (float, 0.6, s): sim time without cmd_vel after which the robot stops
    ~max_linear_acc (float, 1.0, m/s^2), ~max_angular_acc (float, 4.0, rad/s^2)
    ~odom_linear_scale_error (float, 0.01), ~odom_linear_noise (float, 0.005, m/sqrt(m))
    ~gyro_scale_error (float, 0.01), ~gyro_noise (float, 0.002, rad/sqrt(s)), ~gyro_bias (float, 0.0, rad/s)

ROS Publishers:
    /clock (rosgraph_msgs/Clock): simulated time, every physics step
    odom (nav_msgs/Odometry): frame odom, child base_footprint; and tf odom->base_footprint
    imu/data (sensor_msgs/Imu): gyro heading and rate, frame gyro_link
    turtlebot_node/sensor_state (turtlebot_node/TurtlebotSensorState): bumpers, distance, angle (10 Hz)
    /diagnostics (diagnostic_msgs/DiagnosticArray): 1 Hz
    scan (sensor_msgs/LaserScan): frame base_laser_link, exactly as the inverted URG-04LX reports it
    camera/depth/image (sensor_msgs/Image, 32FC1 m, NaN no return), camera/depth/camera_info
    camera/rgb/image_color (sensor_msgs/Image, rgb8), camera/rgb/camera_info
    camera/rgb/points (sensor_msgs/PointCloud2, x y z rgb, frame camera_rgb_optical_frame)
    cur_tilt_angle (std_msgs/Float64, deg), cur_tilt_status (std_msgs/UInt8), imu (sensor_msgs/Imu):
        kinect_aux; kinect_aux/joint_states (sensor_msgs/JointState): camera_tilt_joint [rad]
    base_pose_ground_truth (nav_msgs/Odometry): true pose, frame map, child base_footprint
    people_ground_truth (florence_sim/People), ~people_markers (visualization_msgs/MarkerArray)
    ~map (nav_msgs/OccupancyGrid, latched): the ground-truth map of the world at laser height
    ~keepout_map (nav_msgs/OccupancyGrid, latched): the same grid with every obstacle between the
        floor and the top of the robot (table tops, chair seats): where the robot cannot go
        although the laser sees only legs there (move_base's global costmap uses it in simulation)
    ~overhang_map (nav_msgs/OccupancyGrid, latched): only what the laser passes under (table tops,
        chair seats; not their legs, not the walls): move_base's local costmap uses it in
        simulation, the laser places the rest exactly
    collisions (std_msgs/UInt32, latched): number of bumper contacts so far
    (a message is built only when its topic has subscribers; /clock and tf always)
    tf map->odom when ~fake_localization

ROS Subscribers:
    cmd_vel (geometry_msgs/Twist): linear.x [m/s], angular.z [rad/s]; NaN/inf ignored (throttled warning)
    tilt_angle (std_msgs/Float64): Kinect tilt [deg], -31..31

ROS Services:
    ~pause, ~unpause (std_srvs/Empty); ~step (florence_sim/Step): advance a paused simulation
    ~set_robot_pose (florence_sim/SetRobotPose); ~set_person (florence_sim/SetPerson);
    ~remove_person (florence_sim/RemovePerson)
"""

import math
import os
import threading
import time

import numpy as np

from florence_sim.sim import TILT_JOINT

NAME = "florence_sim"
# odometry covariance (x, y, z, roll, pitch, yaw) [m^2, rad^2]: planar, z and tilts unknown
ODOM_COVARIANCE = np.diag([1e-3, 1e-3, 1e6, 1e6, 1e6, 1e-3]).ravel().tolist()


def _default_world():
    import rospkg

    root = os.path.dirname(os.path.dirname(rospkg.RosPack().get_path("florence_sim")))
    return os.path.join(root, "maps", "apartment", "apartment.world.yaml")


def _quaternion(yaw):
    from geometry_msgs.msg import Quaternion

    return Quaternion(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))


class SimNode:
    """One node, one class: parameters, publishers, subscribers, services, the sim loop."""

    def __init__(self):
        import rospy
        import tf2_ros
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import OccupancyGrid, Odometry
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import CameraInfo, Image, Imu, JointState, LaserScan, PointCloud2
        from std_msgs.msg import Float64, UInt8, UInt32
        from std_srvs.srv import Empty
        from visualization_msgs.msg import MarkerArray

        from florence_sim.msg import People
        from florence_sim.srv import RemovePerson, SetPerson, SetRobotPose, Step
        from florence_sim.world import WorldError
        from turtlebot_node.msg import TurtlebotSensorState

        self.rospy = rospy
        try:
            world, self.sim, self.rtf, self.fake_localization, self.render_always, paused = self._configure()
        except (WorldError, ValueError, KeyError, TypeError) as exc:  # nonsense parameters or files
            rospy.logfatal(f"{NAME}: {exc}")
            raise SystemExit(1) from exc
        self.lock = threading.Condition()
        self.paused = paused
        self.pending_steps = 0
        self.achieved_rtf = 0.0

        # publishers before subscribers
        P = rospy.Publisher
        self.pub_clock = P("/clock", Clock, queue_size=100)  # 100 Hz sim time: a slow reader may lag
        self.pub_odom = P("odom", Odometry, queue_size=10)
        self.pub_imu = P("imu/data", Imu, queue_size=10)
        self.pub_state = P("turtlebot_node/sensor_state", TurtlebotSensorState, queue_size=10)
        self.pub_diag = P("/diagnostics", DiagnosticArray, queue_size=10)
        self.pub_scan = P("scan", LaserScan, queue_size=10)
        self.pub_depth = P("camera/depth/image", Image, queue_size=2)
        self.pub_depth_info = P("camera/depth/camera_info", CameraInfo, queue_size=2)
        self.pub_rgb = P("camera/rgb/image_color", Image, queue_size=2)
        self.pub_rgb_info = P("camera/rgb/camera_info", CameraInfo, queue_size=2)
        self.pub_points = P("camera/rgb/points", PointCloud2, queue_size=2)
        self.pub_tilt = P("cur_tilt_angle", Float64, queue_size=10)
        self.pub_tilt_status = P("cur_tilt_status", UInt8, queue_size=10)
        self.pub_accel = P("imu", Imu, queue_size=10)
        self.pub_joints = P("kinect_aux/joint_states", JointState, queue_size=10)
        self.pub_truth = P("base_pose_ground_truth", Odometry, queue_size=10)
        self.pub_people = P("people_ground_truth", People, queue_size=10)
        self.pub_markers = P("~people_markers", MarkerArray, queue_size=2)
        self.pub_map = P("~map", OccupancyGrid, queue_size=1, latch=True)
        self.pub_keepout = P("~keepout_map", OccupancyGrid, queue_size=1, latch=True)
        self.pub_overhang = P("~overhang_map", OccupancyGrid, queue_size=1, latch=True)
        self.pub_collisions = P("collisions", UInt32, queue_size=10, latch=True)
        self.tf = tf2_ros.TransformBroadcaster()
        self.msgs = _Messages(self.sim)
        self.pub_collisions.publish(0)
        self.published_collisions = 0

        from florence_sim.mapgen import overhang, rasterize

        world, laser_height = self.sim.world, self.sim.laser.mount[2, 3]
        laser = rasterize(world, laser_height)
        keepout = rasterize(world, laser_height, top=self.sim.base.cfg.height)
        self.pub_map.publish(self.msgs.ground_truth_map(laser))
        self.pub_keepout.publish(self.msgs.ground_truth_map(keepout))
        self.pub_overhang.publish(self.msgs.ground_truth_map(overhang(laser, keepout)))

        rospy.Subscriber("cmd_vel", Twist, self._on_cmd_vel, queue_size=10)
        rospy.Subscriber("tilt_angle", Float64, self._on_tilt, queue_size=10)
        rospy.Service("~pause", Empty, self._on_pause)
        rospy.Service("~unpause", Empty, self._on_unpause)
        rospy.Service("~step", Step, self._on_step)
        rospy.Service("~set_robot_pose", SetRobotPose, self._on_set_pose)
        rospy.Service("~set_person", SetPerson, self._on_set_person)
        rospy.Service("~remove_person", RemovePerson, self._on_remove_person)
        rospy.loginfo(f"{NAME}: world {world.path} ({len(world.scene.names)} primitives), "
                      f"{len(self.sim.people)} people, real_time_factor {self.rtf or 'unthrottled'}")

    def _configure(self):
        """Read and validate every ~parameter; load the world, people and robot; build the core."""
        from florence_sim.base import BaseConfig
        from florence_sim.people import load_people
        from florence_sim.robot_model import RobotModel
        from florence_sim.sensors import CameraConfig, LaserConfig
        from florence_sim.sim import Rates, SimConfig, Simulator
        from florence_sim.world import load_world

        rospy = self.rospy
        p = rospy.get_param
        world_file = p("~world", "") or _default_world()
        people_file = p("~people_file", "")
        rtf = float(p("~real_time_factor", 1.0))
        if not (math.isfinite(rtf) and rtf >= 0):
            raise ValueError(f"~real_time_factor must be >= 0 (0 = unthrottled), got {rtf}")
        paused = bool(p("~paused", False))
        dt = float(p("~physics_step", 0.01))
        start = (float(p("~x", 1.0)), float(p("~y", 2.5)), float(p("~yaw", 0.0)))
        fake_localization = bool(p("~fake_localization", False))
        seed = int(p("~seed", 0))
        laser = LaserConfig(min_ang=float(p("~min_ang", -math.pi / 2)), max_ang=float(p("~max_ang", math.pi / 2)),
                            noise=float(p("~laser_noise", 0.01)), self_hits=bool(p("~laser_self_hits", False)))
        camera = CameraConfig(width=int(p("~camera_width", 160)), height=int(p("~camera_height", 120)),
                              depth_noise=float(p("~depth_noise", 0.0012)))
        rates = Rates(laser=float(p("~laser_rate", 10.0)), camera=float(p("~camera_rate", 15.0)),
                      odom=float(p("~odom_rate", 30.0)))
        render_always = bool(p("~render_without_subscribers", False))
        base_params = {
            "cmd_timeout": float(p("~cmd_vel_timeout", 0.6)),
            "max_linear_acc": float(p("~max_linear_acc", 1.0)),
            "max_angular_acc": float(p("~max_angular_acc", 4.0)),
            "odom_linear_scale_error": float(p("~odom_linear_scale_error", 0.01)),
            "odom_linear_noise": float(p("~odom_linear_noise", 0.005)),
            "gyro_scale_error": float(p("~gyro_scale_error", 0.01)),
            "gyro_noise": float(p("~gyro_noise", 0.002)),
            "gyro_bias": float(p("~gyro_bias", 0.0)),
        }
        world = load_world(world_file)
        people = load_people(people_file, world.scene) if people_file else []
        robot = RobotModel(p("/robot_description")) if rospy.has_param("/robot_description") \
            else RobotModel.from_xacro()
        dims = base_dimensions(robot)
        base = BaseConfig(radius=dims["radius"], height=robot.height(), wheel_separation=dims["separation"],
                          **base_params)
        sim = Simulator(world, robot, base, SimConfig(dt=dt, rates=rates, laser=laser, camera=camera, seed=seed),
                        people, start)
        sim.set_robot_pose(*start)
        return world, sim, rtf, fake_localization, render_always, paused

    # ------------------------------------------------------------------ callbacks
    def _on_cmd_vel(self, msg):
        with self.lock:
            ok = self.sim.base.command(msg.linear.x, msg.angular.z, self.sim.time)
        if not ok:
            self.rospy.logwarn_throttle(5.0, f"{NAME}: ignoring cmd_vel with NaN/inf "
                                             f"(linear.x={msg.linear.x}, angular.z={msg.angular.z})")

    def _on_tilt(self, msg):
        with self.lock:
            ok = self.sim.set_tilt_degrees(msg.data)
        if not ok:
            self.rospy.logwarn_throttle(5.0, f"{NAME}: ignoring tilt_angle {msg.data}")

    def _on_pause(self, _req):
        from std_srvs.srv import EmptyResponse

        with self.lock:
            self.paused = True
        return EmptyResponse()

    def _on_unpause(self, _req):
        from std_srvs.srv import EmptyResponse

        with self.lock:
            self.paused = False
            self.lock.notify_all()
        return EmptyResponse()

    def _on_step(self, req):
        from florence_sim.srv import StepResponse

        with self.lock:
            self.pending_steps += max(1, req.steps)
            self.lock.notify_all()
            while self.pending_steps > 0 and not self.rospy.is_shutdown():
                self.lock.wait(0.1)
            return StepResponse(self.sim.time)

    def _on_set_pose(self, req):
        from florence_sim.srv import SetRobotPoseResponse

        try:
            with self.lock:
                self.sim.set_robot_pose(req.x, req.y, req.yaw)
            return SetRobotPoseResponse(True, f"robot at ({req.x:.3f}, {req.y:.3f}, {req.yaw:.3f})")
        except ValueError as exc:
            return SetRobotPoseResponse(False, str(exc))

    def _on_set_person(self, req):
        import yaml

        from florence_sim.people import person_from_spec
        from florence_sim.srv import SetPersonResponse
        from florence_sim.world import WorldError, _Reader

        try:
            spec = yaml.safe_load(req.spec) if req.spec.strip() else {}
            if not isinstance(spec, dict):
                raise WorldError("set_person", "spec", "expected a YAML mapping")
            person = person_from_spec({**spec, "id": req.id}, _Reader("set_person"), "spec")
            with self.lock:
                self.sim.add_person(person)
            return SetPersonResponse(True, f"person {req.id} set")
        except (WorldError, yaml.YAMLError) as exc:
            return SetPersonResponse(False, str(exc))

    def _on_remove_person(self, req):
        from florence_sim.srv import RemovePersonResponse

        try:
            with self.lock:
                self.sim.remove_person(req.id)
            return RemovePersonResponse(True, f"person {req.id} removed")
        except KeyError as exc:
            return RemovePersonResponse(False, str(exc.args[0]))

    # ------------------------------------------------------------------ main loop
    def spin(self):
        from rosgraph_msgs.msg import Clock

        rospy = self.rospy
        self.pub_clock.publish(Clock(rospy.Time.from_sec(self.sim.time)))  # time is defined even while paused
        ref_wall, ref_sim = time.monotonic(), self.sim.time
        window_wall, window_sim = ref_wall, ref_sim
        while not rospy.is_shutdown():
            with self.lock:
                if self.paused and self.pending_steps == 0:
                    self.lock.wait(0.05)
                    ref_wall, ref_sim = time.monotonic(), self.sim.time
                    continue
                due = self.sim.step()
                if self.pending_steps:
                    self.pending_steps -= 1
                    self.lock.notify_all()
                self._publish(due)
            now = time.monotonic()
            if now - window_wall >= 1.0:
                self.achieved_rtf = (self.sim.time - window_sim) / (now - window_wall)
                window_wall, window_sim = now, self.sim.time
            if self.rtf > 0:
                delay = ref_wall + (self.sim.time - ref_sim) / self.rtf - now
                if delay > 0:
                    time.sleep(delay)
                elif delay < -0.25:  # fell behind (loaded machine): do not try to catch up in a burst
                    ref_wall, ref_sim = now, self.sim.time

    @staticmethod
    def _send(pub, build):
        """Build and publish a message only when somebody listens (rospy messages cost CPU)."""
        if pub.get_num_connections():
            pub.publish(build())

    def _publish(self, due):
        from rosgraph_msgs.msg import Clock

        sim, m, send = self.sim, self.msgs, self._send
        stamp = self.rospy.Time.from_sec(sim.time)
        self.pub_clock.publish(Clock(stamp))
        if "odom" in due:
            odom, tf_odom = m.odometry(stamp)
            transforms = [tf_odom]
            if self.fake_localization:
                transforms.append(m.map_to_odom(stamp))
            self.tf.sendTransform(transforms)
            send(self.pub_odom, lambda: odom)
            send(self.pub_imu, lambda: m.gyro(stamp))
            send(self.pub_truth, lambda: m.ground_truth(stamp))
        if "laser" in due:
            send(self.pub_scan, lambda: m.scan(stamp, sim.scan()))
        if "camera" in due:
            self._publish_camera(stamp)
        if "sensor_state" in due:
            state = m.sensor_state(stamp)  # built anyway: it resets the packet's distance and angle
            send(self.pub_state, lambda: state)
            if sim.base.collisions != self.published_collisions:  # latched: published on change
                self.pub_collisions.publish(sim.base.collisions)
                self.published_collisions = sim.base.collisions
        if "kinect_aux" in due:
            send(self.pub_tilt, lambda: math.degrees(sim.tilt))
            send(self.pub_tilt_status, lambda: sim.tilt_status)
            send(self.pub_accel, lambda: m.accelerometer(stamp))
            send(self.pub_joints, lambda: m.joint_states(stamp))
        if "people" in due:
            send(self.pub_people, lambda: m.people(stamp))
            send(self.pub_markers, lambda: m.markers(stamp))
        if "diagnostics" in due:
            send(self.pub_diag, lambda: m.diagnostics(stamp, self.achieved_rtf, self.rtf))

    def _publish_camera(self, stamp):
        m, send = self.msgs, self._send
        depth_wanted = self.render_always or self.pub_depth.get_num_connections() > 0
        rgb_wanted = self.render_always or (self.pub_rgb.get_num_connections() + self.pub_points.get_num_connections()
                                            ) > 0
        send(self.pub_depth_info, lambda: m.camera_info(stamp, "camera_depth_optical_frame"))
        send(self.pub_rgb_info, lambda: m.camera_info(stamp, "camera_rgb_optical_frame"))
        if depth_wanted:
            depth, _ = self.sim.render_camera("camera_depth_optical_frame", color=False)
            self.pub_depth.publish(m.depth_image(stamp, depth))
        if rgb_wanted:
            depth, rgb = self.sim.render_camera("camera_rgb_optical_frame")
            if self.render_always or self.pub_rgb.get_num_connections():
                self.pub_rgb.publish(m.rgb_image(stamp, rgb))
            if self.render_always or self.pub_points.get_num_connections():
                self.pub_points.publish(m.points(stamp, depth, rgb))


def base_dimensions(robot):
    """Footprint radius and wheel separation [m] from the description."""
    left = robot.pose("left_wheel_link")[1, 3]
    right = robot.pose("right_wheel_link")[1, 3]
    return {"radius": robot.cylinder_radius("base_link"), "separation": abs(left - right)}


class _Messages:
    """Message construction from the simulator state (kept apart from the loop)."""

    def __init__(self, sim):
        self.sim = sim

    @staticmethod
    def _odometry_msg(stamp, frame, pose, v, w, covariance=None):
        """nav_msgs/Odometry of base_footprint at ``pose`` (x, y, yaw) in ``frame``."""
        from nav_msgs.msg import Odometry

        msg = Odometry()
        msg.header.stamp = stamp
        msg.header.frame_id = frame
        msg.child_frame_id = "base_footprint"
        msg.pose.pose.position.x, msg.pose.pose.position.y = pose[0], pose[1]
        msg.pose.pose.orientation = _quaternion(pose[2])
        msg.twist.twist.linear.x, msg.twist.twist.angular.z = v, w
        if covariance is not None:
            msg.pose.covariance = msg.twist.covariance = covariance
        return msg

    @staticmethod
    def _transform(stamp, parent, child, x, y, yaw):
        from geometry_msgs.msg import TransformStamped

        t = TransformStamped()
        t.header.stamp = stamp
        t.header.frame_id = parent
        t.child_frame_id = child
        t.transform.translation.x, t.transform.translation.y = x, y
        t.transform.rotation = _quaternion(yaw)
        return t

    def odometry(self, stamp):
        """``odom`` message and the tf odom -> base_footprint."""
        b = self.sim.base
        odom = self._odometry_msg(stamp, "odom", (b.ox, b.oy, b.oyaw), b.odom_v, b.odom_w, ODOM_COVARIANCE)
        return odom, self._transform(stamp, "odom", "base_footprint", b.ox, b.oy, b.oyaw)

    def map_to_odom(self, stamp):
        """tf map -> odom = truth * odom^-1 (fake localization)."""
        b = self.sim.base
        dyaw = b.yaw - b.oyaw
        c, s = math.cos(dyaw), math.sin(dyaw)
        return self._transform(stamp, "map", "odom", b.x - (c * b.ox - s * b.oy), b.y - (s * b.ox + c * b.oy), dyaw)

    def ground_truth(self, stamp):
        b = self.sim.base
        return self._odometry_msg(stamp, "map", (b.x, b.y, b.yaw), b.v, b.w)

    def gyro(self, stamp):
        from sensor_msgs.msg import Imu

        b = self.sim.base
        msg = Imu()
        msg.header.stamp = stamp
        msg.header.frame_id = "gyro_link"
        msg.orientation = _quaternion(b.oyaw)
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
        from sensor_msgs.msg import Image

        msg = Image()
        msg.header.stamp = stamp
        msg.header.frame_id = "camera_depth_optical_frame"
        msg.height, msg.width = depth.shape
        msg.encoding = "32FC1"
        msg.is_bigendian = 0
        msg.step = depth.shape[1] * 4
        msg.data = depth.astype("<f4").tobytes()
        return msg

    def rgb_image(self, stamp, rgb):
        from sensor_msgs.msg import Image

        msg = Image()
        msg.header.stamp = stamp
        msg.header.frame_id = "camera_rgb_optical_frame"
        msg.height, msg.width = rgb.shape[:2]
        msg.encoding = "rgb8"
        msg.step = rgb.shape[1] * 3
        msg.data = rgb.tobytes()
        return msg

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
        from geometry_msgs.msg import Point, Pose, Twist, Vector3

        from florence_sim.msg import People, PersonState

        msg = People()
        msg.header.stamp = stamp
        msg.header.frame_id = "map"
        for p in self.sim.people.values():
            msg.people.append(PersonState(p.id, Pose(Point(p.x, p.y, 0.0), _quaternion(p.yaw)),
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

    def diagnostics(self, stamp, achieved, requested):
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

        b = self.sim.base
        ox, oy, _ = b.odom_in_world()
        arr = DiagnosticArray()
        arr.header.stamp = stamp
        base = DiagnosticStatus(level=DiagnosticStatus.WARN if b.bumps else DiagnosticStatus.OK,
                                name="turtlebot_node: Base (simulated)",
                                message="bumper pressed" if b.bumps else "OK", hardware_id="florence_sim")
        base.values = [KeyValue("bumps_wheeldrops", str(b.bumps)), KeyValue("collisions", str(b.collisions)),
                       KeyValue("odom_error_m", f"{math.hypot(b.x - ox, b.y - oy):.3f}")]
        laser = DiagnosticStatus(level=DiagnosticStatus.OK, name="hokuyo_node: Hokuyo (simulated)",
                                 message="OK", hardware_id="florence_sim URG-04LX")
        sim = DiagnosticStatus(level=DiagnosticStatus.OK, name="florence_sim: Simulation", message="running",
                               hardware_id="florence_sim")
        sim.values = [KeyValue("sim_time_s", f"{self.sim.time:.2f}"),
                      KeyValue("real_time_factor_requested", str(requested or "unthrottled")),
                      KeyValue("real_time_factor_achieved", f"{achieved:.2f}"),
                      KeyValue("people", str(len(self.sim.people)))]
        arr.status = [base, laser, sim]
        return arr


def main():
    import rospy

    rospy.init_node(NAME)
    node = SimNode()
    thread = threading.Thread(target=node.spin, name="florence_sim_loop", daemon=True)
    thread.start()
    rospy.spin()
    thread.join(2.0)
