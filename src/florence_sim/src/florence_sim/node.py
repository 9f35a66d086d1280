"""florence_sim node: the simulator on ROS, standing in for turtlebot_node, hokuyo_node,
the Kinect camera and kinect_aux with their topics, frames and conventions.

ROS Parameters: PARAMS below (rendered in the README).

ROS Publishers:
    /clock (rosgraph_msgs/Clock): simulated time, every physics step
    odom (nav_msgs/Odometry): frame odom, child base_footprint; and tf odom->base_footprint
    imu/data (sensor_msgs/Imu): gyro heading and rate, frame gyro_link
    turtlebot_node/sensor_state (turtlebot_node/TurtlebotSensorState): bumpers, distance, angle (10 Hz)
    /diagnostics: the base (bumpers, collisions, odometry error), the laser, the simulation (time,
        real-time factor asked and achieved, people), through diagnostic_updater
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
    cmd_vel (geometry_msgs/Twist): linear.x [m/s], angular.z [rad/s]; NaN/inf ignored (throttled warning);
        the newest one takes effect at the next physics step
    tilt_angle (std_msgs/Float64): Kinect tilt [deg], -31..31

ROS Services:
    ~pause, ~unpause (std_srvs/Empty); ~step (florence_sim/Step): advance a paused simulation
    ~now (florence_sim/Now): the simulated time now (a client's topics may lag behind it)
    ~set_robot_pose (florence_sim/SetRobotPose); ~set_person (florence_sim/SetPerson);
    ~remove_person (florence_sim/RemovePerson)
"""

import math
import threading
import time

from florence_common.maps import map_file
from florence_common.params import Param, ParamTable
from florence_common_ros.diagnostics import OK, WARN, Diagnostics
from florence_common_ros.node import read_params, run
from florence_sim.base import BaseConfig
from florence_sim.messages import Messages
from florence_sim.sensors import EDGE_DROPOUT_MAX, CameraConfig, LaserConfig

NAME = "florence_sim"
_BASE, _CAMERA = BaseConfig(radius=1.0, height=1.0, wheel_separation=1.0), CameraConfig()
PARAMS = ParamTable(
    Param("world", str, "", "world file (empty: maps/apartment/apartment.world.yaml)"),
    Param("people_file", str, "", "people file (empty: nobody)"),
    Param("real_time_factor", float, 1.0, "simulated seconds per wall second; 0 runs unthrottled", ge=0),
    Param("paused", bool, False, "start paused (use ~unpause or ~step)"),
    Param("physics_step", float, 0.01, "fixed physics step", unit="s", gt=0, le=0.1),
    Param("x", float, 1.0, "robot start x in the map frame", unit="m"),
    Param("y", float, 2.5, "robot start y in the map frame", unit="m"),
    Param("yaw", float, 0.0, "robot start heading in the map frame", unit="rad"),
    Param("fake_localization", bool, False, "publish tf map -> odom from ground truth (no amcl needed)"),
    Param("seed", int, 0, "random seed of every noise source", ge=0),
    Param("min_ang", float, -math.pi / 2, "first scan angle, as hokuyo_node's (clipped to the URG-04LX's "
          "+-2.0862 rad, rounded to its steps)", unit="rad"),
    Param("max_ang", float, math.pi / 2, "last scan angle, as hokuyo_node's", unit="rad"),
    Param("laser_noise", float, 0.01, "range noise standard deviation below 1 m (1 % of the range beyond)", unit="m",
          ge=0),
    Param("laser_self_hits", bool, False, "the scan also sees the robot's own standoffs at laser height, as the "
          "real inverted Hokuyo does (laser_filter drops such readings)"),
    Param("laser_rate", float, 10.0, "scan rate", unit="Hz", gt=0),
    Param("camera_rate", float, 15.0, "Kinect frame rate", unit="Hz", gt=0),
    Param("odom_rate", float, 30.0, "odometry, imu and tf rate", unit="Hz", gt=0),
    Param("camera_width", int, _CAMERA.width, "Kinect image width", unit="px", ge=8, le=640),
    Param("camera_height", int, _CAMERA.height, "Kinect image height", unit="px", ge=6, le=480),
    Param("depth_noise", float, _CAMERA.depth_noise, "depth noise std = depth_noise * depth^2 (4 cm at 5 m, "
          "Khoshelham and Elberink 2012)", unit="1/m", ge=0),
    Param("depth_edge_dropout", int, _CAMERA.edge_dropout, "no depth (NaN) at object edges, as the Kinect: the "
          "farther side of every depth jump of more than 10 % over this many pixels, and the projector's shadow "
          "left of nearer objects; 0 turns both off", unit="px", ge=0, le=EDGE_DROPOUT_MAX),
    Param("render_without_subscribers", bool, False, "render the Kinect even when nobody listens"),
    Param("cmd_vel_timeout", float, _BASE.cmd_timeout, "sim time without cmd_vel after which the robot stops",
          unit="s", gt=0),
    Param("max_linear_acc", float, _BASE.max_linear_acc, "the Create's wheel ramp", unit="m/s^2", gt=0),
    Param("max_angular_acc", float, _BASE.max_angular_acc, "the Create's turn ramp", unit="rad/s^2", gt=0),
    Param("odom_linear_scale_error", float, _BASE.odom_linear_scale_error, "odometry distance = true * (1 + error)",
          gt=-1),
    Param("odom_linear_noise", float, _BASE.odom_linear_noise, "random walk of the odometry distance",
          unit="m/sqrt(m)", ge=0),
    Param("gyro_scale_error", float, _BASE.gyro_scale_error, "measured rate = true * (1 + error)", gt=-1),
    Param("gyro_noise", float, _BASE.gyro_noise, "random walk of the gyro heading", unit="rad/sqrt(s)", ge=0),
    Param("gyro_bias", float, _BASE.gyro_bias, "constant gyro drift", unit="rad/s"),
)
# the ~parameters that are BaseConfig fields, and their field names
BASE_FIELDS = {"cmd_vel_timeout": "cmd_timeout", "max_linear_acc": "max_linear_acc",
               "max_angular_acc": "max_angular_acc", "odom_linear_scale_error": "odom_linear_scale_error",
               "odom_linear_noise": "odom_linear_noise", "gyro_scale_error": "gyro_scale_error",
               "gyro_noise": "gyro_noise", "gyro_bias": "gyro_bias"}


