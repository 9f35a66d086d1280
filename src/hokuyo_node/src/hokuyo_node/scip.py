"""SCIP 2.0 codec of the driver: commands to bytes, replies to values. ROS- and transport-free.

Every decoding function validates what it reads (echo, status, every sum)
and raises :class:`ScipError` naming what was wrong, so the transport can count
the error and carry on with the next reply.
"""

import math
from dataclasses import dataclass

import numpy as np

from hokuyo_node import scip_spec as spec


class ScipError(ValueError):
    """A reply that does not follow SCIP 2.0 (bad sum, bad status, wrong shape)."""

    def __init__(self, kind, detail):
        super().__init__(f"{kind}: {detail}")
        self.kind = kind  # "checksum", "status", "format"


def checksum(data):
    """The SCIP sum character of ``data`` (bytes)."""
    return (sum(data) & 0x3F) + spec.ENCODING_OFFSET


def decode_value(chars):
    """Decode one 2-, 3- or 4-character value."""
    value = 0
    for c in chars:
        value = (value << spec.BITS_PER_CHAR) | (c - spec.ENCODING_OFFSET)
    return value


def decode_values(data, chars):
    """Decode a run of ``chars``-character values (bytes) into an int32 numpy array."""
    if len(data) % chars:
        raise ScipError("format", f"{len(data)} data characters are not a multiple of {chars}")
    codes = np.frombuffer(data, dtype=np.uint8).astype(np.int32) - spec.ENCODING_OFFSET
    if codes.size and (codes.min() < 0 or codes.max() > 63):
        raise ScipError("format", "character outside the SCIP encoding range")
    codes = codes.reshape(-1, chars)
    values = codes[:, 0].copy()
    for i in range(1, chars):
        values = (values << spec.BITS_PER_CHAR) | codes[:, i]
    return values


# --- commands ------------------------------------------------------------------------------------------
def command(symbol, parameters=b"", tag=b""):
    return symbol + parameters + ((b";" + tag) if tag else b"") + b"\n"


def measure_command(first, last, cluster=1, skip=0, scans=0, symbol=spec.MEASURE_3, tag=b""):
    """MD/MS/ME: steps ``first``..``last``, ``cluster`` steps per value, ``skip`` scans
    left out between two sent, ``scans`` scans (0 = until QT)."""
    return command(symbol, b"%04d%04d%02d%01d%02d" % (first, last, cluster, skip, scans), tag)


def scan_command(first, last, cluster=1, symbol=spec.SCAN_3, tag=b""):
    return command(symbol, b"%04d%04d%02d" % (first, last, cluster), tag)


# --- replies ---------------------------------------------------------------------------------------------
@dataclass
class Reply:
    echo: bytes  # the command as the sensor echoed it
    status: bytes  # two status characters ("0" alone for the SCIP 1.1 answer to "SCIP2.0")
    lines: list  # data lines, each still ending in its sum character


def parse_reply(raw):
    """Split one reply (bytes up to and including the terminating empty line)."""
    lines = raw.split(b"\n")
    if len(lines) < 3 or lines[-1] != b"" or lines[-2] != b"":
        raise ScipError("format", f"reply does not end in LF LF: {raw[-8:]!r}")
    lines = lines[:-2]
    if len(lines) < 2:
        raise ScipError("format", "reply without a status line")
    echo, status = lines[0], lines[1]
    if len(status) == 3:
        if checksum(status[:2]) != status[2]:
            raise ScipError("checksum", f"status line {status!r}")
        status = status[:2]
    elif len(status) != 1:
        raise ScipError("format", f"status line {status!r}")
    return Reply(echo, status, lines[2:])


def check_status(reply, *accepted):
    if reply.status not in accepted:
        meaning = spec.MEASUREMENT_STATUS.get(reply.status, "")
        raise ScipError("status", f"{reply.echo!r} answered status {reply.status!r} {meaning}".rstrip())


