"""The simulation core: world, people, Create base, laser, Kinect and its tilt motor (no ROS).

Time advances in fixed physics steps (``dt``, 10 ms by default) independent of
the sensor rates; :meth:`Simulator.step` returns the names of the outputs that
fell due in that step (``PERIODIC`` rates), so the ROS node (or a benchmark)
renders and publishes only those.
"""

import math
from dataclasses import dataclass, field

import numpy as np

from florence_sim.base import BaseConfig, DiffDriveBase
from florence_sim.people import check_path
from florence_sim.sensors import CameraConfig, DepthCamera, LaserConfig, UrgLaser, world_pose

TILT_JOINT = "camera_tilt_joint"
TILT_LIMIT_DEG = 31.0  # [deg] kinect_aux accepts -31..31
TILT_SPEED = math.radians(20.0)  # [rad/s] tilt motor speed (assumed)
TILT_STOPPED, TILT_LIMIT, TILT_MOVING = 0, 1, 4  # kinect_aux cur_tilt_status values


@dataclass
class Rates:
    """Output rates [Hz]."""

    laser: float = 10.0
    camera: float = 15.0
    odom: float = 30.0  # turtlebot_node update_rate
    sensor_state: float = 10.0
    kinect_aux: float = 10.0
    people: float = 10.0
    diagnostics: float = 1.0

    def validate(self):
        for name, value in self.__dict__.items():
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"rate {name} must be > 0 Hz, got {value!r}")
        return self


