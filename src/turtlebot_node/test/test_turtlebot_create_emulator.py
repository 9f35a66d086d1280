"""The Create emulator follows the specification's mode rules and drive semantics."""

import pytest
from turtlebot_node.create_emulator import CreateEmulator

from turtlebot_node import oi_spec as oi

pytestmark = pytest.mark.unit


def started(mode_opcode=oi.FULL):
    emulator = CreateEmulator()
    emulator.feed(bytes([oi.START, mode_opcode]), 0.0)
    return emulator


def test_off_until_start_and_passive_ignores_actuators():
    emulator = CreateEmulator()
    assert emulator.mode == oi.MODE_OFF
    emulator.feed(bytes([oi.SAFE]), 0.0)
    assert emulator.mode == oi.MODE_OFF
    emulator.feed(bytes([oi.START, oi.DRIVE_DIRECT, 0, 100, 0, 100, oi.DIGITAL_OUTPUTS, 7]), 0.0)
    assert emulator.mode == oi.MODE_PASSIVE
    assert (emulator.right, emulator.left, emulator.digital_outputs) == (0, 0, 0)


@pytest.mark.parametrize(("radius", "wheels"), [
    (0x8000, (200, 200)),  # straight
    (0x7FFF, (200, 200)),
    (0xFFFF, (-200, 200)),  # -1: turn in place clockwise
    (0x0001, (200, -200)),  # 1: counter-clockwise
    (500, (252, 148)),  # left turn of 0.5 m radius: 200 * (500 +- 129) / 500
])
def test_drive_radii(radius, wheels):
    emulator = started()
    emulator.feed(bytes([oi.DRIVE, 0, 200, radius >> 8, radius & 0xFF]), 0.0)
    assert (emulator.right, emulator.left) == wheels


def test_wheel_drop_in_safe_mode_stops_and_falls_back_to_passive():
    emulator = started(oi.SAFE)
    emulator.feed(bytes([oi.DRIVE_DIRECT, 0, 100, 0, 100]), 0.0)
    emulator.bumps_wheeldrops = oi.WHEELDROP_CASTER
    emulator.step(0.015)
    assert emulator.mode == oi.MODE_PASSIVE and emulator.right == emulator.left == 0


def test_commands_split_across_reads_are_reassembled():
    emulator = started()
    emulator.feed(bytes([oi.DRIVE_DIRECT, 0]), 0.0)
    emulator.feed(bytes([50, 0xFF]), 0.0)
    emulator.feed(bytes([0xCE]), 0.0)
    assert (emulator.right, emulator.left) == (50, -50)
    assert emulator.commands[-1] == bytes([145, 0, 50, 0xFF, 0xCE])


def test_gyro_reading_is_dithered_to_the_exact_mean():
    emulator = started()
    emulator.right, emulator.left = 100, -100
    readings = [emulator._gyro_reading() for _ in range(1000)]
    exact = 512 - (200 / 258 * 57.29577951308232) / 150 * 512
    assert sum(readings) / len(readings) == pytest.approx(exact, abs=0.01)
