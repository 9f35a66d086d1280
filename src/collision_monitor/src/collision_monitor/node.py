"""collision_monitor_node: between cmd_vel_mux and velocity_filter, every velocity command is
judged against the obstacles the laser and the Kinect see (collision_monitor.monitor says how) and
passed, slowed or stopped.

ROS Parameters: PARAMS below (rendered in the README); ~sources entries: obstacles.SOURCE.

ROS Subscribers:
    cmd_vel_in (geometry_msgs/Twist): the multiplexer's output. A command with a NaN or infinite
        component is dropped with a throttled warning (velocity_filter keeps the previous one).
    active_input (std_msgs/String, latched): the multiplexer's input in control (cmd_vel_mux's
        ~active), for ~input_stop_distances.
    <topic of each source> (sensor_msgs/LaserScan, or sensor_msgs/Image and sensor_msgs/CameraInfo
        for a depth source): the obstacle sensors (config/sources.yaml: /scan, the Hokuyo;
        /camera/depth/image and /camera/depth/camera_info, the Kinect; /kinect_scan, its fake
        laser, is the fallback).

ROS Services:
    ~forget (std_srvs/Trigger): drop every remembered obstacle point (the robot was carried:
        odometry did not move, the world did; florence_sim's scenario tests carry it between tests).
        What the sensors see comes back with their next scan or image taken after the call.

ROS Publishers:
    cmd_vel (geometry_msgs/Twist): each command as judged, at once (velocity_filter's input); and,
        when a new scan shows that the last command (younger than ~recheck_window) must slow down
        more, that command again as judged now; when the last command is older than that (younger
        than ~stale_window), a stop. One zero Twist on shutdown.
    ~state (collision_monitor/MonitorState): the judgement of every command published.
    /diagnostics: the state, the commands slowed and stopped, each source's age, points, time to
        take a scan or image (p50 / p99) and problems, the time to judge a command (p50 / p99).
"""

import dataclasses
import math
import threading
import time
from collections import Counter, deque

import numpy as np
import rospy
import tf2_ros
from geometry_msgs.msg import Twist
from std_msgs.msg import String
from std_srvs.srv import Trigger, TriggerResponse

from collision_monitor.monitor import BLIND, CLEAR, SLOW, STOP, TURN, MonitorConfig, blind, decide
from collision_monitor.msg import MonitorState
from collision_monitor.obstacles import DEPTH, parse_sources
from collision_monitor.sources import ScanSources
from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.diagnostics import ERROR, OK, WARN, Diagnostics
from florence_common_ros.node import publish_stop, read_params, run
from florence_common_ros.transforms import lookup_matrix

LOG = "collision_monitor: "
_D = MonitorConfig()


def _footprint_problem(value):
    try:
        MonitorConfig(footprint=tuple(tuple(p) for p in value))
    except (TypeError, ValueError) as exc:
        return str(exc)
    return None


PARAMS = ParamTable(
    Param("sources", list, None, "the obstacle sensors, each {name, topic, type, timeout, required, self_range, "
          "padding, memory, ...} (config/sources.yaml; the table below)", optional=True),
    Param("fixed_frame", FRAME, "odom", "frame the obstacle points are kept in while the robot moves"),
    Param("base_frame", FRAME, "base_footprint", "the robot's frame (commands are in it)"),
    Param("footprint", list, [], "polygon [[x, y], ...] in the base frame; [] = a circle of ~robot_radius", unit="m",
          check=lambda v: _footprint_problem(v) if v else None),
    Param("robot_radius", float, _D.robot_radius, "radius of the footprint circle (the Create's body)", unit="m",
          gt=0),
    Param("stop_distance", float, _D.stop_distance, "least distance a motion may bring the footprint to an obstacle",
          unit="m", gt=0),
    Param("input_stop_distances", dict, {"move_base": 0.005}, "the stop distance of the multiplexer's inputs that "
          "keep clear of obstacles themselves ({input name: m}): move_base plans on its costmaps and may pass a door "
          "jamb a few mm away; the monitor only keeps it from touching", unit="m",
          check=lambda v: next((f"{k}: {d!r} is not a distance > 0" for k, d in v.items()
                                if isinstance(d, bool) or not isinstance(d, (int, float)) or not d > 0), None)),
    Param("time_horizon", float, _D.time_horizon, "how far ahead a command's motion is followed, at its own speed",
          unit="s", gt=0),
    Param("min_lookahead", float, _D.min_lookahead, "path length checked however slow the command", unit="m", ge=0),
    Param("deceleration", float, _D.deceleration, "braking the speed limit counts on (velocity_filter brakes at "
          "max_linear_acc 1.0)", unit="m/s^2", gt=0),
    Param("latency", float, _D.latency, "time a command stands before the next one is judged (move_base sends 5 a "
          "second)", unit="s", ge=0),
    Param("min_speed", float, _D.min_speed, "an allowed speed below this stops the linear motion", unit="m/s", ge=0),
    Param("recheck_window", float, 0.3, "on each scan, the last command, when younger than this, is judged again and "
          "sent again if it must slow down more (0: never)", unit="s", ge=0),
    Param("stale_window", float, 1.0, "... and when older than recheck_window but younger than this (velocity_filter's "
          "command_timeout: it drives the last command that long), stopped instead, if it must slow down (its sender "
          "went quiet: move_base starved of CPU)", unit="s", ge=0),
    Param("tf_timeout", float, 0.5, "how long a scan waits for its transform before it is skipped", unit="s", ge=0,
          le=2),
)


