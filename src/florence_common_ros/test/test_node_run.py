"""run(): a bad parameter is a fatal log naming it and exit status 1; the node's shutdown()
runs on the way out."""

import sys
import textwrap

import pytest

from florence_common.processes import ManagedProcess, wait_for

pytestmark = pytest.mark.ros

NODE = textwrap.dedent("""
    import rospy
    from florence_common.params import Param, ParamTable
    from florence_common_ros.node import read_params, run

    TABLE = ParamTable(Param("rate", float, 10.0, "rate", unit="Hz", gt=0))

    class Node:
        def __init__(self):
            self.p = read_params(TABLE)
            rospy.loginfo("toy: up at %.1f Hz", self.p.rate)
            # run() registers shutdown() once the constructor returned: say so a moment later
            rospy.Timer(rospy.Duration(0.5), lambda _e: print("toy: spinning", flush=True), oneshot=True)

        def shutdown(self):
            print("toy: shutdown hook ran", flush=True)

    run(Node, "toy_node")
""")


def _start(ros_master, *args):
    return ManagedProcess([sys.executable, "-c", NODE, *args], env=ros_master.env(), name="toy_node")


def test_bad_parameter_exits_1_naming_it(ros_master):
    proc = _start(ros_master, "_rate:=-2.0")
    try:
        proc.proc.wait(30)
        assert proc.proc.returncode == 1
        assert "~rate must be > 0 [Hz], got -2.0" in proc.output()
    finally:
        proc.stop()


def test_good_parameter_spins_and_runs_shutdown_hook(ros_master):
    proc = _start(ros_master, "_rate:=5.0")
    try:
        # (a SIGINT while the constructor still runs ends the node before its hook is registered)
        wait_for(lambda: "toy: spinning" in proc.output(), 30, what="the toy node spinning")
        assert "up at 5.0 Hz" in proc.output()
    finally:
        proc.stop()
    assert "shutdown hook ran" in proc.output()
