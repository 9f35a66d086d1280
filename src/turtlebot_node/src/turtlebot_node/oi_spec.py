"""iRobot Create Open Interface: the facts of the specification, as data.

Source: iRobot Create Open Interface (OI) Specification, 2006 (command reference
and sensor packet tables). Only constants live here; the driver's codec
(:mod:`turtlebot_node.create_oi`) and the emulator
(:mod:`turtlebot_node.create_emulator`) are written separately against them.

Conventions of the specification:
- serial 57600 baud, 8N1, no flow control (baud code 10);
- every 16-bit value is sent high byte first (big-endian);
- velocities in mm/s (-500..500), radius in mm (-2000..2000);
- distance (packet 19) in mm, positive forward: the mean of both wheels'
  travel since the packet was last sent;
- angle (packet 20) in degrees, counter-clockwise positive, since last sent;
- stream frames: ``19, n, (id, data...)..., checksum`` where n counts the
  bytes between n and the checksum and all bytes including the checksum sum
  to 0 modulo 256; one frame every 15 ms.
"""

# Opcodes (command reference).
START = 128
BAUD = 129
CONTROL = 130  # same as SAFE on the Create
SAFE = 131
FULL = 132
DRIVE = 137  # velocity [mm/s] int16, radius [mm] int16
LOW_SIDE_DRIVERS = 138
LEDS = 139
SENSORS = 142  # packet id
DRIVE_DIRECT = 145  # right velocity [mm/s] int16, left velocity [mm/s] int16
DIGITAL_OUTPUTS = 147  # one byte, bits 0-2
STREAM = 148  # n, ids...
QUERY_LIST = 149  # n, ids...
PAUSE_RESUME_STREAM = 150  # 0 pause, 1 resume

# Number of data bytes that follow each opcode (None: variable, first byte is a count).
ARGUMENT_BYTES = {
    START: 0,
    BAUD: 1,
    CONTROL: 0,
    SAFE: 0,
    FULL: 0,
    DRIVE: 4,
    LOW_SIDE_DRIVERS: 1,
    LEDS: 3,
    SENSORS: 1,
    DRIVE_DIRECT: 4,
    DIGITAL_OUTPUTS: 1,
    STREAM: None,
    QUERY_LIST: None,
    PAUSE_RESUME_STREAM: 1,
}

# Drive (137) special radii.
RADIUS_STRAIGHT = (0x8000, 0x7FFF)  # as unsigned 16-bit values
RADIUS_TURN_CW = -1
RADIUS_TURN_CCW = 1

# Limits.
MAX_WHEEL_SPEED = 500  # [mm/s]
MAX_RADIUS = 2000  # [mm]
WHEEL_BASE = 0.258  # [m] distance between the wheels (TurtleBot driver's robot_axle_length)

# OI modes (packet 35) and the opcode that enters each.
MODE_OFF, MODE_PASSIVE, MODE_SAFE, MODE_FULL = 0, 1, 2, 3
MODE_OPCODES = {MODE_PASSIVE: START, MODE_SAFE: SAFE, MODE_FULL: FULL}
MODE_NAMES = {MODE_OFF: "off", MODE_PASSIVE: "passive", MODE_SAFE: "safe", MODE_FULL: "full"}

# Baud codes (command 129).
BAUD_CODES = {300: 0, 600: 1, 1200: 2, 2400: 3, 4800: 4, 9600: 5, 14400: 6, 19200: 7,
              28800: 8, 38400: 9, 57600: 10, 115200: 11}

# Stream framing.
STREAM_HEADER = 19
STREAM_PERIOD = 0.015  # [s] one frame every 15 ms

# Single-value sensor packets: id -> (name, size [bytes], signed).
# Names are the TurtlebotSensorState fields that carry them.
PACKETS = {
    7: ("bumps_wheeldrops", 1, False),
    8: ("wall", 1, False),
    9: ("cliff_left", 1, False),
    10: ("cliff_front_left", 1, False),
    11: ("cliff_front_right", 1, False),
    12: ("cliff_right", 1, False),
    13: ("virtual_wall", 1, False),
    14: ("motor_overcurrents", 1, False),
    15: ("dirt_detector_left", 1, False),  # unused on the Create, always 0
    16: ("dirt_detector_right", 1, False),  # unused on the Create, always 0
    17: ("remote_opcode", 1, False),
    18: ("buttons", 1, False),
    19: ("distance", 2, True),  # [mm]
    20: ("angle", 2, True),  # [deg]
    21: ("charging_state", 1, False),
    22: ("voltage", 2, False),  # [mV]
    23: ("current", 2, True),  # [mA]
    24: ("temperature", 1, True),  # [degC]
    25: ("charge", 2, False),  # [mAh]
    26: ("capacity", 2, False),  # [mAh]
    27: ("wall_signal", 2, False),
    28: ("cliff_left_signal", 2, False),
    29: ("cliff_front_left_signal", 2, False),
    30: ("cliff_front_right_signal", 2, False),
    31: ("cliff_right_signal", 2, False),
    32: ("user_digital_inputs", 1, False),
    33: ("user_analog_input", 2, False),  # 0-1023: the TurtleBot's gyro
    34: ("charging_sources_available", 1, False),
    35: ("oi_mode", 1, False),
    36: ("song_number", 1, False),
    37: ("song_playing", 1, False),
    38: ("number_of_stream_packets", 1, False),
    39: ("requested_velocity", 2, True),  # [mm/s]
    40: ("requested_radius", 2, True),  # [mm]
    41: ("requested_right_velocity", 2, True),  # [mm/s]
    42: ("requested_left_velocity", 2, True),  # [mm/s]
}

# Group packets: id -> (first, last) single packet id they contain.
GROUPS = {0: (7, 26), 1: (7, 16), 2: (17, 20), 3: (21, 26), 4: (27, 34), 5: (35, 42), 6: (7, 42)}

# Bits of packet 7.
BUMP_RIGHT = 0x01
BUMP_LEFT = 0x02
WHEELDROP_RIGHT = 0x04
WHEELDROP_LEFT = 0x08
WHEELDROP_CASTER = 0x10

# Charging states (packet 21).
CHARGING_STATE_NAMES = {0: "not charging", 1: "reconditioning", 2: "full charging", 3: "trickle charging",
                        4: "waiting", 5: "charging fault"}


def packet_ids(packet_id):
    """The single packet ids a (group) packet id stands for, in transmission order."""
    if packet_id in GROUPS:
        first, last = GROUPS[packet_id]
        return list(range(first, last + 1))
    if packet_id in PACKETS:
        return [packet_id]
    raise ValueError(f"unknown sensor packet id {packet_id}")


def packet_size(packet_id):
    """Data bytes of a (group) packet [bytes]."""
    return sum(PACKETS[i][1] for i in packet_ids(packet_id))
