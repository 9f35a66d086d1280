"""fakenect dumps: the folder fakenect-record writes and fakenect's libfreenect.so replays (ROS-free).

The format (libfreenect's fakenect/record.c and fakenect.c, README.fakenect):

- ``INDEX.txt``: one file name a line, in the order of the recording; fakenect reads one line
  per ``freenect_process_events`` call and stops at the first empty line or the end (Debian's
  0.5.3 does not loop: the stream ends there).
- a file per record, named ``<type>-<time>-<timestamp>.<ext>``: type ``d`` (depth), ``r``
  (RGB) or ``a`` (accelerometer and tilt); time [s] with six decimals (printf "%f": fakenect
  waits between records as long as the recording did); timestamp the device's frame counter.
- ``d``: the PGM header line ``P5 640 480 65535`` then 640x480 11-bit values as little-endian
  uint16 (the raw buffer, not PGM's big-endian); ``r``: ``P6 640 480 255`` then 640x480x3 RGB
  bytes; ``a``: the 12 bytes of freenect_raw_tilt_state (int16 x, y, z; int8 tilt in half
  degrees; a pad byte; int32 motor status).

fakenect itself calls exit(1) when a listed file is missing and copies a fixed number of bytes
from whatever a file holds: :func:`check` finds such entries first, :func:`replayable` makes a
copy of the index without them (symbolic links to the good files), so a damaged dump plays
what it has instead of ending the process.
"""

import os
import re
import struct
from dataclasses import dataclass, field

import numpy as np

from florence_common.files import atomic_write
from openni_camera import kinect

INDEX = "INDEX.txt"
NAME = re.compile(r"^([dra])-([0-9]+(?:\.[0-9]*)?)-([0-9]+)")
DEPTH_HEADER = f"P5 {kinect.WIDTH} {kinect.HEIGHT} 65535\n".encode()
RGB_HEADER = f"P6 {kinect.WIDTH} {kinect.HEIGHT} 255\n".encode()
TILT_STATE = struct.Struct("<hhhbxi")  # freenect_raw_tilt_state: 12 bytes
EXTENSIONS = {"d": "pgm", "r": "ppm", "a": "dump"}
PAYLOAD = {"d": (DEPTH_HEADER, kinect.DEPTH_BYTES), "r": (RGB_HEADER, kinect.RGB_BYTES)}


class DumpError(ValueError):
    """A folder that is no fakenect dump at all (the message says why)."""


def record_name(kind, time, timestamp):
    """fakenect-record's file name of a record: type, time [s] ("%f"), device timestamp."""
    return f"{kind}-{time:f}-{int(timestamp) & 0xFFFFFFFF}.{EXTENSIONS[kind]}"


def depth_bytes(raw):
    """A ``d`` file of a (480, 640) uint16 frame of 11-bit values."""
    raw = np.asarray(raw)
    if raw.shape != (kinect.HEIGHT, kinect.WIDTH):
        raise ValueError(f"depth frame must be {kinect.WIDTH}x{kinect.HEIGHT}, got {raw.shape}")
    return DEPTH_HEADER + raw.astype("<u2").tobytes()


def rgb_bytes(rgb):
    """An ``r`` file of a (480, 640, 3) uint8 RGB frame."""
    rgb = np.asarray(rgb)
    if rgb.shape != (kinect.HEIGHT, kinect.WIDTH, 3):
        raise ValueError(f"colour frame must be {kinect.WIDTH}x{kinect.HEIGHT}x3, got {rgb.shape}")
    return RGB_HEADER + rgb.astype(np.uint8).tobytes()


def tilt_state_bytes(counts, tilt_raw, status):
    """An ``a`` file: raw accelerometer counts (x, y, z), tilt (half degrees), motor status."""
    return TILT_STATE.pack(*(int(c) for c in counts), int(tilt_raw), int(status))


def parse_tilt_state(data):
    """(counts (x, y, z), tilt raw, status) of 12 bytes of freenect_raw_tilt_state."""
    x, y, z, tilt, status = TILT_STATE.unpack(bytes(data))
    return (x, y, z), tilt, status


