"""florence_common.pty_device.PtyKeyboard types as a terminal does while a key is held."""

import os
import select
import time

import pytest

from florence_common.pty_device import PtyKeyboard

pytestmark = pytest.mark.unit


def read_all(fd, timeout=0.5):
    data = b""
    while select.select([fd], [], [], timeout)[0]:
        chunk = os.read(fd, 4096)
        if not chunk:
            break
        data += chunk
    return data


def test_typed_text_reaches_the_slave_side():
    with PtyKeyboard() as keyboard:
        os.set_blocking(keyboard.slave, False)
        import tty

        tty.setcbreak(keyboard.slave)
        keyboard.type("iq")
        assert read_all(keyboard.slave) == b"iq"


def test_a_held_key_repeats_after_the_delay_and_stops_on_until():
    with PtyKeyboard(repeat=50.0) as keyboard:
        import tty

        tty.setcbreak(keyboard.slave)
        start = time.monotonic()
        last = keyboard.hold("j", 0.5, delay=0.1)
        assert 0.45 <= last - start <= 1.0
        typed = read_all(keyboard.slave)
        assert set(typed) == {ord("j")} and 5 <= len(typed) <= 30
        calls = []
        keyboard.hold("i", 5.0, delay=0.05, until=lambda: calls.append(1) or len(calls) > 3)
        assert read_all(keyboard.slave) == b"iiii"


def test_close_is_idempotent():
    keyboard = PtyKeyboard()
    keyboard.close()
    keyboard.close()
    assert keyboard.master is None and keyboard.slave is None
