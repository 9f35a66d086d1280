"""The node's side of the libfreenect worker (ROS-free): start it, read its records, notice when
the device is lost, say why, start it again.

    link = KinectLink("camera", library, on_record=handle, on_event=report)
    link.start()          # a thread: connect, stream, reconnect
    link.send("tilt 10")  # motor commands
    link.stop()

``on_record(record)`` runs in the reading thread for every frame (:class:`Record`), in order;
``on_event(kind, text)`` for "connected", "lost" (the reason), "warning" (a damaged dump) and
"message" (what the worker or libfreenect printed).
"""

import collections
import contextlib
import fcntl
import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass

from openni_camera import fakenect_dump, freenect, kinect, usb, worker

F_SETPIPE_SZ = 1031  # fcntl.F_SETPIPE_SZ (Linux), not in Python 3.11's fcntl on every build
PIPE_BYTES = 1 << 20  # room for a whole colour frame in the pipe
START_TIMEOUT = 15.0  # [s] from starting the worker to its device information
MAX_RETRY_WAIT = 10.0  # [s] the longest wait between two attempts that start a worker
CAMERA_PRODUCTS = (kinect.PRODUCT_CAMERA, kinect.PRODUCT_K4W_CAMERA)


@dataclass
class Record:
    kind: bytes  # worker.DEPTH, VIDEO, TILT, INFO, EVENT
    timestamp: int  # the device's frame counter
    host_time: float  # [s] CLOCK_MONOTONIC when the worker had the frame
    dropped: int  # frames the worker dropped so far (the node was not ready for them)
    payload: bytearray


def _read_exact(stream, buffer):
    view, got = memoryview(buffer), 0
    while got < len(buffer):
        n = stream.readinto(view[got:])
        if not n:
            return False
        got += n
    return True


class WorkerProcess:
    """One run of ``python3 -m openni_camera.worker``."""

    def __init__(self, mode, library, device, rate, env, on_record, on_line):
        read_fd, write_fd = os.pipe()
        with contextlib.suppress(OSError):
            fcntl.fcntl(write_fd, F_SETPIPE_SZ, PIPE_BYTES)
        argv = [sys.executable, "-m", "openni_camera.worker", mode, "--library", library, "--device", device,
                "--rate", str(rate), "--fd", str(write_fd)]
        try:
            self.proc = subprocess.Popen(argv, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                         stderr=subprocess.STDOUT, pass_fds=(write_fd,))
        finally:
            os.close(write_fd)
        self.data = os.fdopen(read_fd, "rb", buffering=0)
        self.on_record, self.on_line = on_record, on_line
        self.lines = collections.deque(maxlen=12)
        self.last_record = None  # [s] monotonic
        self.info = None
        self.records_done = threading.Event()
        self.info_ready = threading.Event()
        self._threads = [threading.Thread(target=self._read_records, name="kinect-records", daemon=True),
                         threading.Thread(target=self._read_lines, name="kinect-output", daemon=True)]
        for t in self._threads:
            t.start()

    def _read_records(self):
        header = bytearray(worker.HEADER.size)
        try:
            while _read_exact(self.data, header):
                kind, timestamp, host_time, dropped, size = worker.HEADER.unpack(header)
                payload = bytearray(size)
                if not _read_exact(self.data, payload):
                    break
                self.last_record = time.monotonic()
                if kind == worker.INFO:
                    self.info = json.loads(payload)
                    self.info_ready.set()
                self.on_record(Record(kind, timestamp, host_time, dropped, payload))
                self.last_record = time.monotonic()  # the time spent on the record is not the device's silence
        except (OSError, ValueError):
            pass
        finally:
            self.records_done.set()

    def _read_lines(self):
        for raw in self.proc.stdout:
            line = raw.decode("utf-8", "replace").rstrip()
            if line:
                self.lines.append(line)
                self.on_line(line)

    def running(self):
        return self.proc.poll() is None

    def send(self, line):
        try:
            self.proc.stdin.write(line.encode() + b"\n")
            self.proc.stdin.flush()
            return True
        except (OSError, ValueError):
            return False

    def stop(self, timeout=3.0):
        """Ask the worker to quit, then terminate it, then kill it; returns its exit status."""
        if self.running():
            self.send("quit")
        with contextlib.suppress(OSError, ValueError):
            self.proc.stdin.close()
        for action in (None, self.proc.terminate, self.proc.kill):
            if action is not None and self.running():
                with contextlib.suppress(OSError):
                    action()
            try:
                self.proc.wait(timeout)
                break
            except subprocess.TimeoutExpired:
                continue
        self.records_done.wait(timeout)
        for t in self._threads:
            t.join(timeout)
        with contextlib.suppress(OSError):
            self.data.close()
        return self.proc.returncode

    def reason(self):
        """Why it ended: the exit status's meaning and the last thing the worker said."""
        status = self.proc.returncode
        said = " | ".join(list(self.lines)[-3:])
        what = worker.REASONS.get(status, f"worker ended with status {status}")
        return f"{what}: {said}" if said else what


