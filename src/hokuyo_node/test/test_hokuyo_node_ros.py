"""hokuyo_node against the URG-04LX emulator over a real pseudo-terminal, on a private master."""

import math
import threading
from pathlib import Path

import numpy as np
import pytest
from hokuyo_node.urg_emulator import STEPS, UrgEmulator

from florence_common.processes import ManagedProcess, pid_alive, wait_for
from florence_common.pty_device import PtyDevice

pytestmark = pytest.mark.protocol


NODE = Path(__file__).resolve().parents[1] / "nodes" / "hokuyo_node"
NS = "/hokuyo_test"
PATTERN = [5 if i % 37 == 0 else 300 + 7 * i for i in range(STEPS)]  # [mm]; every 37th step an error code


class Laser:
    def __init__(self, rospy, link):
        from diagnostic_msgs.msg import DiagnosticArray
        from sensor_msgs.msg import LaserScan

        self.link = link
        self.emulator = UrgEmulator(ranges=lambda _now: PATTERN)
        self.device = PtyDevice(self.emulator, link=link).start()
        self.lock = threading.Lock()
        self.scans = []
        self.received = []
        self.diags = {}
        self.subs = [rospy.Subscriber(f"{NS}/scan", LaserScan, self._on_scan),
                     rospy.Subscriber("/diagnostics", DiagnosticArray, self._on_diag)]

    def _on_scan(self, msg):
        import rospy

        received = rospy.Time.now()  # to judge the stamp by, whatever the test process's own delays
        with self.lock:
            self.scans.append(msg)
            self.received.append(received)

    def _on_diag(self, msg):
        for status in msg.status:
            if status.name.startswith(f"{NS[1:]}/hokuyo_node: "):
                with self.lock:
                    self.diags[status.name.split(": ", 1)[1]] = (
                        status.level, status.message, {v.key: v.value for v in status.values})

    def count(self):
        with self.lock:
            return len(self.scans)

    def diag(self, name):
        with self.lock:
            return self.diags.get(name, (None, "", {}))

    def close(self):
        for sub in self.subs:
            sub.unregister()
        self.device.close()


def start_node(ros_master, link, *params, ns=NS):
    return ManagedProcess(["/usr/bin/python3", str(NODE), "__name:=hokuyo_node", f"__ns:={ns}", f"_port:={link}",
                           "_frame_id:=base_laser_link", "_min_ang:=-1.570", "_max_ang:=1.570",
                           "_reconnect_interval:=0.2", *params], env=ros_master.env(), name="hokuyo_node")


@pytest.fixture(scope="module")
def laser(ros_master, rospy_node, tmp_path_factory):
    link = str(tmp_path_factory.mktemp("urg") / "ttyACM")
    laser = Laser(rospy_node, link)
    laser.proc = start_node(ros_master, link, "_calibrate_time:=true", "_intensity:=true")
    try:
        wait_for(lambda: laser.count() > 2, 30.0, what="scans from hokuyo_node")
        yield laser
    except Exception:
        print(laser.proc.output())
        raise
    finally:
        if not laser.proc.running():
            print(laser.proc.output())
        laser.proc.stop()
        laser.close()


def test_scan_decodes_exactly_in_sensor_order(laser):
    with laser.lock:
        scan, received = laser.scans[-1], laser.received[-1]
    resolution = 2 * math.pi / 1024
    first, last = 129, 639  # -1.570 and 1.570 rad rounded inwards to steps (front step 384)
    assert scan.header.frame_id == "base_laser_link"
    assert len(scan.ranges) == last - first + 1
    assert scan.angle_min == pytest.approx((first - 384) * resolution, abs=1e-6)
    assert scan.angle_max == pytest.approx((last - 384) * resolution, abs=1e-6)
    assert scan.angle_increment == pytest.approx(resolution, abs=1e-7)
    assert scan.time_increment == pytest.approx(0.1 / 1024, rel=1e-5)
    assert scan.scan_time == pytest.approx(0.1)
    assert (scan.range_min, scan.range_max) == (pytest.approx(0.02), pytest.approx(5.6))
    # Ranges in the sensor's own order (the inversion is tf's business), error codes as no return.
    expected = [math.inf if v < 20 else float(np.float32(v / 1000.0)) for v in PATTERN[first : last + 1]]
    assert list(scan.ranges) == expected
    assert math.inf in expected
    # Time stamps from the calibrated sensor clock: at most a few scans before the message arrived.
    age = (received - scan.header.stamp).to_sec()
    assert -0.05 < age < 0.5


