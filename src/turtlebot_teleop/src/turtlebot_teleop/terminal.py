"""Single keys from a terminal, without Enter and without echo, and the terminal put back (ROS-free).

    with KeyReader(sys.stdin) as keys:      # NoTerminal when stdin is no terminal
        key = keys.read(timeout=0.1)        # one character, or None; TerminalClosed at hang-up

The terminal goes to cbreak mode (no line editing, no echo; Ctrl-C still raises SIGINT, output
still turns "\\n" into "\\r\\n") and is restored on leaving the ``with`` block, whatever ended it: a
return, Ctrl-C, an exception. A terminal that is gone by then (hang-up) cannot be restored and
needs no restoring: that is ignored.
"""

import contextlib
import errno
import os
import select
import termios
import tty


class NoTerminal(RuntimeError):
    """Standard input is no terminal (a pipe, /dev/null, roslaunch without a terminal)."""


class TerminalClosed(RuntimeError):
    """The terminal went away (hang-up, the window closed, end of input)."""


class KeyReader:
    def __init__(self, stream):
        try:
            self.fd = stream.fileno()
        except (AttributeError, ValueError, OSError) as exc:
            raise NoTerminal(f"standard input cannot be read ({exc})") from None
        if not os.isatty(self.fd):
            raise NoTerminal("standard input is not a terminal")
        self.saved = None
        self.buffer = b""

    def __enter__(self):
        try:
            self.saved = termios.tcgetattr(self.fd)
            tty.setcbreak(self.fd, termios.TCSANOW)
        except termios.error as exc:
            raise NoTerminal(f"cannot set up the terminal ({exc})") from None
        return self

    def __exit__(self, *exc):
        self.restore()
        return False

    def restore(self):
        """Put the terminal back as it was (idempotent; a terminal that is gone is ignored)."""
        if self.saved is not None:
            with contextlib.suppress(termios.error, OSError):
                termios.tcsetattr(self.fd, termios.TCSADRAIN, self.saved)
            self.saved = None

    def read(self, timeout):
        """One character typed within ``timeout`` [s] (>= 0), or None. Raises TerminalClosed."""
        if not self.buffer:
            try:
                ready, _, _ = select.select([self.fd], [], [], max(0.0, timeout))
            except InterruptedError:
                return None  # a signal (Ctrl-C): the caller looks at why
            except (OSError, ValueError) as exc:
                raise TerminalClosed(str(exc)) from None
            if not ready:
                return None
            try:
                data = os.read(self.fd, 64)
            except OSError as exc:
                if exc.errno in (errno.EAGAIN, errno.EINTR):
                    return None
                raise TerminalClosed(os.strerror(exc.errno or 0)) from None
            if not data:
                raise TerminalClosed("end of input")
            self.buffer = data
        char, self.buffer = self.buffer[:1], self.buffer[1:]
        return char.decode("latin-1")