def _twist(v, w):
    msg = Twist()
    msg.linear.x, msg.angular.z = float(v), float(w)
    return msg


class CollisionMonitorNode:
    def __init__(self):
        p = read_params(PARAMS)
        specs = parse_sources(p.sources)
        self.config = MonitorConfig(footprint=tuple(tuple(float(c) for c in pt) for pt in p.footprint),
                                    robot_radius=p.robot_radius, stop_distance=p.stop_distance,
                                    time_horizon=p.time_horizon, min_lookahead=p.min_lookahead,
                                    deceleration=p.deceleration, latency=p.latency, min_speed=p.min_speed)
        self.configs = {name: dataclasses.replace(self.config, stop_distance=float(d))
                        for name, d in p.input_stop_distances.items()}
        self.active_input = ""
        self.fixed_frame, self.base_frame = p.fixed_frame, p.base_frame
        self.recheck_window = p.recheck_window
        self.stale_window = p.stale_window
        self.lock = threading.Lock()
        self.last = None  # (time [s], v in, w in, v out) of the last command
        self.counts = Counter()
        self.judge_ms = deque(maxlen=500)  # [ms] wall time to judge one command
        self.last_decision, self.last_reason = None, "no command yet"
        self.dropped = 0
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.pub = rospy.Publisher("cmd_vel", Twist, queue_size=10, tcp_nodelay=True)
        self.state_pub = rospy.Publisher("~state", MonitorState, queue_size=10)
        self.diag = Diagnostics("collision_monitor")
        self.diag.add("Collision monitor", self._diagnose)
        self.sources = ScanSources(specs, self.fixed_frame, self.tf_buffer, p.tf_timeout,
                                   on_scan=self._on_scan if max(self.recheck_window, self.stale_window) > 0 else None,
                                   log_prefix=LOG)
        self.forget_srv = rospy.Service("~forget", Trigger, self._forget)
        self.active_sub = rospy.Subscriber("active_input", String, self._on_active, queue_size=1)
        self.sub = rospy.Subscriber("cmd_vel_in", Twist, self.on_command, queue_size=10, tcp_nodelay=True)
        shape = (f"polygon of {len(p.footprint)} points" if p.footprint else f"circle of {p.robot_radius} m")
        rospy.loginfo(LOG + "footprint %s, stop distance %.3f m, horizon %.2f s, sources %s", shape, p.stop_distance,
                      p.time_horizon, ", ".join(f"{s.name} ({s.topic})" for s in specs))

    def _on_active(self, msg):
        self.active_input = msg.data

    def _forget(self, _req):
        points, _ = self.sources.points()
        self.sources.forget()
        rospy.loginfo(LOG + "forgot %d obstacle points (~forget)", len(points))
        return TriggerResponse(success=True, message=f"forgot {len(points)} obstacle points")

    # --- judging ---------------------------------------------------------------------------------
    def judge(self, v, w):
        """(Decision, reason) for command (v, w) now."""
        now = rospy.get_time()
        stale = self.sources.stale(now)
        silent = [f"{name} silent for {age:.1f} s" if math.isfinite(age) else f"no scan from {name} yet"
                  for name, age, needed in stale if needed]
        if silent:
            return blind(v, w), "; ".join(silent)
        pose, why = lookup_matrix(self.tf_buffer, self.fixed_frame, self.base_frame, rospy.Time(0))
        if pose is None:
            return blind(v, w), why
        points, padding = self.sources.points()
        inv = np.linalg.inv(pose)
        local = points @ inv[:2, :3].T + inv[:2, 3]
        decision = decide(local, v, w, self.configs.get(self.active_input, self.config), padding)
        return decision, self._reason(decision, stale)

    def _reason(self, d, stale):
        note = "".join(f"; no scan from {name} (optional)" for name, _, _ in stale)
        if d.state == SLOW:
            return (f"slowed to {d.scale:.0%}: the footprint would come within the stop distance in "
                    f"{d.stop_path:.2f} m{note}")
        if d.state == STOP:
            return f"stopped: the footprint would come within the stop distance in {d.stop_path:.2f} m" + note
        if d.state == TURN:
            return "turning in place" + note
        return "clear" + note

    def _publish(self, msg_in, d, reason):
        out = _twist(d.v, d.w)
        self.pub.publish(out)
        state = MonitorState()
        state.header.stamp = rospy.Time.now()
        state.header.frame_id = self.base_frame
        state.state, state.reason = d.state, reason
        state.scale, state.stop_path, state.clearance = d.scale, d.stop_path, d.clearance
        state.nearest.x, state.nearest.y = d.nearest
        state.command, state.output = msg_in, out
        self.state_pub.publish(state)

    def on_command(self, msg):
        start = time.perf_counter()
        v, w = msg.linear.x, msg.angular.z
        if not (math.isfinite(v) and math.isfinite(w)):
            self.dropped += 1
            rospy.logwarn_throttle(5.0, LOG + f"dropped a non-finite command (linear.x={v}, angular.z={w})")
            return
        with self.lock:
            d, reason = self.judge(v, w)
            self._publish(msg, d, reason)
            self.judge_ms.append(1e3 * (time.perf_counter() - start))
            self._account(d, reason)
            self.last = (rospy.get_time(), msg, d.v)

    def _on_scan(self, _name):
        """A new scan: the last command, if recent and moving, judged again; sent when stricter."""
        with self.lock:
            if self.last is None:
                return
            t, msg, v_out = self.last
            age = rospy.get_time() - t
            if msg.linear.x == 0.0 or age > max(self.recheck_window, self.stale_window):
                return
            d, reason = self.judge(msg.linear.x, msg.angular.z)
            if abs(d.v) < abs(v_out) - 1e-3:
                if age > self.recheck_window:  # its sender went quiet: velocity_filter still drives it
                    d = dataclasses.replace(d, state=STOP, v=0.0, w=0.0, scale=0.0)
                    reason = f"stopped: the last command, {age:.2f} s old, would now be {reason}"
                self._publish(msg, d, reason + " (judged again on a new scan)")
                self._account(d, reason)
                self.last = (t, msg, d.v)

    def _account(self, d, reason):
        self.counts[d.state] += 1
        if self.last_decision is None or d.state != self.last_decision.state:
            level = rospy.loginfo if d.state in (CLEAR, TURN) else rospy.logwarn
            level(LOG + "%s: %s", d.state, reason)
        self.last_decision, self.last_reason = d, reason

    # --- diagnostics -------------------------------------------------------------------------------
    def _diagnose(self, stat):
        now = rospy.get_time()
        ages = self.sources.ages(now)
        stale = self.sources.stale(now)
        with self.lock:
            d, reason, counts = self.last_decision, self.last_reason, dict(self.counts)
            times = np.array(self.judge_ms)
        level = OK
        if any(req for _, _, req in stale):
            level = ERROR
        elif stale or (d is not None and d.state in (SLOW, STOP, BLIND)):
            level = WARN
        stat.summary(level, reason if d is not None else "no command yet")
        stat.add("state", d.state if d is not None else "idle")
        for state in (CLEAR, SLOW, STOP, TURN, BLIND):
            stat.add(f"commands {state}", counts.get(state, 0))
        stat.add("non-finite commands dropped", self.dropped)
        if len(times):
            stat.add("judge time p50 / p99 (ms)", f"{np.percentile(times, 50):.2f} / {np.percentile(times, 99):.2f}")
        for name, age in ages.items():
            spec = self.sources.specs[name]
            text = f"{age:.2f} s ago" if math.isfinite(age) else "no scan yet"
            memory = self.sources.memories[name]
            text += (f", {self.sources.taken[name]} taken, {self.sources.skipped[name]} skipped, "
                     f"{len(memory.points)} points")
            if spec.type == DEPTH:
                text += f" in {len(memory.columns)} columns"
            took = self.sources.update_times(name)
            if len(took):
                text += f", {np.percentile(took, 50):.1f} / {np.percentile(took, 99):.1f} ms each (p50 / p99)"
            if self.sources.problem[name]:
                text += f" (last: {self.sources.problem[name]})"
            stat.add(f"source {name} ({spec.topic}{', required' if spec.required else ''})", text)
        return stat

    def shutdown(self):
        """A safe state on the way out: one zero command."""
        publish_stop(self.pub)


def main():
    run(CollisionMonitorNode, "collision_monitor")
