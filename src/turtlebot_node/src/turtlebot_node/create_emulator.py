"""An iRobot Create (with the TurtleBot's gyro) emulated from the Open Interface specification.

Written against the specification, not against the driver: it shares only the
constants of :mod:`turtlebot_node.oi_spec` (opcodes, packet ids and sizes) and
has its own command parser and packet encoder, so a misreading of the
specification in the driver is not silently mirrored here.

What it models:
- modes: off until Start (128), passive after Start, safe (131/130), full
  (132); actuator commands are ignored outside safe and full; in safe mode a
  wheel drop stops the motors and falls back to passive;
- Drive (137, with the special radii) and Drive Direct (145): instantaneous
  wheel velocities, differential-drive kinematics on a 258 mm wheel base;
- distance (19) and angle (20) accumulated since last sent, with the
  sub-unit remainder kept so that integer reports add up to the true motion;
- the gyro on the cargo-bay analog input (33): ``zero - rate_dps /
  (range * gain) * zero`` counts, error-diffused to integers; a driver needs
  ``gyro_scale_correction = gain`` to recover the true rate;
- bumpers (7, settable), battery (voltage, current, charge, capacity,
  temperature), digital outputs (147);
- Sensors (142), Query List (149) and Stream (148, one frame per 15 ms of
  emulated time, pause/resume 150).

The core is transport-free: ``feed(data, now)`` and ``poll(now)`` return the
bytes to send (see :class:`florence_common.pty_device.PtyDevice`).
"""

import logging
import math
import threading

from turtlebot_node import oi_spec as oi

log = logging.getLogger(__name__)


