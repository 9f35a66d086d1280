"""hokuyo_node: Hokuyo URG laser over SCIP 2.0 (seed 2.1, Tables 1 and 2).

The scan is published as the sensor measures it, counter-clockwise from
angle_min to angle_max in frame_id: an upside-down mounting is a matter of tf
(base_laser_link is rolled by pi), never of reordering the ranges.

ROS Parameters:
    ~port (str, "/dev/ttyACM0"): serial port of the sensor.
    ~baud (int, 115200, baud): serial speed (ignored by USB models).
    ~min_ang (float, -pi/2, rad): angle of the first range, rounded inwards to a step.
    ~max_ang (float, pi/2, rad): angle of the last range, rounded inwards to a step.
    ~cluster (int, 1): adjacent steps merged into one range (the sensor keeps the nearest), 1..99.
    ~skip (int, 0): scans left out between two published ones, 0..9.
    ~intensity (bool, false): publish intensities; refused (error, ranges only) on models
        without the ME command, such as the URG-04LX.
    ~frame_id (str, "laser"): frame of the scan.
    ~time_offset (float, 0.0, s): added to every time stamp (latency correction).
    ~calibrate_time (bool, true): map the sensor's clock to the host's (TM command) on every
        connect, so stamps follow the sensor's clock instead of the arrival time.
    ~allow_unsafe_settings (bool, false): send ~min_ang/~max_ang to the sensor even beyond its
        measurable range (the sensor may refuse); otherwise they are clamped with a warning.
    ~reconnect_interval (float, 1.0, s): wait between attempts to reopen a lost port.
    ~diagnostic_period (float, 1.0, s): read by diagnostic_updater.
  Set by the node once the sensor answered PP: ~min_ang_limit, ~max_ang_limit [rad],
  ~min_range, ~max_range [m].

ROS Publishers:
    scan (sensor_msgs/LaserScan): ranges [m]; error codes (readings below the sensor's DMIN) as
        +inf, i.e. no return (REP 117).
    /diagnostics (diagnostic_msgs/DiagnosticArray): connection, scan rate, error counts.

ROS Services:
    ~self_test (diagnostic_msgs/SelfTest): identification, laser and a single-scan check.
"""

import math
import sys
import threading
import time

import diagnostic_updater
import numpy as np
import rospy
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from diagnostic_msgs.srv import SelfTest, SelfTestResponse
from sensor_msgs.msg import LaserScan

from hokuyo_node import scip
from hokuyo_node.driver import PORT_ERRORS, HokuyoDriver, ScipTimeout


