"""Serve an emulated serial device on a pseudo-terminal.

A device *core* is any object with two methods, both taking the time ``now``
[s, time.monotonic()] and returning the bytes the device sends back:

- ``feed(data, now)``: bytes the host wrote to the port;
- ``poll(now)``: called every ``tick`` seconds (periodic output such as a sensor
  stream or a laser scan).

:class:`PtyDevice` opens a pty pair in raw mode, keeps the slave side open (so
the master never sees EIO while no host is connected), and optionally points a
stable symlink at the slave (``/dev/pts/N`` changes from run to run, a driver's
``~port`` parameter should not). Like a real serial line without flow control,
output nobody reads is buffered up to ``max_pending`` bytes and then dropped
(counted in ``dropped_bytes``). Closing the device makes the host's reads fail,
which is how tests unplug a device; a new PtyDevice on the same link plugs it
back in.

No rospy here: emulator nodes and tests share it.
"""

import contextlib
import logging
import os
import pty
import select
import threading
import time
import tty

log = logging.getLogger(__name__)


class PtyDevice:
    """A device core behind a pseudo-terminal, run by a background thread."""

    def __init__(self, core, link=None, tick=0.002, max_pending=65536):
        self.core = core
        self.link = link  # symlink path to the slave, or None
        self.tick = tick  # [s] poll period
        self.max_pending = max_pending  # [bytes]
        self.dropped_bytes = 0
        self.path = None  # /dev/pts/N once started
        self._master = self._slave = None
        self._pending = bytearray()
        self._inject = bytearray()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = None

    @property
    def port(self):
        """The name a driver should open: the symlink if there is one, else the pty."""
        return self.link or self.path

    def start(self):
        self._master, self._slave = pty.openpty()
        tty.setraw(self._slave)
        tty.setraw(self._master)
        os.set_blocking(self._master, False)
        self.path = os.ttyname(self._slave)
        if self.link:
            tmp = f"{self.link}.{os.getpid()}.tmp"
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            os.symlink(self.path, tmp)
            os.replace(tmp, self.link)
        self._thread = threading.Thread(target=self._run, name=f"pty {self.path}", daemon=True)
        self._thread.start()
        log.info("device serving on %s%s", self.path, f" (link {self.link})" if self.link else "")
        return self

    def inject(self, data):
        """Send raw ``data`` to the host ahead of the core's output (line noise in tests)."""
        with self._lock:
            self._inject += data

    def close(self):
        """Stop serving and close the pty: the host's port goes away."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
        for fd in (self._master, self._slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = None
        if self.link and os.path.islink(self.link) and os.readlink(self.link) == self.path:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.link)

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.close()

    def _queue(self, data):
        if not data:
            return
        self._pending += data
        excess = len(self._pending) - self.max_pending
        if excess > 0:
            del self._pending[:excess]
            self.dropped_bytes += excess

    def _run(self):
        while not self._stop.is_set():
            try:
                readable, _, _ = select.select([self._master], [], [], self.tick)
                now = time.monotonic()
                if readable:
                    try:
                        data = os.read(self._master, 4096)
                    except BlockingIOError:
                        data = b""
                    if data:
                        self._queue(self.core.feed(data, now))
                self._queue(self.core.poll(now))
                with self._lock:
                    if self._inject:
                        self._pending[:0] = self._inject
                        self._inject.clear()
                if self._pending:
                    try:
                        written = os.write(self._master, self._pending)
                        del self._pending[:written]
                    except BlockingIOError:
                        pass
            except OSError as exc:
                if not self._stop.is_set():
                    log.error("pty device %s failed: %s", self.path, exc)
                return
            except Exception:
                log.exception("device core raised; the emulated device keeps running")


class PtyKeyboard:
    """A person at a terminal, for programs that read single keys from one (turtlebot_teleop_key):
    the program gets the slave side of a pseudo-terminal as its standard input (``slave``), and
    keys are typed on the master side as a terminal sends them while a key is held: once, again
    after the terminal's repeat ``delay``, then ``repeat`` times a second."""

    def __init__(self, repeat=30.0):
        self.master, self.slave = pty.openpty()
        self.repeat = repeat  # [1/s] the terminal's autorepeat rate

    def type(self, text):
        os.write(self.master, text.encode())

    def hold(self, key, seconds, delay=0.5, until=None):
        """Hold ``key`` for ``seconds`` [s, wall], or until ``until()`` is true after the first
        ``delay``; returns the time (time.monotonic) of the last character sent."""
        start = time.monotonic()
        self.type(key)
        time.sleep(delay)
        last = time.monotonic()
        while time.monotonic() - start < seconds and not (until and until()):
            self.type(key)
            last = time.monotonic()
            time.sleep(1.0 / self.repeat)
        return last

    def close(self):
        """Close both sides (to the program reading it: the terminal closed)."""
        for fd in (self.master, self.slave):
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self.master = self.slave = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