@dataclass
class SimConfig:
    dt: float = 0.01  # [s] physics step
    rates: Rates = field(default_factory=Rates)
    laser: LaserConfig = field(default_factory=LaserConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    seed: int = 0


def base_dimensions(robot):
    """Footprint radius and wheel separation [m] of a :class:`robot_model.RobotModel`."""
    left = robot.pose("left_wheel_link")[1, 3]
    right = robot.pose("right_wheel_link")[1, 3]
    return {"radius": robot.cylinder_radius("base_link"), "separation": abs(left - right)}


class Simulator:
    """One robot in a world with people. ``robot`` is a :class:`robot_model.RobotModel`."""

    @classmethod
    def from_files(cls, world_file, people_file=None, robot=None, config=None, start=(0.0, 0.0, 0.0),
                   **base_overrides):
        """The simulator of a world file and a people file (None or "": nobody) with the robot
        ``robot`` (a RobotModel; default: turtlebot_control's Florence TurtleBot), whose base
        radius, height and wheel separation come from its description; ``base_overrides`` are
        other :class:`base.BaseConfig` fields (cmd_timeout, gyro_scale_error, ...); the robot starts
        at ``start`` (x, y, yaw) in the world. The node, the offline runs and the benchmarks all
        build their simulator here. Raises WorldError (file and field) or ValueError."""
        from florence_sim.people import load_people
        from florence_sim.robot_model import RobotModel
        from florence_sim.world import load_world

        world = load_world(str(world_file))
        people = load_people(str(people_file), world.scene) if people_file else []
        robot = robot if robot is not None else RobotModel.from_xacro()
        dims = base_dimensions(robot)
        base = BaseConfig(radius=dims["radius"], height=robot.height(), wheel_separation=dims["separation"],
                          **base_overrides)
        sim = cls(world, robot, base, config, people, tuple(start))
        sim.set_robot_pose(*start)
        return sim

    def __init__(self, world, robot, base_config, config=None, people=(), start=(0.0, 0.0, 0.0)):
        self.cfg = config or SimConfig()
        if not (0 < self.cfg.dt <= 0.1):
            raise ValueError(f"physics step dt must be within 0..0.1 s, got {self.cfg.dt}")
        self.cfg.rates.validate()
        self.world = world
        self.robot = robot
        rng = np.random.default_rng(self.cfg.seed)
        self.base = DiffDriveBase(base_config, *start, rng=np.random.default_rng(rng.integers(1 << 31)))
        self.laser = UrgLaser(robot.pose(self.cfg.laser.frame_id), self.cfg.laser,
                              rng=np.random.default_rng(rng.integers(1 << 31)),
                              robot_cylinders=robot.vertical_cylinders())
        self.camera = DepthCamera(self.cfg.camera, rng=np.random.default_rng(rng.integers(1 << 31)))
        self.people = {}
        self._scene, self._scene_dirty = None, True
        for p in people:
            self.add_person(p)
        self.time = 0.0  # [s]
        self.steps = 0
        self.tilt = 0.0  # [rad] camera_tilt_joint position
        self.tilt_target = 0.0  # [rad]
        self._next_due = {name: 0.0 for name in self.cfg.rates.__dict__}

    # ------------------------------------------------------------------ stepping
    def step(self):
        """Advance one physics step; return the list of outputs due now."""
        dt = self.cfg.dt
        robot = (self.base.x, self.base.y, self.base.cfg.radius)
        for p in self.people.values():
            p.step(dt, keep_clear=robot)
        self._scene_dirty = True
        self.base.step(dt, self.time, self.scene())
        self._step_tilt(dt)
        self.steps += 1
        self.time = self.steps * dt
        due = []
        for name, rate in self.cfg.rates.__dict__.items():
            if self.time + 1e-9 >= self._next_due[name]:
                due.append(name)
                period = 1.0 / rate
                # keep the average rate exact (15 Hz on a 10 ms step: 7, 7, 6 steps apart ...)
                self._next_due[name] += period
                if self._next_due[name] <= self.time:  # the rate was changed or time jumped
                    self._next_due[name] = self.time + period
        return due

    def _step_tilt(self, dt):
        err = self.tilt_target - self.tilt
        self.tilt += max(-TILT_SPEED * dt, min(TILT_SPEED * dt, err))

    def scene(self):
        """Static world plus the people's bodies as they are now (built once per step)."""
        if self._scene_dirty:
            cylinders = [c for p in self.people.values() for c in p.primitives()]
            self._scene = self.world.scene.with_cylinders(cylinders)
            self._scene_dirty = False
        return self._scene

    # ------------------------------------------------------------------ sensors
    def scan(self):
        b = self.base
        return self.laser.scan(self.scene(), b.x, b.y, b.yaw)

    def frame_pose(self, frame):
        """4x4 world pose of a robot frame at the current tilt."""
        b = self.base
        return world_pose(b.x, b.y, b.yaw) @ self.robot.pose(frame, {TILT_JOINT: self.tilt})

    def render_camera(self, frame="camera_depth_optical_frame", noise=True, color=True):
        """Depth (H, W) [m] and RGB (H, W, 3) (None unless ``color``) seen from ``frame``."""
        return self.camera.render(self.scene(), self.frame_pose(frame), noise=noise, color=color)

    # ------------------------------------------------------------------ kinect_aux
    def set_tilt_degrees(self, degrees):
        """Tilt command as kinect_aux takes it [deg], clipped to +-31; False if not finite."""
        if not math.isfinite(degrees):
            return False
        self.tilt_target = math.radians(max(-TILT_LIMIT_DEG, min(TILT_LIMIT_DEG, degrees)))
        return True

    @property
    def tilt_status(self):
        if abs(self.tilt_target - self.tilt) > 1e-6:
            return TILT_MOVING
        return TILT_LIMIT if abs(math.degrees(self.tilt)) >= TILT_LIMIT_DEG - 1e-6 else TILT_STOPPED

    def accelerometer(self):
        """Gravity reaction [m/s^2] in camera_link, as the Kinect's accelerometer measures it."""
        rot = self.robot.pose("camera_link", {TILT_JOINT: self.tilt})[:3, :3]
        return rot.T @ np.array([0.0, 0.0, 9.81])

    # ------------------------------------------------------------------ test services
    def set_robot_pose(self, x, y, yaw):
        clearance, owner = self.scene().clearance([[x, y]], z_max=self.base.cfg.height)
        if clearance[0] < self.base.cfg.radius:
            raise ValueError(f"pose ({x:.2f}, {y:.2f}) puts the robot into {self.scene().names[owner[0]]!r}")
        self.base.set_pose(x, y, yaw)

    def add_person(self, person):
        """Add or replace a person after checking its path against the world."""
        check_path(person, self.world.scene, source="person")
        self.people[person.id] = person
        self._scene_dirty = True

    def remove_person(self, pid):
        if pid not in self.people:
            raise KeyError(f"no person {pid!r} (known: {', '.join(sorted(self.people)) or 'none'})")
        del self.people[pid]
        self._scene_dirty = True
