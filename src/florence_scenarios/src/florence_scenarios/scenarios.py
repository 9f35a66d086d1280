"""The demo's two scenarios, driven only through the system's public interfaces and judged
against the simulator's ground truth:

1. :func:`by_hand`: as a person at the keyboard (the multiplexer's teleop input): out of the
   living room into the corridor, a turn, along it, the Kinect tilted up and back, a drive at
   the corridor wall that the collision monitor stops short (no bump) and back off; sensor rates in
   simulated time, odometry drift against ground truth.
2. :func:`navigation`: as a client of move_base: the people leave, and the robot goes to the
   kitchen, the bedroom and back to the living room (room hotspots of maps/apartment/rooms.yaml).

Each returns its record and its :class:`~florence_scenarios.checks.Checks`; steps are kept by
key, and checks name the step they read.
"""

import math
import time

import yaml

from florence_common import angles, pose
from florence_common.maps import map_file
from florence_common.processes import ProcessError, wait_for
from florence_scenarios.checks import Checks
from florence_scenarios.observer import RATES
from florence_scenarios.teleop import Teleop

START = (2.45, 4.5, math.pi / 2)  # [m, m, rad] living room, facing its door to the corridor
NAV_GOALS = ("kitchen", "bedroom", "living_room")  # room hotspots the navigation scenario visits
# what the sensors must run at over the by-hand scenario [Hz, simulated time]
EXPECTED_RATES = {"/scan": 10.0, "/odom": 30.0, "/camera/depth/image": 15.0, "/turtlebot_node/sensor_state": 10.0,
                  "/clock": 100.0}
BOB_IN_THE_BEDROOM = ("{path: [[1.0, 7.4], [4.8, 7.4]], speed: 0.4, mode: back_and_forth, pause: 2.0, "
                      "shirt: [0.1, 0.3, 0.85]}")


def odom_drift(start, odom, truth):
    """Position [m] and heading [rad] error of the odometry, carried into the map frame through
    the start pose (odometry starts at zero where the robot starts)."""
    mx, my, myaw = pose.compose(start, odom)
    return math.hypot(mx - truth[0], my - truth[1]), abs(angles.diff(myaw, truth[2]))


CORRIDOR_NORTH_WALL_Y = 6.8  # [m] the apartment's corridor wall the scenario drives at (maps/apartment)
ROBOT_RADIUS = 0.17  # [m] the Create's body


def collisions(rospy, timeout):
    """The simulator's collision counter (/collisions)."""
    from std_msgs.msg import UInt32

    return rospy.wait_for_message("/collisions", UInt32, timeout).data


class Steps:
    """The by-hand scenario's record: one row per step, kept by key, in order."""

    def __init__(self, obs):
        self.obs = obs
        self.rows = {}
        self.t0 = obs.now()

    def record(self, key, description):
        truth, odom = self.obs.truth(), self.obs.odom()
        dist, ang = odom_drift(START, odom, truth)
        state = self.obs.get("/turtlebot_node/sensor_state")
        self.rows[key] = {"key": key, "step": description, "sim_time_s": round(self.obs.now() - self.t0, 2),
                          "truth": [round(v, 3) for v in truth], "odom": [round(v, 3) for v in odom],
                          "drift_m": round(dist, 3), "drift_deg": round(math.degrees(ang), 2),
                          "bumps_wheeldrops": state.bumps_wheeldrops if state else None}
        print(f"demo: {description}: truth ({truth[0]:.2f}, {truth[1]:.2f}, {math.degrees(truth[2]):.0f} deg), "
              f"odom drift {dist:.3f} m", flush=True)

    def __getitem__(self, key):
        return self.rows[key]

    def last(self):
        return list(self.rows.values())[-1]


def by_hand(rospy, obs, timeout):
    """Scenario 1; returns (steps, summary)."""
    from std_msgs.msg import Float64

    from florence_sim.srv import SetPerson

    teleop = Teleop(rospy, obs, timeout)
    wait_for(obs.ready, timeout, what="the simulator's topics")
    wall0, counts0 = time.monotonic(), obs.counts()
    steps = Steps(obs)

    # bob walks the corridor the robot is about to use: send him to the bedroom (test service)
    rospy.wait_for_service("/florence_sim/set_person", timeout)
    res = rospy.ServiceProxy("/florence_sim/set_person", SetPerson)("bob", BOB_IN_THE_BEDROOM)
    if not res.success:
        raise ProcessError(f"set_person bob: {res.message}")
    steps.record("start", "start in the living room (bob sent to walk in the bedroom)")
    teleop.straight(1.7)
    steps.record("door", "through the door into the corridor")
    teleop.turn(-math.pi / 2)
    steps.record("turned_east", "turned right, facing east along the corridor")
    teleop.straight(1.2)
    steps.record("corridor", "along the corridor")
    tilt_pub = rospy.Publisher("/tilt_angle", Float64, queue_size=1, latch=True)
    tilt_pub.publish(Float64(15.0))
    wait_for(lambda: obs.get("/cur_tilt_angle") and abs(obs.get("/cur_tilt_angle").data - 15.0) < 0.1, timeout,
             what="Kinect tilted to 15 deg")
    tilt_pub.publish(Float64(0.0))
    wait_for(lambda: abs(obs.get("/cur_tilt_angle").data) < 0.1, timeout, what="Kinect tilt back to 0")
    steps.record("tilt", "Kinect tilted up 15 deg and back")
    teleop.turn(math.pi / 2)
    steps.record("facing_wall", "turned left, facing the corridor's north wall")
    before = collisions(rospy, timeout)

    def bumped():
        state = obs.get("/turtlebot_node/sensor_state")
        return state is not None and state.bumps_wheeldrops & 0b11 != 0

    # the collision monitor (before velocity_filter) stops any command short of the wall
    teleop.straight(1.0, speed=0.2, until=bumped)
    steps.record("bump", "drove at the corridor wall (the collision monitor stops it short)")
    teleop.straight(-0.3, speed=0.2)
    steps.record("backed_off", "backed off")
    bumps = collisions(rospy, timeout) - before
    tilt_pub.unregister()

    sim_s, wall_s = obs.now() - steps.t0, time.monotonic() - wall0
    counts = obs.counts()
    people = obs.get("/people_ground_truth")
    last = steps.last()
    summary = {
        "sim_seconds": round(sim_s, 2), "wall_seconds": round(wall_s, 2),
        "real_time_factor_achieved": round(sim_s / wall_s, 2),
        "collisions_in_scenario": bumps,
        "final_drift_m": last["drift_m"], "final_drift_deg": last["drift_deg"],
        "rates_hz_sim_time": {topic: round((counts[topic] - counts0[topic]) / sim_s, 1) for topic in RATES},
        "people": {p.id: [round(p.pose.position.x, 2), round(p.pose.position.y, 2)] for p in people.people}
        if people else {},
    }
    return steps, summary


