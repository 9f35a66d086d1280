"""The simulator's present, for recorders that may lag behind it.

A session records florence_sim's ground truth from topics. On a loaded machine a busy Python
process reads its sockets late: the demo's recorder, CPU-starved beside the whole system, still
held the robot's pose of 8 simulated seconds before when the locator said the approach had
succeeded, and judged the robot where it stood then (0.69 m from the user and facing 104 deg
off; it ended 0.46 m from her, facing her within 5 deg). Before an outcome is judged, the
session asks the simulator what time it is (florence_sim's ``~now`` service, which reads the
simulation, not a topic) and waits until its recorder holds that time.
"""

import rospy

from florence_common.processes import wait_for

NOW = "/florence_sim/now"
TOLERANCE = 0.1  # [s] the ground truth is published with odometry, not every physics step


def present(timeout=30.0):
    """Simulated time now [s], from florence_sim itself."""
    from florence_sim.srv import Now

    rospy.wait_for_service(NOW, timeout)
    return rospy.ServiceProxy(NOW, Now)().sim_time


def catch_up(recorded, timeout=60.0):
    """Wait (at most ``timeout`` wall seconds) until ``recorded()`` (the simulated time of a
    recorder's latest ground truth) reaches the simulator's present; returns that present [s]."""
    now = present()
    wait_for(lambda: recorded() >= now - TOLERANCE, timeout,
             what=f"the recorded ground truth to reach simulated {now:.2f} s")
    return now
