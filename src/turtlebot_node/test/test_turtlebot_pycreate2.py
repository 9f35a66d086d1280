"""A third-party Open Interface client (pycreate2, PyPI) drives our Create emulator over a pty.

pycreate2 targets the Create 2, whose OI is a superset of the Create's for the
commands used here (Start, Safe, Full, Drive Direct). Its get_sensors() asks for
packet 100, which only the Create 2 has, so sensors are not part of this test.
"""

import gc

import pycreate2
import pytest
from turtlebot_node.create_emulator import CreateEmulator

from florence_common.processes import wait_for
from florence_common.pty_device import PtyDevice
from turtlebot_node import oi_spec as oi

pytestmark = pytest.mark.protocol


def test_pycreate2_drives_our_emulator():
    emulator = CreateEmulator()
    with PtyDevice(emulator) as device:
        bot = pycreate2.Create2(device.path, baud=57600)
        bot.sleep_timer = 0.01  # its mode commands sleep this long
        bot.start()
        bot.safe()
        wait_for(lambda: emulator.mode == oi.MODE_SAFE, 5.0, what="safe mode")
        bot.full()
        bot.drive_direct(200, -100)
        wait_for(lambda: (emulator.right, emulator.left) == (200, -100), 5.0, what="drive direct")
        assert emulator.mode == oi.MODE_FULL
        bot.drive_stop()
        wait_for(lambda: (emulator.right, emulator.left) == (0, 0), 5.0, what="stop")
        del bot  # its destructor still writes to the port: let it while the pty is there
        gc.collect()
