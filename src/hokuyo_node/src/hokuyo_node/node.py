"""hokuyo_node: Hokuyo URG laser over SCIP 2.0 (seed 2.1, Tables 1 and 2).

The scan is published as the sensor measures it, counter-clockwise from
angle_min to angle_max in frame_id: an upside-down mounting is a matter of tf
(base_laser_link is rolled by pi), never of reordering the ranges.

ROS Parameters: PARAMS below (rendered in the README); ~diagnostic_period (float, 1.0, s) is
read by diagnostic_updater. Set by the node once the sensor answered PP: ~min_ang_limit,
~max_ang_limit [rad], ~min_range, ~max_range [m].

ROS Publishers:
    scan (sensor_msgs/LaserScan): ranges [m]; error codes (readings below the sensor's DMIN) as
        +inf, i.e. no return (REP 117).
    /diagnostics (diagnostic_msgs/DiagnosticArray): connection, scan rate, error counts.

ROS Services:
    ~self_test (diagnostic_msgs/SelfTest): identification, laser and a single-scan check.
"""

import math
import threading
import time

import numpy as np
import rospy
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from diagnostic_msgs.srv import SelfTest, SelfTestResponse
from sensor_msgs.msg import LaserScan

from florence_common.params import FRAME, Param, ParamTable
from florence_common_ros.diagnostics import Diagnostics
from florence_common_ros.node import read_params, run
from hokuyo_node import scip
from hokuyo_node.driver import PORT_ERRORS, HokuyoDriver, ScipTimeout

PARAMS = ParamTable(
    Param("port", str, "/dev/ttyACM0", "serial port of the sensor"),
    Param("baud", int, 115200, "serial speed (ignored by USB models)", unit="baud", gt=0),
    Param("min_ang", float, -math.pi / 2, "angle of the first range, rounded inwards to a step", unit="rad"),
    Param("max_ang", float, math.pi / 2, "angle of the last range, rounded inwards to a step (above ~min_ang)",
          unit="rad"),
    Param("cluster", int, 1, "adjacent steps merged into one range (the sensor keeps the nearest)", ge=1, le=99),
    Param("skip", int, 0, "scans left out between two published ones", ge=0, le=9),
    Param("intensity", bool, False, "publish intensities; refused (error, ranges only) on models without the ME "
          "command, such as the URG-04LX"),
    Param("frame_id", FRAME, "laser", "frame of the scan"),
    Param("time_offset", float, 0.0, "added to every time stamp (latency correction)", unit="s"),
    Param("calibrate_time", bool, True, "map the sensor's clock to the host's (TM command) on every connect, so "
          "stamps follow the sensor's clock instead of the arrival time"),
    Param("allow_unsafe_settings", bool, False, "send ~min_ang/~max_ang even beyond the measurable range (the "
          "sensor may refuse); otherwise they are clamped with a warning"),
    Param("reconnect_interval", float, 1.0, "wait between attempts to reopen a lost port", unit="s", gt=0),
)


class HokuyoNode:
    def __init__(self):
        p = read_params(PARAMS)
        if not p.min_ang < p.max_ang:
            raise ValueError(f"~min_ang {p.min_ang} must be below ~max_ang {p.max_ang} [rad]")
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
        self.diag = Diagnostics(f"Hokuyo on {p['port']}")
        self.diag.add("Connection", self._diag_connection)
        self.frequency = self.diag.frequency("Scan rate", 0.0, 0.0)  # bounds set once the sensor told its rate
        self.diag.add("Errors", self._diag_errors)
        rospy.Service("~self_test", SelfTest, self._on_self_test)
        self.thread = threading.Thread(target=self._run, name="hokuyo", daemon=True)
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
        self.frequency.params.freq_bound["min"] = self.frequency.params.freq_bound["max"] = rate

    def _run(self):
        while not self._stop.is_set() and not rospy.is_shutdown():
            try:
                self.driver.open()
                self._configure()
                self.diag.updater.setHardwareID(self.driver.version.get("SERI", self.p["port"]))
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
        self.diag.shutdown()
        self.thread.join(5.0)
        try:
            self.driver.stop()
        except PORT_ERRORS as exc:
            rospy.logdebug("hokuyo_node: QT on shutdown: %s", exc)
        self.driver.close()


def main():
    run(HokuyoNode, "hokuyo_node")
