"""KeyReader on a real pseudo-terminal: single keys without Enter, the terminal restored however the
block ends, a closed terminal and a missing one reported."""

import contextlib
import os
import pty
import termios

import pytest
from turtlebot_teleop.terminal import KeyReader, NoTerminal, TerminalClosed

pytestmark = pytest.mark.protocol


class Fd:
    def __init__(self, fd):
        self.fd = fd

    def fileno(self):
        return self.fd


@pytest.fixture
def terminal():
    master, slave = pty.openpty()
    yield master, slave
    for fd in (master, slave):
        with contextlib.suppress(OSError):
            os.close(fd)


def test_keys_one_by_one_without_enter(terminal):
    master, slave = terminal
    before = termios.tcgetattr(slave)
    with KeyReader(Fd(slave)) as keys:
        lflag = termios.tcgetattr(slave)[3]
        assert not lflag & termios.ICANON and not lflag & termios.ECHO and lflag & termios.ISIG
        assert keys.read(0.05) is None
        os.write(master, b"ik ")
        assert [keys.read(1.0), keys.read(1.0), keys.read(1.0)] == ["i", "k", " "]
    assert termios.tcgetattr(slave) == before


def test_restored_after_an_exception(terminal):
    _, slave = terminal
    before = termios.tcgetattr(slave)
    with pytest.raises(ZeroDivisionError), KeyReader(Fd(slave)):
        1 / 0  # noqa: B018
    assert termios.tcgetattr(slave) == before


def test_closed_terminal(terminal):
    master, slave = terminal
    with KeyReader(Fd(slave)) as keys:
        os.close(master)
        with pytest.raises(TerminalClosed):
            keys.read(1.0)


def test_no_terminal():
    r, w = os.pipe()
    try:
        with pytest.raises(NoTerminal, match="not a terminal"):
            KeyReader(Fd(r))
    finally:
        os.close(r)
        os.close(w)
    with pytest.raises(NoTerminal, match="cannot be read"):
        KeyReader(object())
