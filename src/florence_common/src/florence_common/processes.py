"""Processes for tests, the demo and benchmarks: a private ROS master, roslaunch runs.

Nothing here imports rospy, so it can be used before any node exists.

Rules it enforces (DEVELOPERS.md):
- never the default master port: every :class:`RosMaster` binds a free port;
- every child runs in its own process group and is stopped through that group
  (SIGINT, then SIGTERM, then SIGKILL), never by name;
- waits are on conditions with a deadline, not fixed sleeps.
"""

import contextlib
import logging
import os
import signal
import socket
import subprocess
import tempfile
import time
import xmlrpc.client

log = logging.getLogger(__name__)

class ProcessError(RuntimeError):
    """A process did not start, or a condition did not come true in time."""


def free_port():
    """Return a TCP port on 127.0.0.1 that was free at the time of the call."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def pid_alive(pid):
    """True while process ``pid`` runs; a zombie (exited, not yet reaped) counts as gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def descendant_pids(pid):
    """PIDs of every living descendant of process ``pid`` (children, their children, ...), from /proc."""
    parents = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
        except (OSError, IndexError, ValueError):
            continue  # gone meanwhile
        parents.setdefault(ppid, []).append(int(entry))
    found, todo = [], [pid]
    while todo:
        for child in parents.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def wait_for(predicate, timeout, interval=0.05, what="condition"):
    """Poll ``predicate()`` until it returns a truthy value; return that value.

    Raises :class:`ProcessError` naming ``what`` once ``timeout`` [s] of wall time
    has passed. Exceptions from the predicate count as "not yet".
    """
    deadline = time.monotonic() + timeout
    last_error = None
    while True:
        try:
            value = predicate()
            if value:
                return value
        except Exception as exc:  # noqa: BLE001 - a failing probe means "not yet"
            last_error = exc
        if time.monotonic() >= deadline:
            detail = f" (last error: {last_error!r})" if last_error else ""
            raise ProcessError(f"timed out after {timeout:.1f} s waiting for {what}{detail}")
        time.sleep(interval)


