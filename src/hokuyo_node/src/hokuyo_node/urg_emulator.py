"""A Hokuyo URG-04LX emulated from the SCIP 2.0 specification.

Written against the specification, not against the driver: it shares only the
constants of :mod:`hokuyo_node.scip_spec` and has its own command parser,
encoder and checksum. Ranges come from a callback ``ranges(now)`` returning
the distances [mm] of steps 0..ARES/2-ish; values below DMIN are error codes,
as on the real sensor.

Commands: SCIP2.0, VV, PP, II, BM, QT, RS, TM0/TM1/TM2, MD/MS (continuous,
with skip and number of scans), GD/GS (one scan); anything else is answered
with status 0E. A scan is produced every 60/SCAN s (100 ms) of ``now``.

Fault injection for tests (``faults`` list, consumed one per scan):
"checksum" corrupts the sum of one data block, "truncate" cuts the scan off
in the middle (a partial reply), "status" sends status 50 (hardware trouble).

The core is transport-free: ``feed(data, now)`` and ``poll(now)`` return the
bytes to send (see :class:`florence_common.pty_device.PtyDevice`).
"""

import logging
import threading

from hokuyo_node import scip_spec as spec

log = logging.getLogger(__name__)

STEPS = 769  # steps 0..768 can be addressed on the URG-04LX (768 + 1)


def _sum_char(data):
    total = 0
    for byte in data:
        total += byte
    return bytes([(total & 0x3F) + spec.ENCODING_OFFSET])


def _encode(value, chars):
    out = bytearray(chars)
    for i in range(chars - 1, -1, -1):
        out[i] = (value & 0x3F) + spec.ENCODING_OFFSET
        value >>= 6
    return bytes(out)


def _line(data):
    return data + _sum_char(data) + b"\n"


def default_ranges(_now):
    """A 2 m circle around the sensor with an error code (1 mm) every 50 steps."""
    return [1 if i % 50 == 0 else 2000 for i in range(STEPS)]


