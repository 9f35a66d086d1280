"""urg_emulator: an emulated Hokuyo URG-04LX on a pseudo-terminal, for the real hokuyo_node.

Ranges come from the latest ~ranges message (a simulator publishes what the
sensor would see), else from a fixed pattern. Point hokuyo_node's ~port at
~link (or at the printed pty).

ROS Parameters: PARAMS below (rendered in the README).

ROS Subscribers:
    ~ranges (std_msgs/Float32MultiArray): ranges [m] of the sensor's steps 0..768 in step order
        (counter-clockwise); values below 0.02 m become error code 1, beyond 5.6 m "no return" (error 0).

Also sets ~pty (str) to the pseudo-terminal's path and prints it.
"""

import threading

import rospy
from std_msgs.msg import Float32MultiArray

from florence_common.params import Param, ParamTable
from florence_common.pty_device import PtyDevice
from florence_common_ros.node import read_params, run
from hokuyo_node import scip_spec as spec
from hokuyo_node.urg_emulator import STEPS, UrgEmulator

PARAMS = ParamTable(
    Param("link", str, "", 'symlink made to point at the pty (e.g. /tmp/hokuyo); "" for none'),
    Param("serial_number", str, "H0000001", "answered in VV's SERI line"),
    Param("default_range", float, 2.0, "range of every step until ~ranges arrives", unit="m", ge=0.02, le=5.6),
)


class UrgEmulatorNode:
    def __init__(self):
        p = read_params(PARAMS)
        self.lock = threading.Lock()
        self.values = [int(p.default_range * 1000)] * STEPS  # [mm]
        self.core = UrgEmulator(ranges=self._ranges, serial_number=p.serial_number)
        self.device = PtyDevice(self.core, link=p.link or None).start()
        rospy.set_param("~pty", self.device.path)
        print(f"urg_emulator: serving on {self.device.port}", flush=True)
        rospy.Subscriber("~ranges", Float32MultiArray, self._on_ranges, queue_size=1)

    def shutdown(self):
        self.device.close()

    def _ranges(self, _now):
        with self.lock:
            return self.values

    def _on_ranges(self, msg):
        if len(msg.data) != STEPS:
            rospy.logwarn_throttle(5.0, f"urg_emulator: ~ranges needs {STEPS} values, got {len(msg.data)}")
            return
        dmin, dmax = spec.URG_04LX["DMIN"], spec.URG_04LX["DMAX"]
        values = []
        for r in msg.data:
            mm = r * 1000.0
            values.append(0 if not mm <= dmax else 1 if mm < dmin else round(mm))
        with self.lock:
            self.values = values


def main():
    run(UrgEmulatorNode, "urg_emulator")
