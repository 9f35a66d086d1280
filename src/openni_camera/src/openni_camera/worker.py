"""The libfreenect worker: one process that owns the library, the device and its event loop.

    /usr/bin/python3 -m openni_camera.worker camera --library libfreenect.so.0.5 --device "#1" --fd 5
    /usr/bin/python3 -m openni_camera.worker motor --library ... --device "#1" --rate 10 --fd 5

Why a process of its own: libfreenect's USB event loop must keep up with the isochronous
transfers (a busy Python node would lose packets); a driver library that crashes or exits
(fakenect calls exit(1) when a file of its dump is missing) takes only the worker with it; and
every reconnect starts from a fresh library state. Standard library only, so it starts fast.

Records go to file descriptor ``--fd`` (a pipe the node reads), each a :data:`HEADER` and its
payload: ``d`` an 11-bit depth frame (640x480 uint16), ``r`` an RGB frame (640x480x3),
``a`` a raw tilt state (12 bytes, freenect_raw_tilt_state), ``i`` the device (JSON), ``e`` an
event (JSON: a command's result, a library message). Frames are handed to a writer thread
that always sends the newest one: the event loop never waits for the node, and frames the
node was too slow for are dropped here (counted in every header).

Commands come as lines on stdin: ``tilt <deg>``, ``led <option>``, ``quit``. The process ends
with one of the ``EXIT_*`` statuses and its reason printed on stdout.
"""

import argparse
import collections
import ctypes
import json
import os
import select
import signal
import struct
import sys
import threading
import time

HEADER = struct.Struct("<cIdII")  # kind, device timestamp, host CLOCK_MONOTONIC [s], frames dropped, payload bytes
DEPTH, VIDEO, TILT, INFO, EVENT = b"d", b"r", b"a", b"i", b"e"

EXIT_OK = 0
EXIT_FAKENECT = 1  # fakenect's own exit(1): a file of the dump missing or unreadable
EXIT_USAGE = 2
EXIT_NO_DEVICE = 3
EXIT_OPEN = 4
EXIT_START = 5
EXIT_LOST = 6
EXIT_LIBRARY = 7
EXIT_BUG = 8  # an exception in this program (its traceback is printed)
REASONS = {EXIT_FAKENECT: "fakenect stopped", EXIT_NO_DEVICE: "no device", EXIT_OPEN: "cannot open the device",
           EXIT_START: "cannot start the streams", EXIT_LOST: "device lost", EXIT_LIBRARY: "cannot load libfreenect",
           EXIT_BUG: "worker failed"}
LOST_AFTER_ERRORS = 10  # consecutive failed event-loop calls (or state reads) that mean the device is gone


def say(text):
    print(text, flush=True)


class Output:
    """The newest frame of each kind and every event, written to the node's pipe by a thread."""

    def __init__(self, fd):
        self.fd = fd
        self.cond = threading.Condition()
        self.latest = {}  # kind -> (timestamp, host time, payload)
        self.events = collections.deque()
        self.dropped = 0
        self.broken = False
        self.thread = threading.Thread(target=self._run, name="output", daemon=True)
        self.thread.start()

    def frame(self, kind, timestamp, payload):
        with self.cond:
            if kind in self.latest:
                self.dropped += 1
            self.latest[kind] = (timestamp, time.monotonic(), payload)
            self.cond.notify()

    def event(self, kind, payload):
        with self.cond:
            self.events.append((kind, payload))
            self.cond.notify()

    def _write(self, kind, timestamp, host_time, payload):
        header = HEADER.pack(kind, timestamp & 0xFFFFFFFF, host_time, self.dropped & 0xFFFFFFFF, len(payload))
        small = len(payload) < 4096  # one write for an event; no copy of a frame
        chunks = [memoryview(header + payload)] if small else [memoryview(header), memoryview(payload)]
        while chunks:
            written = os.writev(self.fd, chunks)
            while chunks and written >= len(chunks[0]):
                written -= len(chunks[0])
                chunks.pop(0)
            if chunks and written:
                chunks[0] = chunks[0][written:]

    def _run(self):
        try:
            while True:
                with self.cond:
                    while not self.latest and not self.events:
                        self.cond.wait()
                    events = list(self.events)
                    self.events.clear()
                    frames = sorted(self.latest.items(), key=lambda item: item[1][1])
                    self.latest.clear()
                for kind, payload in events:
                    self._write(kind, 0, time.monotonic(), json.dumps(payload).encode())
                for kind, (timestamp, host_time, payload) in frames:
                    self._write(kind, timestamp, host_time, payload)
        except OSError:  # the node is gone
            self.broken = True


class Commands:
    """Lines from stdin, read without blocking."""

    def __init__(self):
        self.buffer = b""
        self.closed = False

    def poll(self):
        lines = []
        while not self.closed and select.select([sys.stdin.fileno()], [], [], 0)[0]:
            chunk = os.read(sys.stdin.fileno(), 4096)
            if not chunk:
                self.closed = True
                break
            self.buffer += chunk
        while b"\n" in self.buffer:
            line, self.buffer = self.buffer.split(b"\n", 1)
            lines.append(line.decode("utf-8", "replace").strip())
        return lines


