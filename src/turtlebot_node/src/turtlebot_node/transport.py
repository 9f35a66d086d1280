"""Serial transport of the Create driver: owns the serial.Serial, reconnects, feeds the parser.

ROS-free. A background thread opens the port, wakes the robot (an RTS pulse,
skipped with a note where the port has no modem lines, as on a
pseudo-terminal), puts the OI into the wanted mode, requests the sensor
stream and hands every decoded frame to ``on_frame(frame, t)`` (t =
time.monotonic() of arrival). A port that fails or vanishes is closed and
reopened every ``reconnect_interval``; a robot that goes quiet for
``stall_timeout`` is set up again. All counts are in :meth:`health`.
"""

import logging
import threading
import time

import serial

from turtlebot_node import create_oi
from turtlebot_node import oi_spec as oi

log = logging.getLogger(__name__)

PORT_ERRORS = (serial.SerialException, OSError, ValueError, TypeError)


class CreateLink:
    def __init__(self, port, baud=57600, mode=oi.MODE_FULL, on_frame=None, stream_packet=6,
                 reconnect_interval=1.0, stall_timeout=1.0, serial_class=serial.Serial):
        self.port = port
        self.baud = baud
        self.mode = mode  # OI mode to (re)enter on every connect
        self.digital_outputs = (0, 0, 0)  # re-sent on every connect
        self.on_frame = on_frame or (lambda frame, t: None)
        self.stream_packet = stream_packet
        self.reconnect_interval = reconnect_interval  # [s]
        self.stall_timeout = stall_timeout  # [s]
        self.serial_class = serial_class
        self.parser = create_oi.StreamParser([stream_packet])
        self.connected = False
        self.modem_lines = None  # None unknown, False: port rejected RTS control
        self.connects = 0
        self.disconnects = 0
        self.stalls = 0
        self.write_errors = 0
        self.last_error = ""
        self.last_frame_time = None  # time.monotonic() of the last good frame
        self._serial = None
        self._open_failures = 0
        self._write_lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = None

    # --- public -------------------------------------------------------------------------------
    def start(self):
        self._thread = threading.Thread(target=self._run, name="create-serial", daemon=True)
        self._thread.start()
        return self

    def stop(self, safe_bytes=b""):
        """Write ``safe_bytes`` (zero velocity) if connected, then close the port."""
        if safe_bytes and self.connected:
            self.write(safe_bytes)
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
        self._close()

    def write(self, data):
        """Write ``data``; False (and counted) when the port is not usable."""
        with self._write_lock:
            ser = self._serial
            if ser is None or not self.connected:
                return False
            try:
                ser.write(data)
                return True
            except PORT_ERRORS as exc:
                self.write_errors += 1
                self.last_error = f"write: {exc}"
                self.connected = False  # the reader thread reconnects
                return False

    def set_mode(self, mode):
        self.mode = mode
        return self.write(create_oi.command_mode(mode))

    def set_digital_outputs(self, out0, out1, out2):
        self.digital_outputs = (out0, out1, out2)
        return self.write(create_oi.command_digital_outputs(out0, out1, out2))

    def health(self):
        counts = self.parser.counters()
        counts.update(connected=self.connected, connects=self.connects, disconnects=self.disconnects,
                      stalls=self.stalls, write_errors=self.write_errors, last_error=self.last_error,
                      modem_lines=self.modem_lines)
        return counts

    # --- thread -----------------------------------------------------------------------------------
    def _run(self):
        while not self._stop.is_set():
            opened = False
            try:
                self._open()
                opened = True
                self._read_loop()
            except PORT_ERRORS as exc:
                self.last_error = str(exc)
                quiet = not opened and self._open_failures > 0  # warn once per outage, not every retry
                self._open_failures = 0 if opened else self._open_failures + 1
                log.log(logging.DEBUG if quiet else logging.WARNING, "Create port %s: %s", self.port, exc)
            self._close()
            if opened and not self._stop.is_set():
                self.disconnects += 1
                log.warning("Create port %s lost; reconnecting every %.1f s", self.port, self.reconnect_interval)
            self._stop.wait(self.reconnect_interval)

    def _open(self):
        self._close()
        ser = self.serial_class(self.port, self.baud, timeout=0.05, write_timeout=1.0)
        self._serial = ser
        self._open_failures = 0
        self._wake(ser)
        ser.reset_input_buffer()
        self.parser.buffer.clear()  # bytes of the previous connection are no frame of this one
        self.connected = True
        self.connects += 1
        self._configure()
        log.info("Create on %s: connected (connect #%d)", self.port, self.connects)

    def _configure(self):
        self.write(create_oi.command_start())
        self.write(create_oi.command_mode(self.mode))
        if self.mode in (oi.MODE_SAFE, oi.MODE_FULL):
            self.write(create_oi.command_digital_outputs(*self.digital_outputs))
        self.write(create_oi.command_stream([self.stream_packet]))
        self.last_frame_time = time.monotonic()

    def _wake(self, ser):
        """Pulse RTS as the TurtleBot driver did; a port without modem lines (a pty) is fine."""
        try:
            ser.rts = False
            time.sleep(0.05)
            ser.rts = True
            self.modem_lines = True
        except PORT_ERRORS as exc:
            if self.modem_lines is not False:
                log.info("Create port %s has no modem-line control (%s): skipping the RTS wake-up", self.port, exc)
            self.modem_lines = False

    def _read_loop(self):
        while not self._stop.is_set() and self.connected:
            ser = self._serial
            data = ser.read(max(1, ser.in_waiting))
            now = time.monotonic()
            if data:
                for frame in self.parser.feed(data):
                    self.last_frame_time = now
                    self.on_frame(frame, now)
            elif self.parser.discard_partial():
                log.warning("Create on %s: partial stream frame dropped", self.port)
            if now - self.last_frame_time > self.stall_timeout:
                self.stalls += 1
                log.warning("Create on %s: no sensor frame for %.1f s; setting up the OI again",
                            self.port, now - self.last_frame_time)
                self._configure()

    def _close(self):
        with self._write_lock:
            self.connected = False
            ser, self._serial = self._serial, None
        if ser is not None:
            try:
                ser.close()
            except PORT_ERRORS as exc:
                log.debug("closing %s: %s", self.port, exc)
