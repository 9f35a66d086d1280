"""/diagnostics through diagnostic_updater, the same way in every node.

    self.diag = Diagnostics("iRobot Create on /dev/ttyUSB0")
    self.diag.add("Battery", self._diag_battery)           # fn(stat) -> stat
    self.scan_rate = self.diag.frequency("Scan rate", 9.0, 11.0)
    ...
    self.scan_rate.tick()                                   # once per scan

The updater publishes every ``~diagnostic_period`` [s] (diagnostic_updater's parameter,
1.0 by default); a timer of ``tick`` [s] drives it. ``tick=None`` makes no timer: the node
calls :meth:`force_update` itself (florence_sim does, from its loop, because a ROS-time timer
under simulated time wakes at every /clock message).
"""

import diagnostic_updater
import rospy
from diagnostic_msgs.msg import DiagnosticStatus

OK, WARN, ERROR, STALE = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR, DiagnosticStatus.STALE


class Diagnostics:
    """A diagnostic_updater.Updater with a hardware id, driven by a timer."""

    def __init__(self, hardware_id, tick=0.1):
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID(hardware_id)
        self._timer = None if tick is None else rospy.Timer(rospy.Duration(tick), lambda _event: self.updater.update())

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
        if self._timer is not None:
            self._timer.shutdown()