class KinectLink:
    """Keeps one Kinect subdevice ("camera" or "motor") streaming through a worker process.

    ``library``: libfreenect's file or name (fakenect's replays FAKENECT_PATH, which is checked
    first, and played without the records that would stop it: see fakenect_dump.replayable).
    ``frame_timeout`` [s]: no record for this long once streaming means the device is lost.
    """

    def __init__(self, mode, library=freenect.DEFAULT_LIBRARY, device="#1", rate=10.0, reconnect_interval=1.0,
                 frame_timeout=2.0, on_record=None, on_event=None, environ=None, sysfs=usb.SYSFS):
        if mode not in ("camera", "motor"):
            raise ValueError(f"mode must be camera or motor, got {mode!r}")
        self.mode, self.library, self.device, self.rate = mode, library, device, float(rate)
        self.reconnect_interval, self.frame_timeout = float(reconnect_interval), float(frame_timeout)
        self.on_record = on_record or (lambda record: None)
        self.on_event = on_event or (lambda kind, text: None)
        self.environ = dict(os.environ if environ is None else environ)
        self.sysfs = sysfs
        lib = freenect.load(library)  # OSError / FreenectError: a configuration error, the node stops
        self.fake = freenect.is_fakenect(lib)
        self.library_file = freenect.library_path(lib)
        if self.fake and not self.environ.get("FAKENECT_PATH"):
            raise ValueError(f"{self.library_file} is fakenect's replay library, but FAKENECT_PATH (the dump to "
                             "replay) is not set")
        self.scratch = tempfile.mkdtemp(prefix=f"kinect-{mode}-")
        self.connected = False
        self.connects = 0
        self.reason = "not connected yet"
        self.info = {}
        self.dump_check = None
        self.worker = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._run, name=f"kinect-{mode}", daemon=True)

    def start(self):
        self._thread.start()
        return self

    def send(self, line):
        """A command for the worker ("tilt 10", "led 2"); False when none is running."""
        with self._lock:
            w = self.worker
        return w is not None and w.running() and w.send(line)

    # --- the loop ----------------------------------------------------------------------------------------------------
    def _run(self):
        failures = 0
        while not self._stop.is_set():
            reason, streamed = self._session()
            if self._stop.is_set():
                break
            self.connected = False
            self.reason = reason
            self.on_event("lost", reason)
            failures = 0 if streamed else failures + 1
            wait = self.reconnect_interval if failures <= 1 else min(MAX_RETRY_WAIT, self.reconnect_interval * failures)
            self._stop.wait(wait)

    def _environment(self):
        """(environment for the worker, None) or (None, why no worker can start now)."""
        env = dict(self.environ)
        if self.fake:
            try:
                folder, result = fakenect_dump.replayable(env["FAKENECT_PATH"], os.path.join(self.scratch, "dump"))
            except fakenect_dump.DumpError as exc:
                return None, f"fakenect dump: {exc}"
            if result.problems and (self.dump_check is None or self.dump_check.problems != result.problems):
                shown = "; ".join(result.problems[:5]) + (" ..." if len(result.problems) > 5 else "")
                self.on_event("warning", f"fakenect dump {env['FAKENECT_PATH']}: {len(result.problems)} of "
                                         f"{len(result.problems) + len(result.good)} records left out ({shown})")
            self.dump_check = result
            env["FAKENECT_PATH"] = folder
        else:
            # with a USB device list to look at, start no worker while the device is not even there
            devices = usb.find_kinects(self.sysfs)
            wanted = CAMERA_PRODUCTS if self.mode == "camera" else (kinect.PRODUCT_MOTOR,)
            if devices is not None and not any(d["product"] in wanted for d in devices):
                return None, usb.diagnose(self.mode, self.sysfs)
        return env, None

    def _session(self):
        """One worker's life: (reason it ended, whether it streamed)."""
        env, why = self._environment()
        if env is None:
            return why, False
        w = WorkerProcess(self.mode, self.library, self.device, self.rate, env, self.on_record,
                          lambda line: self.on_event("message", line))
        with self._lock:
            self.worker = w
        streamed = False
        try:
            deadline = time.monotonic() + START_TIMEOUT
            while not w.info_ready.is_set() and w.running() and not self._stop.is_set():
                if time.monotonic() > deadline:
                    return f"libfreenect did not open the {self.mode} within {START_TIMEOUT:.0f} s", False
                w.info_ready.wait(0.05)
            if w.info_ready.is_set() and w.running():
                self.info = w.info
                self.connected, streamed = True, True
                self.connects += 1
                self.on_event("connected", self._describe(w.info))
                timeout = max(self.frame_timeout, 3.0 / self.rate) if self.mode == "motor" else self.frame_timeout
                start = time.monotonic()
                while w.running() and not self._stop.is_set():
                    last = w.last_record or start
                    if time.monotonic() - last > timeout:
                        return f"no data from the {self.mode} for {timeout:.1f} s (unplugged, or the USB stalled)", True
                    self._stop.wait(0.05)
            w.records_done.wait(2.0)
        finally:
            w.stop()
            with self._lock:
                self.worker = None
        reason = w.reason()
        if not self.fake and w.proc.returncode in (worker.EXIT_NO_DEVICE, worker.EXIT_OPEN, worker.EXIT_LOST):
            why = usb.diagnose(self.mode, self.sysfs)
            if why:
                reason = f"{reason} ({why})"
        return reason, streamed

    def _describe(self, info):
        source = (f"fakenect replaying {self.environ.get('FAKENECT_PATH')}" if self.fake else
                  f"Kinect {info.get('serial') or self.device} ({info.get('devices')} on USB)")
        return f"{self.mode} of {source} through {info.get('library', self.library_file)}"

    def stop(self):
        self._stop.set()
        with self._lock:
            w = self.worker
        if w is not None:
            w.stop()
        if self._thread.is_alive():
            self._thread.join(5.0)
        shutil.rmtree(self.scratch, ignore_errors=True)