class CreateEmulator:
    """State and behaviour of one emulated Create; times in seconds (time.monotonic())."""

    def __init__(self, gyro_zero=512.0, gyro_range=150.0, gyro_gain=1.0, battery_charge=2500,
                 wheel_base=oi.WHEEL_BASE, period=oi.STREAM_PERIOD):
        self.lock = threading.RLock()
        self.gyro_zero = gyro_zero  # [counts] reading at rest
        self.gyro_range = gyro_range  # [deg/s] full scale
        self.gyro_gain = gyro_gain  # the driver's gyro_scale_correction that recovers the true rate
        self.wheel_base = wheel_base  # [m]
        self.period = period  # [s] stream / physics step
        self.mode = oi.MODE_OFF
        self.right = self.left = 0  # [mm/s] wheel velocities in effect
        self.requested_velocity = self.requested_radius = 0  # [mm/s], [mm] of the last Drive
        self.digital_outputs = 0  # bits 0-2
        self.bumps_wheeldrops = 0  # packet 7 bits, settable by tests and simulators
        self.user_digital_inputs = 0
        self.x = self.y = self.theta = 0.0  # [m], [m], [rad] true pose
        self.distance_acc = 0.0  # [mm] since last reported
        self.angle_acc = 0.0  # [deg] since last reported
        self._gyro_residual = 0.0
        self.voltage = 16000  # [mV]
        self.charge = float(battery_charge)  # [mAh]
        self.capacity = 2700  # [mAh]
        self.temperature = 28  # [degC]
        self.stream_ids = []
        self.streaming = False
        self.commands = []  # every complete command received, as bytes (for tests)
        self.unknown_bytes = 0
        self._rx = bytearray()
        self._next_tick = None
        self._values = {
            7: lambda: self.bumps_wheeldrops, 8: lambda: 0, 9: lambda: 0, 10: lambda: 0, 11: lambda: 0,
            12: lambda: 0, 13: lambda: 0, 14: lambda: 0, 15: lambda: 0, 16: lambda: 0, 17: lambda: 255,
            18: lambda: 0, 19: self._report_distance, 20: self._report_angle, 21: lambda: 0,
            22: lambda: self.voltage, 23: self._current, 24: lambda: self.temperature,
            25: lambda: int(self.charge), 26: lambda: self.capacity, 27: lambda: 0, 28: lambda: 0,
            29: lambda: 0, 30: lambda: 0, 31: lambda: 0, 32: lambda: self.user_digital_inputs,
            33: self._gyro_reading, 34: lambda: 0, 35: lambda: self.mode, 36: lambda: 0, 37: lambda: 0,
            38: lambda: len(self.stream_ids), 39: lambda: self.requested_velocity,
            40: lambda: self.requested_radius, 41: lambda: self.right, 42: lambda: self.left,
        }

    # --- host -> device -------------------------------------------------------------------
    def feed(self, data, now):
        with self.lock:
            self._rx += data
            out = bytearray()
            while self._rx:
                opcode = self._rx[0]
                if opcode not in oi.ARGUMENT_BYTES:
                    self.unknown_bytes += 1
                    del self._rx[0]
                    continue
                count = oi.ARGUMENT_BYTES[opcode]
                if count is None:  # variable length: first argument is the number of ids
                    if len(self._rx) < 2:
                        break
                    count = 1 + self._rx[1]
                if len(self._rx) < 1 + count:
                    break
                command = bytes(self._rx[: 1 + count])
                del self._rx[: 1 + count]
                self.commands.append(command)
                out += self._execute(command[0], command[1:], now)
            return bytes(out)

    def _execute(self, opcode, args, now):
        actuating = self.mode in (oi.MODE_SAFE, oi.MODE_FULL)
        if opcode == oi.START:
            self.mode = oi.MODE_PASSIVE
        elif opcode in (oi.SAFE, oi.CONTROL) and self.mode != oi.MODE_OFF:
            self.mode = oi.MODE_SAFE
        elif opcode == oi.FULL and self.mode != oi.MODE_OFF:
            self.mode = oi.MODE_FULL
        elif opcode == oi.DRIVE_DIRECT and actuating:
            self.right = _limit(int.from_bytes(args[0:2], "big", signed=True), oi.MAX_WHEEL_SPEED)
            self.left = _limit(int.from_bytes(args[2:4], "big", signed=True), oi.MAX_WHEEL_SPEED)
        elif opcode == oi.DRIVE and actuating:
            self._drive(int.from_bytes(args[0:2], "big", signed=True), int.from_bytes(args[2:4], "big"))
        elif opcode == oi.DIGITAL_OUTPUTS and actuating:
            self.digital_outputs = args[0] & 0x07
        elif opcode == oi.SENSORS and self.mode != oi.MODE_OFF:
            return self._packet_bytes(args[0], with_id=False)
        elif opcode == oi.QUERY_LIST and self.mode != oi.MODE_OFF:
            return b"".join(self._packet_bytes(i, with_id=False) for i in args[1:])
        elif opcode == oi.STREAM and self.mode != oi.MODE_OFF:
            self.stream_ids = [i for i in args[1:] if i in oi.PACKETS or i in oi.GROUPS]
            self.streaming = bool(self.stream_ids)
        elif opcode == oi.PAUSE_RESUME_STREAM:
            self.streaming = bool(args[0]) and bool(self.stream_ids)
        return b""

    def _drive(self, velocity, radius_u16):
        velocity = _limit(velocity, oi.MAX_WHEEL_SPEED)
        radius = radius_u16 - 0x10000 if radius_u16 >= 0x8000 else radius_u16
        self.requested_velocity = velocity
        self.requested_radius = radius
        half = self.wheel_base * 1000.0 / 2.0  # [mm]
        if radius_u16 in oi.RADIUS_STRAIGHT:
            self.right = self.left = velocity
        elif radius == oi.RADIUS_TURN_CW:
            self.right, self.left = -velocity, velocity
        elif radius == oi.RADIUS_TURN_CCW:
            self.right, self.left = velocity, -velocity
        else:
            radius = _limit(radius, oi.MAX_RADIUS)
            self.right = round(velocity * (radius + half) / radius)
            self.left = round(velocity * (radius - half) / radius)

    # --- device -> host ---------------------------------------------------------------------
    def poll(self, now):
        with self.lock:
            if self._next_tick is None:
                self._next_tick = now + self.period
            out = bytearray()
            while now >= self._next_tick:
                self._next_tick += self.period
                self.step(self.period)
                if self.streaming:
                    out += self._stream_frame()
            return bytes(out)

    def _stream_frame(self):
        body = bytearray([oi.STREAM_HEADER, 0])
        for packet_id in self.stream_ids:
            body += self._packet_bytes(packet_id, with_id=True)
        body[1] = len(body) - 2
        body.append((-sum(body)) & 0xFF)
        return bytes(body)

    def _packet_bytes(self, packet_id, with_id):
        ids = list(range(oi.GROUPS[packet_id][0], oi.GROUPS[packet_id][1] + 1)) if packet_id in oi.GROUPS \
            else [packet_id] if packet_id in oi.PACKETS else []
        out = bytearray([packet_id]) if with_id else bytearray()
        for i in ids:
            _, size, signed = oi.PACKETS[i]
            value = int(self._values[i]())
            lo, hi = (-(1 << (8 * size - 1)), (1 << (8 * size - 1)) - 1) if signed else (0, (1 << (8 * size)) - 1)
            out += max(lo, min(hi, value)).to_bytes(size, "big", signed=signed)
        return bytes(out)

    def _report_distance(self):
        value = round(self.distance_acc)
        value = max(-32768, min(32767, value))
        self.distance_acc -= value
        return value

    def _report_angle(self):
        value = round(self.angle_acc)
        value = max(-32768, min(32767, value))
        self.angle_acc -= value
        return value

    def _current(self):
        return -300 - (abs(self.right) + abs(self.left))  # [mA] discharging

    def true_rate(self):
        """Yaw rate [rad/s] of the wheels in effect."""
        return (self.right - self.left) / 1000.0 / self.wheel_base

    def _gyro_reading(self):
        rate_dps = math.degrees(self.true_rate())
        exact = self.gyro_zero - rate_dps / (self.gyro_range * self.gyro_gain) * self.gyro_zero
        value = round(exact + self._gyro_residual)
        self._gyro_residual += exact - value
        return max(0, min(1023, value))

    # --- physics ------------------------------------------------------------------------------
    def step(self, dt):
        """Advance the emulated robot by dt [s]."""
        if self.mode == oi.MODE_SAFE and self.bumps_wheeldrops & (
                oi.WHEELDROP_LEFT | oi.WHEELDROP_RIGHT | oi.WHEELDROP_CASTER):
            self.right = self.left = 0
            self.mode = oi.MODE_PASSIVE
        d_right = self.right * dt  # [mm]
        d_left = self.left * dt  # [mm]
        distance = (d_right + d_left) / 2.0  # [mm]
        dtheta = (d_right - d_left) / (self.wheel_base * 1000.0)  # [rad]
        mid = self.theta + dtheta / 2.0
        self.x += distance / 1000.0 * math.cos(mid)
        self.y += distance / 1000.0 * math.sin(mid)
        self.theta += dtheta
        self.distance_acc += distance
        self.angle_acc += math.degrees(dtheta)
        self.charge = max(0.0, self.charge + self._current() * dt / 3600.0)

    def snapshot(self):
        """A consistent copy of the state tests look at."""
        with self.lock:
            return {"mode": self.mode, "right": self.right, "left": self.left, "x": self.x, "y": self.y,
                    "theta": self.theta, "digital_outputs": self.digital_outputs, "streaming": self.streaming,
                    "commands": list(self.commands)}


def _limit(value, limit):
    return max(-limit, min(limit, value))