class DumpWriter:
    """Writes a dump as fakenect-record does. The folder is created; an existing INDEX.txt is
    refused (as fakenect-record refuses to overwrite a recording)."""

    def __init__(self, path):
        self.path = os.fspath(path)
        os.makedirs(self.path, exist_ok=True)
        if os.path.exists(os.path.join(self.path, INDEX)):
            raise FileExistsError(f"{self.path} already holds a recording ({INDEX}); use another folder")
        self.names = []

    def _add(self, kind, time, timestamp, data):
        name = record_name(kind, time, timestamp)
        with open(os.path.join(self.path, name), "wb") as f:
            f.write(data)
        self.names.append(name)
        return name

    def depth(self, time, timestamp, raw):
        return self._add("d", time, timestamp, depth_bytes(raw))

    def rgb(self, time, timestamp, rgb):
        return self._add("r", time, timestamp, rgb_bytes(rgb))

    def tilt_state(self, time, timestamp, counts, tilt_raw, status):
        return self._add("a", time, timestamp, tilt_state_bytes(counts, tilt_raw, status))

    def again(self, name, time, timestamp):
        """A record of the same data as the earlier record ``name`` at another time: a relative
        symbolic link (a long replay of a few rendered frames takes no disk)."""
        kind = name[0]
        new = record_name(kind, time, timestamp)
        os.symlink(name, os.path.join(self.path, new))
        self.names.append(new)
        return new

    def close(self):
        atomic_write(os.path.join(self.path, INDEX), "".join(f"{n}\n" for n in self.names).encode())


@dataclass
class Check:
    """What :func:`check` found: the usable index lines, the problems (one text each) and counts."""

    good: list = field(default_factory=list)
    problems: list = field(default_factory=list)
    counts: dict = field(default_factory=lambda: {"d": 0, "r": 0, "a": 0})
    duration: float = 0.0  # [s] from the first to the last usable record
    longest_gap: float = 0.0  # [s] between two usable records


def _file_problem(path, kind):
    try:
        size = os.path.getsize(path)
    except OSError as exc:
        return "missing" if isinstance(exc, FileNotFoundError) else f"unreadable ({exc.strerror})"
    if kind == "a":
        return None if size == TILT_STATE.size else f"{size} bytes, not {TILT_STATE.size}"
    header, payload = PAYLOAD[kind]
    try:
        with open(path, "rb") as f:
            head = f.read(len(header) + 16)
    except OSError as exc:
        return f"unreadable ({exc.strerror})"
    line = head.split(b"\n", 1)[0] + b"\n"
    if line.split() != header.split():
        return f"header {line.strip()[:40]!r}, not {header.strip().decode()!r}"
    if size - len(line) < payload:
        return f"{size - len(line)} bytes of data, not {payload}"
    return None


def check(path):
    """Check every record of the dump at ``path``; DumpError when it has no index."""
    index = os.path.join(os.fspath(path), INDEX)
    try:
        with open(index, encoding="utf-8", errors="replace") as f:
            lines = f.read().split("\n")
    except FileNotFoundError:
        raise DumpError(f"{path}: no {INDEX} (not a fakenect dump, or not there)") from None
    except OSError as exc:
        raise DumpError(f"{index}: {exc.strerror}") from None
    if lines and lines[-1] == "":
        lines.pop()  # the final newline
    result, previous = Check(), None
    for number, line in enumerate(lines, start=1):
        name = line.strip()
        where = f"{INDEX} line {number}"
        if not name:
            result.problems.append(f"{where}: empty (fakenect would stop there)")
            continue
        match = NAME.match(name)
        if not match:
            result.problems.append(f"{where}: {name[:60]!r} is not a record name (type-time-timestamp)")
            continue
        kind, time = match.group(1), float(match.group(2))
        problem = _file_problem(os.path.join(os.fspath(path), name), kind)
        if problem:
            result.problems.append(f"{name}: {problem}")
            continue
        if previous is not None and time < previous:
            result.problems.append(f"{name}: time {time:.6f} before the previous record's {previous:.6f}")
            continue
        if previous is not None:
            result.longest_gap = max(result.longest_gap, time - previous)
            result.duration += time - previous
        previous = time
        result.good.append(name)
        result.counts[kind] += 1
    return result


def replayable(path, scratch):
    """(folder for FAKENECT_PATH, Check): ``path`` itself when every record is good, else a new
    folder in ``scratch`` whose index lists only the good records (links to the originals).
    DumpError when the dump has no index or no usable record."""
    path = os.path.abspath(os.fspath(path))
    result = check(path)
    if not result.good:
        raise DumpError(f"{path}: no usable record" + (f" ({result.problems[0]})" if result.problems else ""))
    if not result.problems:
        return path, result
    os.makedirs(scratch, exist_ok=True)
    for name in os.listdir(scratch):
        os.unlink(os.path.join(scratch, name))
    for name in result.good:
        os.symlink(os.path.join(path, name), os.path.join(scratch, name))
    atomic_write(os.path.join(scratch, INDEX), "".join(f"{n}\n" for n in result.good).encode())
    return os.fspath(scratch), result