class SimNode:
    """One node, one class: parameters, publishers, subscribers, services, the sim loop."""

    def __init__(self):
        import rospy
        import tf2_ros
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import OccupancyGrid, Odometry
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import CameraInfo, Image, Imu, JointState, LaserScan, PointCloud2
        from std_msgs.msg import Float64, UInt8, UInt32
        from std_srvs.srv import Empty
        from visualization_msgs.msg import MarkerArray

        from florence_sim.msg import People
        from florence_sim.srv import Now, RemovePerson, SetPerson, SetRobotPose, Step
        from turtlebot_node.msg import TurtlebotSensorState

        self.rospy = rospy
        # a bad parameter or a broken world file: run() logs it (file and field) and exits 1
        world, self.sim, self.rtf, self.fake_localization, self.render_always, paused = self._configure()
        self.lock = threading.Condition()
        # the newest cmd_vel and tilt command, taken by the loop before its next step: a callback
        # never waits on self.lock, which a loop running behind real time (a loaded machine) holds
        # nearly always (a lock is not fair: cmd_vel waited 0.3-0.4 s of sim time for it while the
        # base drove on at the old speed, into a chair the collision monitor had stopped it for)
        self.inputs_lock = threading.Lock()
        self.inputs = {}  # {"cmd_vel": (v, w), "tilt": degrees}
        self.paused = paused
        self.pending_steps = 0
        self.achieved_rtf = 0.0

        # publishers before subscribers
        P = rospy.Publisher
        self.pub_clock = P("/clock", Clock, queue_size=100)  # 100 Hz sim time: a slow reader may lag
        self.pub_odom = P("odom", Odometry, queue_size=10)
        self.pub_imu = P("imu/data", Imu, queue_size=10)
        self.pub_state = P("turtlebot_node/sensor_state", TurtlebotSensorState, queue_size=10)
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
        self.msgs = Messages(self.sim)
        # published from the loop when the core's diagnostics rate (1 Hz simulated) is due, not by the
        # helper's timer: a rospy.Timer on simulated time wakes at every /clock message (100 a simulated
        # second), which cost the unthrottled node 0.01-0.04 CPU s per simulated s (bench/sim.py)
        self.diag = Diagnostics("florence_sim", tick=None)
        self.diag.add("Base (simulated)", self._diag_base)
        self.diag.add("Hokuyo (simulated)", self._diag_laser)
        self.diag.add("Simulation", self._diag_sim)
        self.pub_collisions.publish(0)
        self.published_collisions = 0

        from florence_sim.mapgen import overhang, rasterize

        world, laser_height = self.sim.world, self.sim.laser.mount[2, 3]
        laser = rasterize(world, laser_height)
        keepout = rasterize(world, laser_height, top=self.sim.base.cfg.height)
        self.pub_map.publish(self.msgs.ground_truth_map(laser))
        self.pub_keepout.publish(self.msgs.ground_truth_map(keepout))
        self.pub_overhang.publish(self.msgs.ground_truth_map(overhang(laser, keepout)))

        rospy.Subscriber("cmd_vel", Twist, self._on_cmd_vel, queue_size=1, tcp_nodelay=True)
        rospy.Subscriber("tilt_angle", Float64, self._on_tilt, queue_size=1)
        rospy.Service("~pause", Empty, self._on_pause)
        rospy.Service("~unpause", Empty, self._on_unpause)
        rospy.Service("~step", Step, self._on_step)
        rospy.Service("~now", Now, self._on_now)
        rospy.Service("~set_robot_pose", SetRobotPose, self._on_set_pose)
        rospy.Service("~set_person", SetPerson, self._on_set_person)
        rospy.Service("~remove_person", RemovePerson, self._on_remove_person)
        rospy.loginfo(f"{NAME}: world {world.path} ({len(world.scene.names)} primitives), "
                      f"{len(self.sim.people)} people, real_time_factor {self.rtf or 'unthrottled'}")
        self.loop = threading.Thread(target=self.spin, name="florence_sim_loop", daemon=True)
        self.loop.start()

    def _configure(self):
        """Read and validate every ~parameter; load the world, people and robot; build the core."""
        from florence_sim.robot_model import RobotModel
        from florence_sim.sim import Rates, SimConfig, Simulator

        rospy = self.rospy
        p = read_params(PARAMS)
        start = (p.x, p.y, p.yaw)
        laser = LaserConfig(min_ang=p.min_ang, max_ang=p.max_ang, noise=p.laser_noise, self_hits=p.laser_self_hits)
        camera = CameraConfig(width=p.camera_width, height=p.camera_height, depth_noise=p.depth_noise,
                              edge_dropout=p.depth_edge_dropout)
        rates = Rates(laser=p.laser_rate, camera=p.camera_rate, odom=p.odom_rate)
        robot = RobotModel(rospy.get_param("/robot_description")) if rospy.has_param("/robot_description") \
            else RobotModel.from_xacro()
        sim = Simulator.from_files(p.world or map_file("apartment", "apartment.world.yaml"), p.people_file or None,
                                   robot, SimConfig(dt=p.physics_step, rates=rates, laser=laser, camera=camera,
                                                    seed=p.seed), start,
                                   **{field: p[name] for name, field in BASE_FIELDS.items()})
        return sim.world, sim, p.real_time_factor, p.fake_localization, p.render_without_subscribers, p.paused

    # ------------------------------------------------------------------ callbacks
    def _on_cmd_vel(self, msg):
        v, w = msg.linear.x, msg.angular.z
        if not (math.isfinite(v) and math.isfinite(w)):
            self.rospy.logwarn_throttle(5.0, f"{NAME}: ignoring cmd_vel with NaN/inf (linear.x={v}, angular.z={w})")
            return
        with self.inputs_lock:
            self.inputs["cmd_vel"] = (v, w)

    def _on_tilt(self, msg):
        if not math.isfinite(msg.data):
            self.rospy.logwarn_throttle(5.0, f"{NAME}: ignoring tilt_angle {msg.data}")
            return
        with self.inputs_lock:
            self.inputs["tilt"] = msg.data

    def _take_inputs(self):
        """Hand the newest commands to the core, stamped with the sim time they take effect at
        (called by the loop with self.lock held, before a step)."""
        with self.inputs_lock:
            inputs, self.inputs = self.inputs, {}
        if "cmd_vel" in inputs:
            self.sim.base.command(*inputs["cmd_vel"], self.sim.time)
        if "tilt" in inputs:
            self.sim.set_tilt_degrees(inputs["tilt"])

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

    def _on_now(self, _req):
        from florence_sim.srv import NowResponse

        with self.lock:
            return NowResponse(self.sim.time)

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
                self._take_inputs()
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
        if "diagnostics" in due and self.diag.has_subscribers():
            self.diag.force_update()

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

    # ------------------------------------------------------------------ diagnostics
    def _diag_base(self, stat):
        b = self.sim.base
        ox, oy, _ = b.odom_in_world()
        stat.summary(WARN if b.bumps else OK, "bumper pressed" if b.bumps else "OK")
        stat.add("bumps_wheeldrops", b.bumps)
        stat.add("collisions", b.collisions)
        stat.add("odom_error_m", f"{math.hypot(b.x - ox, b.y - oy):.3f}")
        return stat

    def _diag_laser(self, stat):
        stat.summary(OK, "OK")
        stat.hardware_id = "florence_sim URG-04LX"
        return stat

    def _diag_sim(self, stat):
        stat.summary(OK, "running")
        stat.add("sim_time_s", f"{self.sim.time:.2f}")
        stat.add("real_time_factor_requested", self.rtf or "unthrottled")
        stat.add("real_time_factor_achieved", f"{self.achieved_rtf:.2f}")
        stat.add("people", len(self.sim.people))
        return stat


def main():
    run(SimNode, NAME)
