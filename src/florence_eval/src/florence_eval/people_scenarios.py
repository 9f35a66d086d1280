"""The scripted scenarios of the people tracker's evaluation (bench/people.py, its offline mode
and the regression tests), in the shipped apartment. Units: metres, radians, seconds, m/s.

Each puts the robot at ``robot`` (x, y, yaw in the map) and the people of ``people`` (id ->
people-file spec, as florence_sim's ``~set_person`` takes it) in an apartment with nobody else,
drives the robot by ``drive`` [(v [m/s], w [rad/s], seconds)], then lets it stand until
``seconds`` have passed.
"""

import math
from dataclasses import dataclass, field

import yaml

from florence_common.maps import map_file

RED, BLUE, GREEN, YELLOW = [0.85, 0.1, 0.1], [0.1, 0.3, 0.85], [0.1, 0.6, 0.2], [0.9, 0.8, 0.1]
# in view, out of the Kinect's view to the north, through the living room's door, west along the
# corridor behind its wall (out of the laser's sight from the living room), and back
LEAVE_AND_RETURN = [[3.0, 2.6], [1.8, 2.9], [1.8, 4.9], [2.45, 5.2], [2.45, 6.15], [1.0, 6.15]]


@dataclass
class Scenario:
    name: str
    robot: tuple
    people: dict
    seconds: float
    drive: list = field(default_factory=list)
    beside: bool = False  # judge the share of frames a person beside the robot (laser only) is tracked
    clutter: bool = False  # nobody: every track is a false positive
    near: bool = False  # judge the share of frames people near the robot (laser's view) are on tracked_people


def shipped_people():
    """The apartment's residents as shipped (maps/apartment/people.yaml): id -> spec."""
    people = yaml.safe_load(map_file("apartment", "people.yaml").read_text())["people"]
    return {p["id"]: {k: v for k, v in p.items() if k != "id"} for p in people}


SEAT = (3.0, 2.4, 2.8)  # [m, m, rad] the day's seat of the user in the living room, facing west-north-west
SEATED_APPROACH = Scenario(
    "coming_to_the_seated", (SEAT[0] + 2.4 * math.cos(SEAT[2]), SEAT[1] + 2.4 * math.sin(SEAT[2]), SEAT[2] - math.pi), {
        "erin": {"pose": list(SEAT), "posture": "sitting", "shirt": RED, "height": 1.63, "build": 0.9}},
    12.0, drive=[(0.2, 0.0, 1.75 / 0.2)])

SCENARIOS = [
    Scenario("robot_still", (0.6, 2.5, 0.0), {
        "alice": {"path": [[2.0, 2.6], [4.4, 2.6]], "speed": 0.5, "mode": "back_and_forth", "pause": 1.0,
                  "shirt": RED}}, 40.0),
    Scenario("robot_turning", (0.6, 2.5, 0.0), {
        "bob": {"pose": [3.0, 2.6, math.pi], "shirt": BLUE},
        "carol": {"pose": [0.8, 4.6, -1.5], "shirt": GREEN, "height": 1.58, "build": 0.9}},
        30.0, drive=[(0.0, 0.4, 2 * math.pi / 0.4)]),
    Scenario("robot_driving", (0.5, 2.5, 0.0), {
        "alice": {"path": [[4.4, 1.9], [4.4, 3.2]], "speed": 0.4, "mode": "back_and_forth", "shirt": RED}},
        12.0, drive=[(0.15, 0.0, 10.0)]),
    # an X across the robot's view in the kitchen, from opposite sides: they pass each other 2.1 m
    # ahead, 0.6 m apart (centres), the nearer one hiding the other for a moment
    Scenario("two_crossing", (6.2, 0.9, math.pi / 2), {
        "alice": {"path": [[5.3, 2.2], [7.1, 3.4]], "speed": 0.45, "mode": "back_and_forth", "shirt": RED},
        "bob": {"path": [[7.1, 2.8], [5.3, 4.0]], "speed": 0.45, "mode": "back_and_forth", "shirt": BLUE,
                "height": 1.85, "build": 1.15}}, 30.0),
    # two people passing each other along the robot's line of sight, in lanes 0.6 m apart
    Scenario("passing_in_depth", (0.6, 2.4, 0.0), {
        "alice": {"path": [[2.7, 2.05], [4.5, 2.05]], "speed": 0.45, "mode": "back_and_forth", "shirt": RED},
        "bob": {"path": [[4.5, 2.65], [2.7, 2.65]], "speed": 0.45, "mode": "back_and_forth", "shirt": BLUE,
                "height": 1.85, "build": 1.15}}, 30.0),
    Scenario("sitting", (0.6, 2.2, 0.0), {
        "dave": {"pose": [3.2, 2.5, math.pi], "posture": "sitting", "shirt": YELLOW}}, 20.0),
    # the robot drives up to the day's seated user (florence_scenarios.day), from 2.4 m in front of her to 0.65 m,
    # as approach_me_map does: the image cuts her top off from about 1.7 m, nearer than 1.1 m her upper body
    SEATED_APPROACH,
    Scenario("leave_and_return", (0.6, 2.5, 0.0), {
        "alice": {"path": LEAVE_AND_RETURN, "speed": 0.6, "mode": "back_and_forth", "pause": 1.5, "shirt": RED}},
        60.0),
    Scenario("beside_the_robot", (0.6, 2.5, 0.0), {"bob": {"pose": [1.9, 2.6, math.pi], "shirt": BLUE}},
             30.0, drive=[(0.0, 0.0, 4.0), (0.0, -0.3, 1.25 / 0.3)], beside=True),
    # the apartment as shipped: its two residents on their rounds, the robot in the living room
    # looking toward the kitchen, then turning to the corridor
    Scenario("residents", (1.0, 3.2, -0.2), shipped_people(), 60.0,
             drive=[(0.0, 0.0, 30.0), (0.0, 0.4, 2.0)]),
    # the robot drives along the living room with a resident walking just behind it, held up by it
    # (her way passes where it drives), beside it while it turns round, then turning back and coming
    # again: near the robot, mostly out of the Kinect's view, walking and standing; whom move_base
    # must keep clear of
    Scenario("walker_by_the_robot", (0.5, 2.5, 0.0), {
        "alice": {"path": [[0.5, 2.9], [4.4, 2.2]], "speed": 0.6, "mode": "back_and_forth", "pause": 1.0,
                  "shirt": RED}}, 40.0, drive=[(0.15, 0.0, 12.0), (0.0, -0.5, 6.0), (0.15, 0.0, 8.0)], near=True),
    Scenario("clutter_only", (1.2, 5.0, -math.pi / 2), {}, 25.0, drive=[(0.0, 0.4, 2 * math.pi / 0.4)],
             clutter=True),
]


def by_name(names=None):
    """The scenarios named (all for None), in SCENARIOS order; KeyError for an unknown name."""
    known = {sc.name: sc for sc in SCENARIOS}
    for name in names or ():
        if name not in known:
            raise KeyError(f"no scenario {name!r} (known: {', '.join(known)})")
    return [sc for sc in SCENARIOS if not names or sc.name in names]
