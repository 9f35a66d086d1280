"""The harness keeps its promises: private master on a free port, whole process groups stopped."""

import socket
import sys
import time

import pytest

from florence_common.processes import ManagedProcess, ProcessError, RosMaster, free_port, pid_alive, wait_for

pytestmark = pytest.mark.ros


def test_free_port_is_bindable_and_not_the_default():
    port = free_port()
    assert port != 11311
    with socket.socket() as s:
        s.bind(("127.0.0.1", port))


def test_wait_for_returns_value_and_times_out():
    t0 = time.monotonic()
    assert wait_for(lambda: time.monotonic() - t0 > 0.1 and "done", 5.0) == "done"
    with pytest.raises(ProcessError, match="the impossible"):
        wait_for(lambda: False, 0.2, what="the impossible")


def test_stop_kills_the_whole_process_group(tmp_path):
    """A child that ignores SIGINT and a grandchild both end: stop() escalates and works on the group."""
    pidfile = tmp_path / "grandchild.pid"
    script = (
        "import signal, subprocess, sys, time\n"
        "signal.signal(signal.SIGINT, signal.SIG_IGN)\n"
        f"p = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(600)'])\n"
        f"open({str(pidfile)!r}, 'w').write(str(p.pid))\n"
        "time.sleep(600)\n"
    )
    proc = ManagedProcess([sys.executable, "-c", script], name="stubborn")
    grandchild = int(wait_for(lambda: pidfile.exists() and pidfile.read_text(), 10.0, what="grandchild pid"))
    assert pid_alive(grandchild)
    proc.stop(timeout=0.5)
    assert not proc.running()
    wait_for(lambda: not pid_alive(grandchild), 5.0, what="grandchild gone")


def test_private_master_answers_and_stops():
    master = RosMaster().start()
    try:
        assert master.port != 11311
        assert master.is_up()
        assert master.env()["ROS_MASTER_URI"] == master.uri
    finally:
        master.stop()
    with pytest.raises(Exception):  # noqa: B017 - any connection error
        master.is_up()


def test_child_output_reaches_the_log_while_it_runs(monkeypatch):
    """Regression: a Python child blocked after printing must not keep the line in its buffer."""
    monkeypatch.delenv("PYTHONUNBUFFERED", raising=False)
    proc = ManagedProcess([sys.executable, "-c", "import time; print('ready'); time.sleep(600)"], name="printer")
    try:
        wait_for(lambda: "ready" in proc.output(), 10.0, what="the child's line in its log")
    finally:
        proc.stop()


def test_stop_kills_a_descendant_in_its_own_session_that_ignores_signals(tmp_path):
    """roslaunch starts each node with setsid: out of the launch's process group. A node that
    ignores SIGINT and SIGTERM must not outlive stop() (seen: a demo stopped during start-up)."""
    pid_file = tmp_path / "child.pid"
    child = (
        "import os, signal, time; signal.signal(signal.SIGINT, signal.SIG_IGN); "
        "signal.signal(signal.SIGTERM, signal.SIG_IGN); os.setsid(); "
        f"open({str(pid_file)!r}, 'w').write(str(os.getpid())); time.sleep(600)"
    )
    parent = f"import subprocess, sys, time; subprocess.Popen([sys.executable, '-c', {child!r}]); time.sleep(600)"
    proc = ManagedProcess([sys.executable, "-c", parent], name="parent")
    try:
        wait_for(lambda: pid_file.exists() and pid_file.read_text(), 20, what="the child's pid")
        child_pid = int(pid_file.read_text())
        assert pid_alive(child_pid)
        proc.stop(timeout=1.0)
        wait_for(lambda: not pid_alive(child_pid), 10, what="the child gone")
    finally:
        proc.stop()


def test_child_reads_the_stdin_it_is_given():
    """A keyboard program gets a pseudo-terminal as standard input (turtlebot_teleop_key's tests)."""
    import os
    import pty

    master, slave = pty.openpty()
    script = "import os, sys; print('tty' if os.isatty(0) else 'no tty', sys.stdin.readline().strip(), flush=True)"
    proc = ManagedProcess([sys.executable, "-c", script], name="reader", stdin=slave)
    try:
        os.write(master, b"hello\n")
        wait_for(lambda: "tty hello" in proc.output(), 10.0, what="the line typed on the pty")
    finally:
        proc.stop()
        os.close(master)
        os.close(slave)
    plain = ManagedProcess([sys.executable, "-c", script], name="reader")
    try:
        wait_for(lambda: "no tty" in plain.output(), 10.0, what="/dev/null as stdin")
    finally:
        plain.stop()
