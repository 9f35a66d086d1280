"""Warnings throttled per kind of problem.

rospy's ``logwarn_throttle`` throttles per call site: a node that reports every bad input
through one helper would log the first problem and silence every other kind for the period.
Here each kind has its own clock, and the last text of each kind is kept for /diagnostics.

    self.warn = KindThrottle("kinect_aux: ")
    self.warn("tilt", "tilt 45 deg clamped to 31")   # logged
    self.warn("led", "LED option 9 ignored")          # logged too: another kind
    self.warn("tilt", "tilt 50 deg clamped to 31")    # not logged within 5 s, but kept
    self.warn.last  # {"tilt": "tilt 50 deg clamped to 31", "led": "LED option 9 ignored"}
"""

import math
import time


class KindThrottle:
    """``throttle(kind, text)`` logs ``prefix + text`` through ``log`` (rospy.logwarn) at most every
    ``period`` [s, wall] per ``kind``; returns whether it logged."""

    def __init__(self, prefix="", period=5.0, log=None, clock=time.monotonic):
        if log is None:
            import rospy

            log = rospy.logwarn
        self.prefix, self.period, self.log, self.clock = prefix, float(period), log, clock
        self.last = {}  # kind -> the newest text
        self.latest = ""  # the newest text of any kind
        self._logged = {}

    def __call__(self, kind, text):
        self.last[kind] = text
        self.latest = text
        now = self.clock()
        if now - self._logged.get(kind, -math.inf) < self.period:
            return False
        self._logged[kind] = now
        self.log(self.prefix + text)
        return True
