"""Create OI codec of the driver (ROS-free), checked against the specification's numbers and
against the independently written emulator."""

import math

import pytest
from turtlebot_node.create_emulator import CreateEmulator

from turtlebot_node import create_oi
from turtlebot_node import oi_spec as oi

pytestmark = pytest.mark.unit


@pytest.mark.parametrize(("encoded", "expected"), [
    (create_oi.command_start(), [128]),
    (create_oi.command_mode(oi.MODE_PASSIVE), [128]),
    (create_oi.command_mode(oi.MODE_SAFE), [131]),
    (create_oi.command_mode(oi.MODE_FULL), [132]),
    # Drive Direct: right first, big-endian, two's complement
    (create_oi.command_drive_direct(100, -100), [145, 0x00, 0x64, 0xFF, 0x9C]),
    (create_oi.command_drive_direct(900, -900), [145, 0x01, 0xF4, 0xFE, 0x0C]),  # clamped to +-500
    # Drive spec example: velocity -200 mm/s, radius 500 mm -> 137 255 56 1 244
    (create_oi.command_drive(-200, 500), [137, 0xFF, 0x38, 0x01, 0xF4]),
    (create_oi.command_drive(100, None), [137, 0x00, 0x64, 0x80, 0x00]),  # straight
    (create_oi.command_digital_outputs(1, 0, 1), [147, 5]),
    (create_oi.command_stream([6]), [148, 1, 6]),
    (create_oi.command_pause_stream(), [150, 0]),
])
def test_commands_encode_as_the_specification_says(encoded, expected):
    assert list(encoded) == expected


def test_invalid_mode_is_refused():
    with pytest.raises(ValueError, match="no OI mode"):
        create_oi.command_mode(7)


@pytest.mark.parametrize(("linear", "angular", "wheels"), [
    (0.2, 0.0, (200, 200)),
    (-0.1, 0.0, (-100, -100)),
    (0.0, 1.0, (129, -129)),  # counter-clockwise: right wheel forward
    (0.1, 0.4, (152, 48)),
    (1.0, 0.0, (500, 500)),  # saturated
    (0.5, 2.0, (500, 160)),  # 758/242 mm/s scaled together to 500/160: the radius is kept
])
def test_twist_to_wheels(linear, angular, wheels):
    assert create_oi.twist_to_wheels(linear, angular) == wheels


def test_group_sizes_match_the_specification():
    sizes = {0: 26, 1: 10, 2: 6, 3: 10, 4: 14, 5: 12, 6: 52}
    for packet_id, size in sizes.items():
        assert oi.packet_size(packet_id) == size
        assert create_oi.PacketDecoder(packet_id).size == size


def _frame(emulator):
    """One stream frame of group 6 as the emulator sends it."""
    emulator.feed(bytes([128, 132, 148, 1, 6]), 0.0)
    emulator.poll(0.0)
    return emulator.poll(oi.STREAM_PERIOD * 1.01)


def test_emulator_frame_decodes():
    emulator = CreateEmulator()
    emulator.voltage = 15432
    frame = _frame(emulator)
    assert len(frame) == 56 and frame[:3] == bytes([19, 53, 6])
    parser = create_oi.StreamParser([6])
    (values,) = parser.feed(frame)
    assert values["voltage"] == 15432
    assert values["oi_mode"] == oi.MODE_FULL
    assert values["capacity"] == 2700
    assert values["user_analog_input"] == 512
    assert values["number_of_stream_packets"] == 1
    assert parser.counters() == {"frames": 1, "checksum_errors": 0, "garbage_bytes": 0, "partial_frames": 0}


def test_stream_survives_any_split():
    frames = b"".join(_frame(CreateEmulator()) for _ in range(3))
    parser = create_oi.StreamParser([6])
    decoded = [v for byte in frames for v in parser.feed(bytes([byte]))]
    assert len(decoded) == 3 and parser.garbage_bytes == 0


def test_garbage_wrong_checksum_and_partial_frames_are_counted_and_skipped():
    good = _frame(CreateEmulator())
    bad = bytearray(good)
    bad[10] ^= 0x01  # one flipped bit: wrong checksum
    parser = create_oi.StreamParser([6])
    out = parser.feed(b"\x00\x13\xff" + bytes(bad) + good[:20])  # garbage, a bad frame, a partial one
    assert out == []
    assert parser.checksum_errors == 1
    out = parser.feed(good)  # the partial frame is noise now; the good one behind it is found
    assert len(out) == 1
    assert parser.garbage_bytes >= 3 + 56 + 20
    parser.feed(good[:30])
    assert parser.discard_partial() and parser.partial_frames == 1
    assert not parser.discard_partial()


def test_sensors_command_answer_matches_the_decoder():
    emulator = CreateEmulator()
    emulator.feed(bytes([128, 131]), 0.0)
    emulator.bumps_wheeldrops = oi.BUMP_LEFT
    answer = emulator.feed(bytes([142, 6]), 0.0)
    values = create_oi.PacketDecoder(6).decode(answer)
    assert values["bumps_wheeldrops"] == oi.BUMP_LEFT and values["oi_mode"] == oi.MODE_SAFE
    assert math.isclose(values["current"], -300)