def parse_info(reply):
    """VV/PP/II lines ``KEY:value;sum`` to a dict of strings."""
    info = {}
    for line in reply.lines:
        if len(line) < 3 or line[-2:-1] != b";" or b":" not in line:
            raise ScipError("format", f"information line {line!r}")
        body = line[:-2]
        if checksum(body) != line[-1]:
            raise ScipError("checksum", f"information line {line!r}")
        key, value = body.split(b":", 1)
        info[key.decode("ascii", "replace")] = value.decode("ascii", "replace")
    return info


def parse_timestamp(line):
    """The 4-character time stamp line [ms]."""
    if len(line) != spec.TIMESTAMP_CHARS + 1 or checksum(line[:-1]) != line[-1]:
        raise ScipError("checksum" if len(line) == spec.TIMESTAMP_CHARS + 1 else "format", f"time stamp {line!r}")
    return decode_value(line[:-1])


def parse_scan(reply, chars):
    """A GD/GS/MD/MS scan reply: (time stamp [ms], values as int32 array)."""
    if not reply.lines:
        raise ScipError("format", "scan reply without time stamp")
    stamp = parse_timestamp(reply.lines[0])
    blocks = reply.lines[1:]
    payload = bytearray()
    for i, block in enumerate(blocks):
        if len(block) < 2 or len(block) > spec.BLOCK_SIZE + 1:
            raise ScipError("format", f"data block {i} has {len(block)} characters")
        if checksum(block[:-1]) != block[-1]:
            raise ScipError("checksum", f"data block {i} of {len(blocks)}")
        if len(block) != spec.BLOCK_SIZE + 1 and i != len(blocks) - 1:
            raise ScipError("format", f"short data block {i} before the last one")
        payload += block[:-1]
    return stamp, decode_values(bytes(payload), chars)


# --- geometry -------------------------------------------------------------------------------------------
@dataclass
class Geometry:
    """The sensor's PP answer: ranges [mm] and steps."""

    model: str
    dmin: int  # [mm]
    dmax: int  # [mm]
    ares: int  # steps in 360 deg
    amin: int  # first measurable step
    amax: int  # last measurable step
    afrt: int  # step straight ahead
    rpm: int  # [1/min] motor speed

    @classmethod
    def from_info(cls, info):
        try:
            return cls(info["MODL"], int(info["DMIN"]), int(info["DMAX"]), int(info["ARES"]), int(info["AMIN"]),
                       int(info["AMAX"]), int(info["AFRT"]), int(info["SCAN"]))
        except (KeyError, ValueError) as exc:
            raise ScipError("format", f"PP answer incomplete: {exc}") from None

    @property
    def resolution(self):
        return 2.0 * math.pi / self.ares  # [rad/step]

    @property
    def scan_period(self):
        return 60.0 / self.rpm  # [s/revolution]

    def angle(self, step):
        return (step - self.afrt) * self.resolution  # [rad], counter-clockwise from the front

    def steps(self, min_ang, max_ang, clamp=True):
        """First and last step inside [min_ang, max_ang] [rad]; clamped to the measurable range."""
        first = self.afrt + math.ceil(min_ang / self.resolution - 1e-9)
        last = self.afrt + math.floor(max_ang / self.resolution + 1e-9)
        if clamp:
            first, last = max(first, self.amin), min(last, self.amax)
        if last < first:
            raise ValueError(f"no step between {min_ang} and {max_ang} rad")
        return first, last

    def layout(self, first, last, cluster=1, skip=0):
        """LaserScan geometry of a measurement of steps first..last: a dict of SI values."""
        count = (last - first) // cluster + 1
        step_time = self.scan_period / self.ares  # [s] between two steps
        return {
            "count": count,
            "angle_min": self.angle(first),
            "angle_max": self.angle(first + (count - 1) * cluster),
            "angle_increment": cluster * self.resolution,
            "time_increment": cluster * step_time,
            "scan_time": self.scan_period * (skip + 1),
            "range_min": self.dmin / 1000.0,
            "range_max": self.dmax / 1000.0,
        }


def ranges_to_metres(values, dmin):
    """Range values [mm] to metres; values below ``dmin`` are error codes, published as +inf (no return)."""
    out = values.astype(np.float32) / np.float32(1000.0)
    out[values < dmin] = np.inf
    return out
