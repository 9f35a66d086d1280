"""/diagnostics through diagnostic_updater, the same way in every node.

    self.diag = Diagnostics("iRobot Create on /dev/ttyUSB0")
    self.diag.add("Battery", self._diag_battery)           # fn(stat) -> stat
    self.scan_rate = self.diag.frequency("Scan rate", 9.0, 11.0)
    ...
    self.scan_rate.tick()                                   # once per scan

The updater publishes every ``~diagnostic_period`` [s] of ROS time (diagnostic_updater's
parameter, 1.0 by default). A daemon thread calls it every ``tick`` [s] of wall time: not a
rospy.Timer, which under simulated time wakes at every /clock message (100 a simulated second)
in every node that has one. ``tick=None`` makes no thread: the node calls :meth:`force_update`
itself (florence_sim does, from its loop).
"""

import threading
import time

import diagnostic_updater
import rospy
from diagnostic_msgs.msg import DiagnosticStatus

OK, WARN, ERROR, STALE = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR, DiagnosticStatus.STALE


class Diagnostics:
    """A diagnostic_updater.Updater with a hardware id, driven by a wall-clock thread."""

    def __init__(self, hardware_id, tick=0.25):
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID(hardware_id)
        self._stop = threading.Event()
        self._thread = None
        if tick is not None:
            self._thread = threading.Thread(target=self._run, args=(float(tick),), name="diagnostics", daemon=True)
            self._thread.start()

    def _run(self, tick):
        while not self._stop.wait(tick) and not rospy.is_shutdown():
            try:
                self.updater.update()
            except rospy.ROSException:  # shutting down, or simulated time not started yet
                time.sleep(tick)

    def add(self, name, task):
        """``task(stat)`` fills a DiagnosticStatusWrapper (summary, add) and returns it."""
        self.updater.add(name, task)

    def frequency(self, name, min_hz, max_hz, tolerance=0.1, window=10):
        """A rate check of something the node ticks (``.tick()``), added to the updater."""
        bounds = {"min": float(min_hz), "max": float(max_hz)}
        status = diagnostic_updater.FrequencyStatus(
            diagnostic_updater.FrequencyStatusParam(bounds, tolerance, window), name)
        self.updater.add(status)
        return status

    def force_update(self):
        self.updater.force_update()

    def has_subscribers(self):
        """Whether anybody listens on /diagnostics (building the statuses costs CPU)."""
        return self.updater.publisher.get_num_connections() > 0

    def shutdown(self):
        self._stop.set()
