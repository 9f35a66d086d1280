"""Hokuyo SCIP 2.0 session over a serial port. ROS-free; owns the serial.Serial.

:class:`ScipPort` reads whole replies (up to LF LF) with a deadline and skips
replies that do not answer the command in flight; :class:`HokuyoDriver` runs
the session: SCIP 2.0 switch, identification (VV, PP, II), time calibration
(TM), continuous measurement (MD), single scans (GD) and the self test.
Errors are counted by kind in ``HokuyoDriver.errors``.
"""

import logging
import statistics
import time
from collections import Counter
from dataclasses import dataclass

import numpy as np
import serial

from hokuyo_node import scip
from hokuyo_node import scip_spec as spec

log = logging.getLogger(__name__)

PORT_ERRORS = (serial.SerialException, OSError, ValueError, TypeError)


class ScipTimeout(Exception):
    """No complete reply within the deadline."""


class ScipPort:
    """Reply framing on a byte stream: every reply ends with an empty line."""

    def __init__(self, port, baud=115200, serial_class=serial.Serial):
        self.serial = serial_class(port, baud, timeout=0.05, write_timeout=1.0)
        self.buffer = bytearray()

    def close(self):
        self.serial.close()

    def write(self, data):
        self.serial.write(data)

    def read_reply(self, timeout):
        """The next reply's bytes, terminating LF LF included."""
        deadline = time.monotonic() + timeout
        while True:
            end = self.buffer.find(b"\n\n")
            if end >= 0:
                raw = bytes(self.buffer[: end + 2])
                del self.buffer[: end + 2]
                return raw
            if time.monotonic() > deadline:
                raise ScipTimeout(f"no complete reply within {timeout:.2f} s ({len(self.buffer)} bytes pending)")
            chunk = self.serial.read(max(1, self.serial.in_waiting))
            self.buffer += chunk

    def drain(self, quiet=0.1, limit=2.0):
        """Discard input until the line has been quiet for ``quiet`` seconds; returns bytes dropped."""
        dropped = len(self.buffer)
        self.buffer.clear()
        deadline = time.monotonic() + limit
        last = time.monotonic()
        while time.monotonic() - last < quiet and time.monotonic() < deadline:
            chunk = self.serial.read(max(1, self.serial.in_waiting))
            if chunk:
                dropped += len(chunk)
                last = time.monotonic()
        return dropped


@dataclass
class Scan:
    values: np.ndarray  # raw range values [mm] (error codes below dmin included)
    device_time: int  # [ms] sensor time stamp, unwrapped
    receive_time: float  # time.monotonic() when the reply was complete


