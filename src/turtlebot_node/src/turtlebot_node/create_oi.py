"""Create Open Interface codec of the driver: commands to bytes, stream bytes to values.

ROS-free and transport-free: functions return the bytes to write; the
:class:`StreamParser` takes whatever bytes arrived (any split, any noise) and
returns decoded frames, counting what it had to throw away.
"""

import logging
import struct

from turtlebot_node import oi_spec as oi

log = logging.getLogger(__name__)


def _int16(value):
    return struct.pack(">h", int(value))


def command_start():
    return bytes([oi.START])


def command_mode(mode):
    """Bytes that put the OI into ``mode`` (oi.MODE_PASSIVE / MODE_SAFE / MODE_FULL)."""
    if mode not in oi.MODE_OPCODES:
        raise ValueError(f"no OI mode {mode!r}; valid: {sorted(oi.MODE_OPCODES)}")
    return bytes([oi.MODE_OPCODES[mode]])


def _clamp(value, limit):
    return max(-limit, min(limit, round(value)))


def command_drive_direct(right, left):
    """Drive direct (145): wheel velocities [mm/s], right first; clamped to +-500."""
    return bytes([oi.DRIVE_DIRECT]) + _int16(_clamp(right, oi.MAX_WHEEL_SPEED)) + _int16(
        _clamp(left, oi.MAX_WHEEL_SPEED))


def command_drive(velocity, radius):
    """Drive (137): velocity [mm/s] and radius [mm]; radius None drives straight."""
    velocity = _clamp(velocity, oi.MAX_WHEEL_SPEED)
    if radius is None:
        return bytes([oi.DRIVE]) + _int16(velocity) + struct.pack(">H", oi.RADIUS_STRAIGHT[0])
    return bytes([oi.DRIVE]) + _int16(velocity) + _int16(_clamp(radius, oi.MAX_RADIUS))


def command_digital_outputs(out0, out1, out2):
    """Digital outputs (147): the three cargo-bay outputs as bits 0-2."""
    bits = (1 if out0 else 0) | (2 if out1 else 0) | (4 if out2 else 0)
    return bytes([oi.DIGITAL_OUTPUTS, bits])


def command_stream(packet_ids):
    """Stream (148): ask for ``packet_ids`` every 15 ms."""
    return bytes([oi.STREAM, len(packet_ids), *packet_ids])


def command_pause_stream():
    return bytes([oi.PAUSE_RESUME_STREAM, 0])


def twist_to_wheels(linear, angular, wheel_base=oi.WHEEL_BASE):
    """Body velocity to wheel velocities.

    linear [m/s] forward, angular [rad/s] counter-clockwise, wheel_base [m].
    Returns (right, left) [mm/s]; if a wheel would exceed 500 mm/s both are scaled
    down together so the turning radius is kept.
    """
    right = (linear + angular * wheel_base / 2.0) * 1000.0
    left = (linear - angular * wheel_base / 2.0) * 1000.0
    peak = max(abs(right), abs(left))
    if peak > oi.MAX_WHEEL_SPEED:
        scale = oi.MAX_WHEEL_SPEED / peak
        right, left = right * scale, left * scale
    return round(right), round(left)


class PacketDecoder:
    """Decodes the data bytes of one (group) sensor packet into a dict of field values."""

    def __init__(self, packet_id):
        self.packet_id = packet_id
        self.ids = oi.packet_ids(packet_id)
        codes = {(1, False): "B", (1, True): "b", (2, False): "H", (2, True): "h"}
        self._struct = struct.Struct(">" + "".join(codes[oi.PACKETS[i][1:]] for i in self.ids))
        self.names = [oi.PACKETS[i][0] for i in self.ids]
        self.size = self._struct.size  # [bytes]

    def decode(self, data):
        return dict(zip(self.names, self._struct.unpack(data), strict=True))


class StreamParser:
    """Reassembles stream frames (``19, n, id, data..., checksum``) from a byte stream.

    ``feed(data)`` returns the list of decoded frames (dicts) completed by
    ``data``. Bytes that cannot start a valid frame are skipped and counted as
    ``garbage_bytes``; a frame whose checksum or layout is wrong is counted in
    ``checksum_errors`` and the search for the next header starts one byte later,
    so no valid frame behind noise is lost.
    """

    def __init__(self, packet_ids):
        self.decoders = [PacketDecoder(i) for i in packet_ids]
        self.length = sum(1 + d.size for d in self.decoders)  # the frame's n byte
        self.frame_size = self.length + 3  # header, n, payload, checksum [bytes]
        self.buffer = bytearray()
        self.frames = 0
        self.checksum_errors = 0
        self.garbage_bytes = 0
        self.partial_frames = 0

    def counters(self):
        return {"frames": self.frames, "checksum_errors": self.checksum_errors,
                "garbage_bytes": self.garbage_bytes, "partial_frames": self.partial_frames}

    def feed(self, data):
        self.buffer += data
        frames = []
        buf = self.buffer
        while True:
            start = buf.find(oi.STREAM_HEADER)
            if start < 0:
                self.garbage_bytes += len(buf)
                buf.clear()
                break
            if start:
                self.garbage_bytes += start
                del buf[:start]
            if len(buf) < 2:
                break
            if buf[1] != self.length:
                self.garbage_bytes += 1
                del buf[:1]
                continue
            if len(buf) < self.frame_size:
                break
            frame = bytes(buf[: self.frame_size])
            decoded = self._decode(frame)
            if decoded is None:
                self.checksum_errors += 1
                self.garbage_bytes += 1
                del buf[:1]
                continue
            del buf[: self.frame_size]
            self.frames += 1
            frames.append(decoded)
        return frames

    def discard_partial(self):
        """Drop an unfinished frame (the line went quiet mid-frame); True if there was one."""
        if not self.buffer:
            return False
        self.partial_frames += 1
        self.garbage_bytes += len(self.buffer)
        self.buffer.clear()
        return True

    def _decode(self, frame):
        if sum(frame) & 0xFF:
            return None
        values = {}
        pos = 2
        for decoder in self.decoders:
            if frame[pos] != decoder.packet_id:
                return None
            pos += 1
            values.update(decoder.decode(frame[pos : pos + decoder.size]))
            pos += decoder.size
        return values