class HokuyoNode:
    def __init__(self):
        p = {name: rospy.get_param("~" + name, default) for name, default in (
            ("port", "/dev/ttyACM0"), ("baud", 115200), ("min_ang", -math.pi / 2), ("max_ang", math.pi / 2),
            ("cluster", 1), ("skip", 0), ("intensity", False), ("frame_id", "laser"), ("time_offset", 0.0),
            ("calibrate_time", True), ("allow_unsafe_settings", False), ("reconnect_interval", 1.0))}
        problems = []
        if not 1 <= int(p["cluster"]) <= 99:
            problems.append(f"~cluster {p['cluster']} outside 1..99")
        if not 0 <= int(p["skip"]) <= 9:
            problems.append(f"~skip {p['skip']} outside 0..9")
        if not p["min_ang"] < p["max_ang"]:
            problems.append(f"~min_ang {p['min_ang']} must be below ~max_ang {p['max_ang']}")
        if not p["reconnect_interval"] > 0:
            problems.append("~reconnect_interval must be > 0")
        if problems:
            for problem in problems:
                rospy.logfatal("hokuyo_node: %s", problem)
            sys.exit(1)
        self.p = p
        self.driver = HokuyoDriver(p["port"], int(p["baud"]))
        self.layout = None
        self.steps = None
        self.clock_offset = None  # [s] sensor clock -> time.monotonic()
        self.connected = False
        self.connects = 0
        self.intensity_refused = False
        self.last_error_codes = 0
        self._last_error_total = 0
        self._self_test_request = threading.Event()
        self._self_test_done = threading.Event()
        self._self_test_result = None
        self._stop = threading.Event()

        self.scan_pub = rospy.Publisher("scan", LaserScan, queue_size=5)
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID(f"Hokuyo on {p['port']}")
        self.frequency_bounds = {"min": 0.0, "max": 0.0}
        self.frequency = diagnostic_updater.FrequencyStatus(
            diagnostic_updater.FrequencyStatusParam(self.frequency_bounds, 0.1, 10), "Scan rate")
        self.updater.add("Connection", self._diag_connection)
        self.updater.add(self.frequency)
        self.updater.add("Errors", self._diag_errors)
        rospy.Service("~self_test", SelfTest, self._on_self_test)
        self.diag_timer = rospy.Timer(rospy.Duration(0.1), lambda _e: self.updater.update())
        self.thread = threading.Thread(target=self._run, name="hokuyo", daemon=True)
        rospy.on_shutdown(self.shutdown)
        self.thread.start()

    # --- session ------------------------------------------------------------------------------------
    def _configure(self):
        g = self.driver.geometry
        p = self.p
        rospy.set_param("~min_ang_limit", g.angle(g.amin))
        rospy.set_param("~max_ang_limit", g.angle(g.amax))
        rospy.set_param("~min_range", g.dmin / 1000.0)
        rospy.set_param("~max_range", g.dmax / 1000.0)
        first, last = g.steps(p["min_ang"], p["max_ang"], clamp=not p["allow_unsafe_settings"])
        requested = g.steps(p["min_ang"], p["max_ang"], clamp=False)
        if (first, last) != requested:
            rospy.logwarn("hokuyo_node: ~min_ang/~max_ang %.4f/%.4f rad exceed the %s's range %.4f..%.4f rad: "
                          "clamped (set ~allow_unsafe_settings to send them anyway)", p["min_ang"], p["max_ang"],
                          g.model, g.angle(g.amin), g.angle(g.amax))
        if p["intensity"] and not self.driver.supports_intensity():
            if not self.intensity_refused:
                rospy.logerr("hokuyo_node: ~intensity refused: the %s has no intensity mode (ME); "
                             "publishing ranges only", g.model)
            self.intensity_refused = True
        self.steps = (first, last, int(p["cluster"]), int(p["skip"]))
        self.layout = g.layout(*self.steps)
        rate = 1.0 / self.layout["scan_time"]
        self.frequency_bounds["min"] = self.frequency_bounds["max"] = rate

    def _run(self):
        while not self._stop.is_set() and not rospy.is_shutdown():
            try:
                self.driver.open()
                self._configure()
                self.updater.setHardwareID(self.driver.version.get("SERI", self.p["port"]))
                if self.p["calibrate_time"]:
                    self.clock_offset = self.driver.calibrate_time()
                self.driver.laser_on()
                self.driver.start(*self.steps)
                self.connected = True
                self.connects += 1
                rospy.loginfo("hokuyo_node: %s on %s, %d ranges %.4f..%.4f rad, %.1f Hz", self.driver.model,
                              self.p["port"], self.layout["count"], self.layout["angle_min"],
                              self.layout["angle_max"], 1.0 / self.layout["scan_time"])
                self._scan_loop()
            except (scip.ScipError, ScipTimeout) as exc:
                rospy.logwarn("hokuyo_node: %s: %s; restarting the sensor", self.p["port"], exc)
            except PORT_ERRORS as exc:
                self.driver.errors["port"] += 1
                level = rospy.logwarn if self.connected or self.driver.errors["port"] == 1 else rospy.logdebug
                level("hokuyo_node: port %s: %s; retrying every %.1f s", self.p["port"], exc,
                      self.p["reconnect_interval"])
            self.connected = False
            self.driver.close()
            self._stop.wait(self.p["reconnect_interval"])

    def _scan_loop(self):
        while not self._stop.is_set() and not rospy.is_shutdown():
            if self._self_test_request.is_set():
                self._self_test_result = self.driver.self_test()
                self._self_test_request.clear()
                self._self_test_done.set()
                self.driver.laser_on()
                self.driver.start(*self.steps)
            try:
                scan = self.driver.read_scan(timeout=max(1.0, 5.0 * self.layout["scan_time"]))
            except scip.ScipError as exc:
                rospy.logwarn_throttle(2.0, f"hokuyo_node: damaged scan dropped: {exc}")
                continue
            except ScipTimeout:
                self.driver.errors["timeout"] += 1
                raise
            self._publish(scan)

    def _stamp(self, scan):
        t = scan.device_time / 1000.0 + self.clock_offset if self.clock_offset is not None else scan.receive_time
        now_ros, now_mono = rospy.Time.now(), time.monotonic()
        return now_ros - rospy.Duration.from_sec(now_mono - t - self.p["time_offset"])

    def _publish(self, scan):
        g, layout = self.driver.geometry, self.layout
        msg = LaserScan()
        msg.header.stamp = self._stamp(scan)
        msg.header.frame_id = self.p["frame_id"]
        for key in ("angle_min", "angle_max", "angle_increment", "time_increment", "scan_time", "range_min",
                    "range_max"):
            setattr(msg, key, layout[key])
        msg.ranges = scip.ranges_to_metres(scan.values, g.dmin).tolist()
        self.last_error_codes = int(np.count_nonzero(scan.values < g.dmin))
        self.scan_pub.publish(msg)
        self.frequency.tick()

    # --- services and diagnostics ------------------------------------------------------------------------
    def _on_self_test(self, _req):
        response = SelfTestResponse()
        response.id = self.driver.version.get("SERI", "unknown")
        if not self.connected:
            response.passed = 0
            response.status = [DiagnosticStatus(level=DiagnosticStatus.ERROR, name="Connection",
                                                message=f"sensor on {self.p['port']} not connected")]
            return response
        self._self_test_done.clear()
        self._self_test_request.set()
        if not self._self_test_done.wait(15.0):
            response.passed = 0
            response.status = [DiagnosticStatus(level=DiagnosticStatus.ERROR, name="Self test",
                                                message="timed out waiting for the sensor")]
            return response
        results = self._self_test_result
        response.passed = int(all(ok for _, ok, _ in results))
        response.status = [DiagnosticStatus(level=DiagnosticStatus.OK if ok else DiagnosticStatus.ERROR, name=name,
                                            message=message, hardware_id=response.id,
                                            values=[KeyValue("passed", str(ok))]) for name, ok, message in results]
        return response

    def _diag_connection(self, stat):
        d = self.driver
        if self.connected:
            stat.summary(DiagnosticStatus.OK, f"{d.model} scanning")
        else:
            stat.summary(DiagnosticStatus.ERROR, f"not connected to {self.p['port']}")
        if self.intensity_refused:
            stat.mergeSummary(DiagnosticStatus.WARN, "intensity requested but not supported")
        stat.add("Port", self.p["port"])
        for key in ("PROD", "FIRM", "PROT", "SERI"):
            stat.add(key, d.version.get(key, ""))
        stat.add("Connects", self.connects)
        if self.layout:
            for key, value in self.layout.items():
                stat.add(key, value)
        return stat

    def _diag_errors(self, stat):
        errors = self.driver.errors
        total = sum(errors.values())
        if total > self._last_error_total:
            stat.summary(DiagnosticStatus.WARN, f"{total - self._last_error_total} new errors")
        else:
            stat.summary(DiagnosticStatus.OK, "no new errors")
        self._last_error_total = total
        stat.add("Scans", self.driver.scans)
        for kind in ("checksum", "format", "status", "timeout", "port", "stale"):
            stat.add(f"{kind} errors", errors[kind])
        stat.add("Error codes in last scan", self.last_error_codes)
        return stat

    def shutdown(self):
        self._stop.set()
        self.diag_timer.shutdown()
        self.thread.join(5.0)
        try:
            self.driver.stop()
        except PORT_ERRORS as exc:
            rospy.logdebug("hokuyo_node: QT on shutdown: %s", exc)
        self.driver.close()


def main():
    rospy.init_node("hokuyo_node")
    HokuyoNode()
    rospy.spin()