def open_device(fn, subdevice, device, what):
    """Select ``subdevice`` and open ``device`` ("#N": the N-th, or a camera serial); exits with
    EXIT_NO_DEVICE / EXIT_OPEN and the reason."""
    from openni_camera.freenect import FreenectError

    fn.select(subdevice)
    count = fn.num_devices()
    if count == 0:
        say(f"no Kinect found by libfreenect ({what})")
        sys.exit(EXIT_NO_DEVICE)
    serials = fn.serials()
    index, serial = 0, None
    if device.startswith("#"):
        index = int(device[1:]) - 1
        if not 0 <= index < count:
            say(f"device {device} asked for, but libfreenect sees {count} Kinect(s)")
            sys.exit(EXIT_NO_DEVICE)
    else:
        serial = device
        if serials and serial not in serials:
            say(f"no Kinect with serial {serial!r} (connected: {', '.join(serials)})")
            sys.exit(EXIT_NO_DEVICE)
    try:
        fn.open(index, serial)
    except FreenectError as exc:
        say(f"cannot open the Kinect's {what}: {exc}")
        sys.exit(EXIT_OPEN)
    return {"devices": count, "serials": serials, "index": index, "serial": serial or (serials[index] if
                                                                                       index < len(serials) else "")}


def run_camera(fn, out, commands, running):
    from openni_camera.freenect import FreenectError

    def handler(kind):
        def on_frame(pointer, size, timestamp):
            out.frame(kind, timestamp, ctypes.string_at(pointer, size))
        return on_frame

    try:
        modes = fn.start_streams(on_depth=handler(DEPTH), on_video=handler(VIDEO))
    except FreenectError as exc:
        say(f"cannot start the streams: {exc}")
        return EXIT_START
    out.event(EVENT, {"event": "streaming", "modes": {k: [m.width, m.height, m.bytes] for k, m in modes.items()}})
    return loop(fn, out, commands, running, period=None)


def run_motor(fn, out, commands, running, rate):
    return loop(fn, out, commands, running, period=1.0 / rate)


def loop(fn, out, commands, running, period):
    """The event loop; with ``period`` [s] the tilt state is read and sent at that period."""
    from openni_camera.freenect import FreenectError

    errors = 0
    due = time.monotonic()
    while running.is_set() and not out.broken:
        timeout = 0.1 if period is None else max(0.0, min(0.1, due - time.monotonic()))
        result = fn.process_events(timeout)
        if result < 0:
            errors += 1
            if fn.fake:
                say("end of the fakenect dump (fakenect replays it once)")
                return EXIT_LOST
            if errors >= LOST_AFTER_ERRORS:
                say(f"libfreenect's event loop failed {errors} times in a row (last result {result})")
                return EXIT_LOST
        else:
            errors = 0 if period is None else errors
        if period is not None and time.monotonic() >= due:
            try:
                out.frame(TILT, 0, fn.tilt_state())
                errors = 0
            except FreenectError as exc:
                errors += 1
                if errors >= LOST_AFTER_ERRORS:
                    say(f"the motor stopped answering: {exc}")
                    return EXIT_LOST
            due = max(due + period, time.monotonic())
        for line in commands.poll():
            command(fn, out, line)
        if commands.closed:
            break
    return EXIT_OK


def command(fn, out, line):
    from openni_camera.freenect import FreenectError

    word, _, arg = line.partition(" ")
    if word == "quit":
        raise SystemExit(EXIT_OK)
    try:
        if word == "tilt":
            fn.set_tilt(float(arg))
        elif word == "led":
            fn.set_led(int(arg))
        else:
            out.event(EVENT, {"event": "command", "command": line, "ok": False, "error": "unknown command"})
            return
        out.event(EVENT, {"event": "command", "command": line, "ok": True})
    except (FreenectError, ValueError) as exc:
        out.event(EVENT, {"event": "command", "command": line, "ok": False, "error": str(exc)})


def main(argv=None):
    from openni_camera import freenect

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=["camera", "motor"])
    parser.add_argument("--library", default=freenect.DEFAULT_LIBRARY)
    parser.add_argument("--device", default="#1", help='"#N" for the N-th Kinect, or a camera serial')
    parser.add_argument("--rate", type=float, default=10.0, help="motor: tilt state reads per second")
    parser.add_argument("--fd", type=int, required=True, help="file descriptor of the record pipe")
    args = parser.parse_args(argv)

    running = threading.Event()
    running.set()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: running.clear())
    out = Output(args.fd)
    try:
        fn = freenect.Freenect(args.library)
    except (OSError, freenect.FreenectError) as exc:
        say(f"cannot use libfreenect {args.library!r}: {exc}")
        return EXIT_LIBRARY
    if not fn.fake:
        fn.set_log(freenect.LOG_WARNING, lambda level, text: say(f"libfreenect {freenect.LOG_MESSAGES[level]}: {text}"))
    subdevice, what = ((freenect.DEVICE_CAMERA, "camera") if args.mode == "camera" else
                       (freenect.DEVICE_MOTOR, "motor"))
    status = EXIT_OK
    try:
        info = open_device(fn, subdevice, args.device, what)
        info.update(library=freenect.library_path(fn.lib), fakenect=fn.fake, mode=args.mode)
        out.event(INFO, info)
        commands = Commands()
        if args.mode == "camera":
            status = run_camera(fn, out, commands, running)
        else:
            status = run_motor(fn, out, commands, running, args.rate)
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else EXIT_USAGE
    finally:
        if fn.dev and args.mode == "camera":
            fn.stop_streams()
        fn.close()
    # let the writer send what is queued (the node may already be gone: then nothing waits)
    deadline = time.monotonic() + 0.5
    while (out.latest or out.events) and not out.broken and time.monotonic() < deadline:
        time.sleep(0.01)
    return status


def guarded_main(argv=None):
    """main(), with any exception a traceback and EXIT_BUG (a plain exception would exit 1, which
    is fakenect's own status)."""
    try:
        return main(argv)
    except Exception:  # noqa: BLE001 - the node reports the traceback as the reason
        import traceback

        say(traceback.format_exc())
        return EXIT_BUG


if __name__ == "__main__":
    sys.exit(guarded_main())