class ManagedProcess:
    """A child process in its own process group, with its output in a log file. Its standard input
    is /dev/null unless ``stdin`` (a file descriptor or file, e.g. a pseudo-terminal's slave side
    for a program that reads a keyboard) is given."""

    def __init__(self, argv, env=None, log_path=None, name=None, stdin=subprocess.DEVNULL):
        self.argv = list(argv)
        self.name = name or os.path.basename(self.argv[0])
        if log_path is None:
            fd, log_path = tempfile.mkstemp(prefix=f"{self.name.replace('/', '_').replace(' ', '_')}-", suffix=".log")
            os.close(fd)
        self.log_path = log_path
        self._log = open(self.log_path, "wb")  # noqa: SIM115 - closed in stop()
        env = dict(os.environ if env is None else env)
        env.setdefault("PYTHONUNBUFFERED", "1")  # what a child prints reaches its log at once
        self.proc = subprocess.Popen(
            self.argv,
            env=env,
            stdin=stdin,
            stdout=self._log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        log.debug("started %s (pid %d): %s", self.name, self.proc.pid, " ".join(self.argv))

    @property
    def pid(self):
        return self.proc.pid

    def running(self):
        return self.proc.poll() is None

    def output(self, tail_bytes=20000):
        """The last ``tail_bytes`` of what the process printed (also after stop())."""
        if not self._log.closed:
            self._log.flush()
        try:
            with open(self.log_path, "rb") as f:
                f.seek(0, os.SEEK_END)
                size = f.tell()
                f.seek(max(0, size - tail_bytes))
                return f.read().decode("utf-8", "replace")
        except OSError:
            return ""

    def stop(self, timeout=10.0):
        """Stop the whole process group: SIGINT, then SIGTERM, then SIGKILL; then SIGKILL every
        descendant still alive. roslaunch starts each node in a session of its own, so a node that
        does not end on roslaunch's SIGINT (busy in C code at start-up, say) would outlive a
        roslaunch killed before its own escalation finished."""
        descendants = descendant_pids(self.proc.pid) if self.proc.poll() is None else []
        try:
            for sig, wait in ((signal.SIGINT, timeout), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
                if self.proc.poll() is not None:
                    break
                try:
                    os.killpg(self.proc.pid, sig)
                except ProcessLookupError:
                    break
                try:
                    self.proc.wait(wait)
                except subprocess.TimeoutExpired:
                    continue
            # The leader may be gone while children of its group linger.
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.killpg(self.proc.pid, signal.SIGKILL)
            for pid in descendants:
                if pid_alive(pid):
                    log.warning("%s: descendant %d outlived it, killing it", self.name, pid)
                    with contextlib.suppress(ProcessLookupError, PermissionError):
                        os.kill(pid, signal.SIGKILL)
        finally:
            self._log.close()
        return self.proc.returncode


class RosMaster:
    """A private ``rosmaster`` on a free port, with its own ROS_HOME for logs."""

    def __init__(self, port=None, ros_home=None):
        self.port = port or free_port()
        self.uri = f"http://127.0.0.1:{self.port}/"
        self.ros_home = ros_home or tempfile.mkdtemp(prefix="florence-ros-")
        self.process = None

    def env(self, base=None, **extra):
        """Environment for a child process that should use this master."""
        env = dict(os.environ if base is None else base)
        env.update(
            ROS_MASTER_URI=self.uri,
            ROS_HOSTNAME="127.0.0.1",
            ROS_HOME=self.ros_home,
            ROS_LOG_DIR=os.path.join(self.ros_home, "log"),
            ROS_PYTHON_VERSION="3",
        )
        env.pop("ROS_IP", None)
        env.update({k: str(v) for k, v in extra.items()})
        return env

    def start(self, timeout=30.0):
        self.process = ManagedProcess(
            ["rosmaster", "--core", "-p", str(self.port), "-w", "3"],
            env=self.env(),
            log_path=os.path.join(self.ros_home, "rosmaster.log"),
            name="rosmaster",
        )
        try:
            wait_for(self.is_up, timeout, what=f"rosmaster on port {self.port}")
        except ProcessError:
            out = self.process.output()
            self.stop()
            raise ProcessError(f"rosmaster did not come up on port {self.port}:\n{out}") from None
        return self

    def is_up(self):
        if self.process is not None and not self.process.running():
            raise ProcessError("rosmaster exited")
        proxy = xmlrpc.client.ServerProxy(self.uri)
        code, _, _ = proxy.getPid("/florence_common_processes")
        return code == 1

    def stop(self):
        if self.process is not None:
            self.process.stop()
            self.process = None


def roslaunch(master, package, launch_file, *args, log_path=None, env=None):
    """Start ``roslaunch package launch_file args...`` against ``master``.

    Returns a :class:`ManagedProcess`; the caller stops it. ``args`` are
    ``name:=value`` strings.
    """
    # No --wait: the master is up already, and with --wait roslaunch 1.15 can spin forever.
    argv = ["roslaunch", "--disable-title", package, launch_file, *args]
    return ManagedProcess(
        argv,
        env=master.env(env),
        log_path=log_path or os.path.join(master.ros_home, f"roslaunch-{package}-{launch_file}.log"),
        name=f"roslaunch {package}/{launch_file}",
    )


def rosrun(master, package, executable, *args, env=None):
    """Start ``rosrun package executable args...`` against ``master``; the caller stops it."""
    return ManagedProcess(["rosrun", package, executable, *args], env=master.env(env), name=executable)


def stop_all(*procs):
    """Stop ``procs`` in reverse start order, printing the output of any that had already
    exited (the usual reason a test failed)."""
    for proc in reversed(procs):
        if not proc.running():
            print(f"----- {proc.name} exited early -----\n{proc.output()}")
        proc.stop()