def test_intensity_is_refused_on_the_urg_04lx(laser):
    with laser.lock:
        scan = laser.scans[-1]
    assert list(scan.intensities) == []
    assert "refused" in laser.proc.output() and "URG-04LX" in laser.proc.output()
    wait_for(lambda: laser.diag("Connection")[0] == 1, 5.0, what="intensity warning in diagnostics")


def test_self_test_service(laser):
    import rospy
    from diagnostic_msgs.srv import SelfTest

    rospy.wait_for_service(f"{NS}/hokuyo_node/self_test", 10.0)
    result = rospy.ServiceProxy(f"{NS}/hokuyo_node/self_test", SelfTest)()
    assert result.id == "H0000001"
    assert result.passed == 1, [(s.name, s.message) for s in result.status]
    assert [s.name for s in result.status] == ["Version (VV)", "Parameters (PP)", "State (II)", "Laser on (BM)",
                                               "Single scan (GD)", "Laser off (QT)"]
    assert any(c.startswith(b"GD") for c in laser.emulator.commands)
    before = laser.count()
    wait_for(lambda: laser.count() > before + 3, 10.0, what="scanning again after the self test")


def test_damaged_replies_are_counted_and_survived(laser):
    def errors(kind):
        return int(laser.diag("Errors")[2].get(f"{kind} errors", 0))

    laser.emulator.faults.append("checksum")  # one data block with a wrong sum
    wait_for(lambda: errors("checksum") >= 1, 10.0, what="checksum error counted")
    damaged = errors("checksum") + errors("format")
    laser.emulator.faults.append("truncate")  # a scan cut in half runs into the next one
    wait_for(lambda: errors("checksum") + errors("format") > damaged, 10.0, what="partial scan counted")
    laser.emulator.faults.append("status")  # status 50: hardware trouble
    wait_for(lambda: errors("status") >= 1, 10.0, what="status error counted")
    formats = errors("format")
    laser.device.inject(b"\x00garbage\n")  # line noise ahead of a scan
    wait_for(lambda: errors("format") > formats, 10.0, what="garbage counted")
    assert laser.diag("Errors")[0] in (0, 1)
    before = laser.count()
    wait_for(lambda: laser.count() > before + 3, 10.0, what="scans after the damage")
    assert pid_alive(laser.proc.pid)


def test_port_loss_and_return(laser):
    laser.device.close()
    wait_for(lambda: laser.diag("Connection")[0] == 2, 10.0, what="not connected in diagnostics")
    laser.emulator = UrgEmulator(ranges=lambda _now: PATTERN)
    laser.device = PtyDevice(laser.emulator, link=laser.link).start()
    wait_for(lambda: int(laser.diag("Connection")[2].get("Connects", 0)) >= 2, 15.0, what="reconnect")
    before = laser.count()
    wait_for(lambda: laser.count() > before + 3, 10.0, what="scans after the reconnect")
    assert pid_alive(laser.proc.pid)


def test_uncalibrated_stamps_follow_arrival_plus_time_offset(ros_master, rospy_node, tmp_path):
    from sensor_msgs.msg import LaserScan

    link = str(tmp_path / "ttyACM")
    ages = []
    device = PtyDevice(UrgEmulator(ranges=lambda _now: PATTERN), link=link).start()
    sub = rospy_node.Subscriber("/hokuyo_offset/scan", LaserScan,
                                lambda msg: ages.append((rospy_node.Time.now() - msg.header.stamp).to_sec()))
    proc = start_node(ros_master, link, "_calibrate_time:=false", "_time_offset:=-2.0", ns="/hokuyo_offset")
    try:
        wait_for(lambda: len(ages) >= 3, 30.0, what="scans with a time offset")
        assert min(ages[-3:]) >= 2.0 and max(ages[-3:]) < 2.5  # stamped 2 s before arrival
    except Exception:
        print(proc.output())
        raise
    finally:
        sub.unregister()
        proc.stop()
        device.close()