class UrgEmulator:
    def __init__(self, ranges=default_ranges, serial_number="H0000001", geometry=None):
        self.lock = threading.RLock()
        self.ranges = ranges  # callable(now) -> sequence of STEPS ranges [mm]
        self.geometry = dict(geometry or spec.URG_04LX)
        self.serial_number = serial_number
        self.laser_on = False
        self.measurement = None  # dict of the running MD/MS
        self.time_adjust = False
        self.faults = []
        self.commands = []  # every command line received (for tests)
        self.scans_sent = 0
        self._rx = bytearray()
        self._t0 = None
        self.period = 60.0 / self.geometry["SCAN"]  # [s] one revolution

    def timestamp(self, now):
        if self._t0 is None:
            self._t0 = now
        return int((now - self._t0) * 1000.0) % spec.TIMESTAMP_MODULO  # [ms]

    # --- host -> sensor ---------------------------------------------------------------------------
    def feed(self, data, now):
        with self.lock:
            self.timestamp(now)
            self._rx += data
            out = bytearray()
            while True:
                ends = [i for i in (self._rx.find(b"\n"), self._rx.find(b"\r")) if i >= 0]
                if not ends:
                    break
                end = min(ends)
                line = bytes(self._rx[:end])
                del self._rx[: end + 1]
                if not line:
                    continue  # the LF of a CR LF pair
                self.commands.append(line)
                out += self._answer(line, now)
            return bytes(out)

    def _answer(self, line, now):  # noqa: PLR0911 - one reply per command
        symbol = line[:2]
        body = line.split(b";", 1)[0]
        if line.startswith(spec.SCIP2):
            return line + b"\n0\n\n"
        if symbol == spec.VERSION:
            return self._info(line, (("VEND", "Hokuyo Automatic Co.,Ltd."), ("PROD", "SOKUIKI Sensor URG-04LX"),
                                     ("FIRM", "3.3.00,07/05/22(20-4095[mm],240[deg])"), ("PROT", "SCIP 2.0"),
                                     ("SERI", self.serial_number)))
        if symbol == spec.PARAMETERS:
            return self._info(line, [(key, str(self.geometry[key])) for key in spec.PP_KEYS])
        if symbol == spec.STATE:
            return self._info(line, (("MODL", self.geometry["MODL"]), ("LASR", "ON" if self.laser_on else "OFF"),
                                     ("SCSP", f"Initial({self.geometry['SCAN']}[rpm])"),
                                     ("MESM", "Measuring by Normal Mode" if self.measurement else "Idle"),
                                     ("SBPS", "USB only"), ("TIME", _encode(self.timestamp(now), 4).decode()),
                                     ("STAT", "Stable 000 no error.")))
        if symbol == spec.LASER_ON:
            status = spec.STATUS_LASER_ALREADY_ON if self.laser_on else spec.STATUS_OK
            self.laser_on = True
            return self._status(line, status)
        if symbol in (spec.LASER_OFF, spec.RESET):
            self.laser_on = False
            self.measurement = None
            self.time_adjust = False
            return self._status(line, spec.STATUS_OK)
        if symbol == spec.TIME and body[2:] in (b"0", b"1", b"2"):
            mode = body[2:]
            if mode == b"0":
                self.time_adjust = True
            elif mode == b"2":
                self.time_adjust = False
            elif not self.time_adjust:
                return self._status(line, b"01")
            reply = line + b"\n" + _line(spec.STATUS_OK)
            if mode == b"1":
                reply += _line(_encode(self.timestamp(now), spec.TIMESTAMP_CHARS))
            return reply + b"\n"
        if symbol in (spec.MEASURE_3, spec.MEASURE_2, spec.SCAN_3, spec.SCAN_2):
            return self._measure(line, body, symbol, now)
        return self._status(line, spec.STATUS_UNDEFINED_COMMAND)

    def _info(self, echo, items):
        out = echo + b"\n" + _line(spec.STATUS_OK)
        for key, value in items:
            text = f"{key}:{value}".encode()
            out += text + b";" + _sum_char(text) + b"\n"
        return out + b"\n"

    def _status(self, echo, status):
        return echo + b"\n" + _line(status) + b"\n"

    def _measure(self, line, body, symbol, now):  # noqa: PLR0911 - one status per parameter error
        continuous = symbol in (spec.MEASURE_3, spec.MEASURE_2)
        params = body[2:]
        fields = [(0, 4, b"01"), (4, 8, b"02"), (8, 10, b"03")]
        if continuous:
            fields += [(10, 11, b"06"), (11, 13, b"07")]
        if len(params) != fields[-1][1]:
            return self._status(line, spec.STATUS_UNDEFINED_COMMAND)
        values = []
        for start, end, error in fields:
            if not params[start:end].isdigit():
                return self._status(line, error)
            values.append(int(params[start:end]))
        first, last, cluster = values[:3]
        if last >= STEPS or first < 0:
            return self._status(line, b"04")
        if last < first:
            return self._status(line, b"05")
        chars = spec.DATA_CHARS[symbol]
        request = {"first": first, "last": last, "cluster": max(1, cluster), "chars": chars, "echo": line}
        if not continuous:
            if not self.laser_on:
                return self._status(line, b"10")
            return line + b"\n" + _line(spec.STATUS_OK) + self._scan_body(request, now) + b"\n"
        request.update(skip=values[3], remaining=values[4], infinite=values[4] == 0,
                       next_time=now + self.period)
        self.laser_on = True
        self.measurement = request
        return self._status(line, spec.STATUS_OK)

    # --- sensor -> host ---------------------------------------------------------------------------
    def _scan_body(self, request, now):
        """Time stamp line and data blocks of one scan (without the final LF)."""
        ranges = self.ranges(now)
        limit = (1 << (6 * request["chars"])) - 1
        data = bytearray()
        for start in range(request["first"], request["last"] + 1, request["cluster"]):
            group = ranges[start : min(request["last"], start + request["cluster"] - 1) + 1]
            valid = [r for r in group if r >= self.geometry["DMIN"]]
            value = min(valid) if valid else min(group)  # a cluster reports its nearest valid range
            data += _encode(min(int(value), limit), request["chars"])
        out = bytearray(_line(_encode(self.timestamp(now), spec.TIMESTAMP_CHARS)))
        for i in range(0, len(data), spec.BLOCK_SIZE):
            out += _line(bytes(data[i : i + spec.BLOCK_SIZE]))
        return bytes(out)

    def poll(self, now):
        with self.lock:
            m = self.measurement
            if m is None or now < m["next_time"]:
                return b""
            m["next_time"] += self.period * (m["skip"] + 1)
            if now > m["next_time"]:  # fell behind (loaded host): skip, as the real sensor's rotation would
                m["next_time"] = now + self.period
            if not m["infinite"]:
                m["remaining"] -= 1
            echo = m["echo"][:13] + b"%02d" % max(m["remaining"], 0) + m["echo"][15:]
            if not m["infinite"] and m["remaining"] <= 0:
                self.measurement = None
            fault = self.faults.pop(0) if self.faults else None
            if fault == "status":
                return echo + b"\n" + _line(b"50") + b"\n"
            body = self._scan_body(m, now)
            if fault == "checksum":
                cut = body.index(b"\n") + 1 + spec.BLOCK_SIZE  # sum character of the first data block
                body = body[:cut] + bytes([((body[cut] - 0x30 + 1) & 0x3F) + 0x30]) + body[cut + 1 :]
            if fault == "truncate":
                return echo + b"\n" + _line(spec.STATUS_SCAN) + body[: len(body) // 2]
            self.scans_sent += 1
            return echo + b"\n" + _line(spec.STATUS_SCAN) + body + b"\n"