class HokuyoDriver:
    def __init__(self, port, baud=115200, serial_class=serial.Serial, reply_timeout=1.0):
        self.port_name = port
        self.baud = baud
        self.serial_class = serial_class
        self.reply_timeout = reply_timeout  # [s]
        self.port = None
        self.version = {}
        self.geometry = None
        self.state = {}
        self.errors = Counter()  # kind -> count ("checksum", "format", "status", "timeout", "port", "stale")
        self.scans = 0
        self.measuring = None  # (first, last, cluster, skip) of the running MD
        self._wraps = 0
        self._last_stamp = None

    # --- connection ----------------------------------------------------------------------------------
    def open(self):
        """Open the port and identify the sensor (SCIP2.0, QT, VV, PP, II)."""
        self.close()
        self.port = ScipPort(self.port_name, self.baud, self.serial_class)
        self.port.write(scip.command(spec.SCIP2))
        self.port.write(scip.command(spec.LASER_OFF))  # stop a measurement a previous session left running
        self.port.drain()
        self.version = scip.parse_info(self.request(spec.VERSION))
        self.geometry = scip.Geometry.from_info(scip.parse_info(self.request(spec.PARAMETERS)))
        self.state = scip.parse_info(self.request(spec.STATE))
        self._last_stamp = None
        return self

    def close(self):
        if self.port is not None:
            try:
                self.port.close()
            except PORT_ERRORS as exc:
                log.debug("closing %s: %s", self.port_name, exc)
            self.port = None
        self.measuring = None

    @property
    def model(self):
        return self.geometry.model if self.geometry else ""

    def supports_intensity(self):
        return any(name in self.model or name in self.version.get("PROD", "") for name in spec.INTENSITY_MODELS)

    def request(self, symbol, parameters=b"", accepted=(spec.STATUS_OK,)):
        """Send a command, return its checked Reply; replies to other commands are skipped (counted)."""
        cmd = scip.command(symbol, parameters)
        self.port.write(cmd)
        deadline = time.monotonic() + self.reply_timeout
        while True:
            try:
                raw = self.port.read_reply(max(0.01, deadline - time.monotonic()))
            except ScipTimeout:
                self.errors["timeout"] += 1
                raise
            try:
                reply = scip.parse_reply(raw)
            except scip.ScipError as exc:
                self.errors[exc.kind] += 1
                log.warning("%s: %s", self.port_name, exc)
                continue
            if reply.echo != cmd[:-1]:
                self.errors["stale"] += 1
                continue
            scip.check_status(reply, *accepted)
            return reply

    # --- time ------------------------------------------------------------------------------------------------
    def calibrate_time(self, samples=10):
        """Offset [s] to add to the sensor's clock [s] to get time.monotonic(): median of TM1 round trips."""
        self.request(spec.TIME, b"0")
        offsets = []
        try:
            for _ in range(samples):
                before = time.monotonic()
                reply = self.request(spec.TIME, b"1")
                after = time.monotonic()
                offsets.append((before + after) / 2.0 - scip.parse_timestamp(reply.lines[0]) / 1000.0)
        finally:
            self.request(spec.TIME, b"2")
        self._last_stamp = None
        self._wraps = 0
        return statistics.median(offsets)

    def unwrap(self, stamp):
        """Sensor time stamp [ms, 24 bit] to a monotonic count [ms]."""
        if self._last_stamp is not None and stamp < self._last_stamp:
            self._wraps += 1
        self._last_stamp = stamp
        return self._wraps * spec.TIMESTAMP_MODULO + stamp

    # --- measurement -----------------------------------------------------------------------------------------
    def laser_on(self):
        self.request(spec.LASER_ON, accepted=(spec.STATUS_OK, spec.STATUS_LASER_ALREADY_ON))

    def start(self, first, last, cluster=1, skip=0):
        """Start a continuous MD measurement of steps first..last."""
        cmd = scip.measure_command(first, last, cluster, skip)
        self.port.write(cmd)
        deadline = time.monotonic() + self.reply_timeout
        while True:
            reply = scip.parse_reply(self.port.read_reply(max(0.01, deadline - time.monotonic())))
            if reply.echo == cmd[:-1]:
                break
            self.errors["stale"] += 1
        scip.check_status(reply, spec.STATUS_OK)
        self.measuring = (first, last, cluster, skip)

    def stop(self):
        """QT: stop measuring and switch the laser off."""
        if self.port is None:
            return
        self.measuring = None
        self.port.write(scip.command(spec.LASER_OFF))
        self.port.drain()

    def read_scan(self, timeout=None):
        """The next scan of the running MD; ScipError (counted) for a damaged one."""
        first, last, cluster, _ = self.measuring
        raw = self.port.read_reply(timeout or self.reply_timeout)
        receive_time = time.monotonic()
        try:
            reply = scip.parse_reply(raw)
            if not reply.echo.startswith(spec.MEASURE_3):
                raise scip.ScipError("format", f"expected an MD scan, got {reply.echo[:20]!r}")
            scip.check_status(reply, spec.STATUS_SCAN)
            stamp, values = scip.parse_scan(reply, 3)
            expected = (last - first) // cluster + 1
            if values.size != expected:
                raise scip.ScipError("format", f"{values.size} values, expected {expected}")
        except scip.ScipError as exc:
            self.errors[exc.kind] += 1
            raise
        self.scans += 1
        return Scan(values, self.unwrap(stamp), receive_time)

    def single_scan(self, first, last, cluster=1):
        """GD: one scan (the laser must be on)."""
        reply = self.request(spec.SCAN_3, b"%04d%04d%02d" % (first, last, cluster))
        stamp, values = scip.parse_scan(reply, 3)
        return Scan(values, stamp, time.monotonic())

    # --- self test ----------------------------------------------------------------------------------------------
    def self_test(self):
        """Run the checks of ~self_test on an open port. Returns [(name, passed, message)].

        Stops a running measurement; the caller restarts it.
        """
        results = []

        def check(name, fn):
            try:
                message = fn()
                results.append((name, True, message))
            except (scip.ScipError, ScipTimeout, *PORT_ERRORS) as exc:
                results.append((name, False, str(exc)))

        self.stop()
        check("Version (VV)", lambda: str(scip.parse_info(self.request(spec.VERSION)).get("FIRM", "")))
        check("Parameters (PP)", lambda: str(scip.Geometry.from_info(scip.parse_info(self.request(spec.PARAMETERS)))))

        def state():
            info = scip.parse_info(self.request(spec.STATE))
            return f"laser {info.get('LASR', '?')}, {info.get('STAT', '?')}"

        check("State (II)", state)
        check("Laser on (BM)", lambda: (self.laser_on(), "laser on")[1])

        def one_scan():
            g = self.geometry
            scan = self.single_scan(g.amin, g.amax)
            expected = g.amax - g.amin + 1
            if scan.values.size != expected:
                raise scip.ScipError("format", f"GD returned {scan.values.size} values, expected {expected}")
            valid = int(np.count_nonzero(scan.values >= g.dmin))
            return f"{scan.values.size} values, {valid} valid ranges"

        check("Single scan (GD)", one_scan)
        check("Laser off (QT)", lambda: (self.request(spec.LASER_OFF), "laser off")[1])
        return results