def by_hand_checks(steps, summary):
    """What scenario 1 must show: the robot reached the corridor, was stopped short of the wall by
    the collision monitor (no collision, bumper free, within 0.15 m of it), sensors alive."""
    checks = Checks()
    corridor = steps["corridor"]["truth"]
    checks.add("robot drove into the corridor", 5.55 < corridor[1] < 6.75, f"truth {corridor}")
    bump = steps["bump"]["bumps_wheeldrops"]
    gap = CORRIDOR_NORTH_WALL_Y - ROBOT_RADIUS - steps["bump"]["truth"][1]
    checks.add("stopped short of the wall: no collision, bumper free, within 0.15 m",
               summary["collisions_in_scenario"] == 0 and bump == 0 and 0.0 < gap <= 0.15,
               f"{summary['collisions_in_scenario']} collision(s), bumps {bump}, {gap:.3f} m from the wall")
    rates = summary["rates_hz_sim_time"]
    for topic, hz in EXPECTED_RATES.items():
        checks.add(f"{topic} at about {hz:g} Hz (sim time)", abs(rates[topic] - hz) < 0.25 * hz, f"{rates[topic]} Hz")
    checks.add("odometry drift below 0.3 m", summary["final_drift_m"] < 0.3, f"{summary['final_drift_m']} m")
    return checks


def navigation(rospy, timeout):
    """Scenario 2: move_base goals to room hotspots; returns (goals, checks)."""
    from florence_eval.nav_session import NavSession

    from florence_sim.srv import RemovePerson

    rooms = yaml.safe_load(map_file("apartment", "rooms.yaml").read_text())["rooms"]
    remove = rospy.ServiceProxy("/florence_sim/remove_person", RemovePerson)
    for person in ("alice", "bob"):
        remove(person)  # person avoidance is the scenario tests' (test_move_base_sim.py)
    session = NavSession()
    if not session.wait_ready(timeout):
        raise ProcessError("move_base's action server did not come up")
    time.sleep(1.0)  # a fresh action client's first goal can be lost while the connections settle
    before = collisions(rospy, timeout)
    goals = {}
    try:
        for room in NAV_GOALS:
            h = rooms[room]["hotspot"]
            start = session.latest()
            state, text, took, length = session.go(h["x"], h["y"], h["phi"], sim_timeout=max(timeout, 120.0) * 1.5)
            here = session.latest()
            err = math.hypot(here[1] - h["x"], here[2] - h["y"])
            yaw_err = abs(angles.diff(here[3], h["phi"]))
            goals[room] = {"goal": room, "hotspot": [h["x"], h["y"], h["phi"]], "state": state, "text": text,
                           "sim_time_s": round(took, 2), "driven_m": round(length, 2),
                           "from": [round(v, 2) for v in start[1:4]], "error_m": round(err, 3),
                           "yaw_error_deg": round(math.degrees(yaw_err), 1)}
            print(f"demo: move_base goal {room}: {state} in {took:.1f} s (sim), {length:.1f} m, "
                  f"off by {err:.2f} m / {math.degrees(yaw_err):.0f} deg {text}", flush=True)
    finally:
        session.close()
    bumps = collisions(rospy, timeout) - before
    checks = Checks()
    checks.add("every goal SUCCEEDED", all(g["state"] == "SUCCEEDED" for g in goals.values()),
               ", ".join(f"{room}: {g['state']}" for room, g in goals.items()))
    # xy_goal_tolerance 0.25 m of the seed plus amcl's error
    checks.add("every goal reached within 0.35 m", all(g["error_m"] < 0.35 for g in goals.values()),
               ", ".join(f"{g['error_m']} m" for g in goals.values()))
    checks.add("no collision while navigating", bumps == 0, f"{bumps} collision(s)")
    return goals, checks
