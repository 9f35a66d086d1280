"""Measures of florenceLocator's runs against the simulator's ground truth (no ROS): how the robot
ended beside the user, how near it came to anybody, when it stopped, how far it turned.

Poses are (x [m], y [m], yaw [rad]) in the map frame; a track is an array [N, >= 4] of rows
(t [s], x, y, yaw, ...); people are {id: (x, y, yaw, posture)} per time.
"""

import math
from dataclasses import dataclass

import numpy as np

from florence_common import angles

PERSONAL_SPACE = 0.45  # [m] centre to centre: the edge of Hall's personal zone
# A gotoRoom / gotoXYPhi that SUCCEEDED: move_base ends a goal once amcl's estimate of the robot is
# within its xy_goal_tolerance (0.25 m), and a robot still braking or turning then comes to rest up
# to a few centimetres beyond it (move_base/README.md, turn_before_tolerance: at most 0.28 m in 100
# legs); amcl's estimate is within 0.1 m of the truth while it tracks (amcl/README.md: RMS 3 cm).
ARRIVAL_TOL = 0.25 + 0.03  # [m] the robot's estimated position at rest from the goal's
LOCALIZATION_TOL = 0.10  # [m] the estimated position from the true one


@dataclass(frozen=True)
class Approach:
    distance: float  # [m] robot centre to the user's centre
    facing_error: float  # [rad] robot heading minus the bearing to the user (0: facing them)
    side: float  # [rad] where the robot stands, seen from the user, relative to the user's heading
    posture: str

    @property
    def side_name(self):
        """front (within 20 deg of the user's heading), front-left / front-right (20-60), left /
        right (60-110), behind (beyond 110)."""
        a = abs(math.degrees(self.side))
        if a <= 20:
            return "front"
        lr = "left" if self.side > 0 else "right"
        if a <= 60:
            return f"front-{lr}"
        return lr if a <= 110 else "behind"

    def as_dict(self):
        return {"distance_m": round(self.distance, 3), "facing_error_deg": round(math.degrees(self.facing_error), 1),
                "side_deg": round(math.degrees(self.side), 1), "side": self.side_name, "posture": self.posture}


def approach(robot, user):
    """How the robot at ``robot`` (x, y, yaw) stands to a user at ``user`` (x, y, yaw, posture)."""
    dx, dy = user[0] - robot[0], user[1] - robot[1]
    bearing = math.atan2(dy, dx)
    side = angles.diff(math.atan2(-dy, -dx), user[2])
    return Approach(math.hypot(dx, dy), float(angles.diff(robot[2], bearing)), float(side),
                    user[3] if len(user) > 3 else "")


@dataclass(frozen=True)
class Arrival:
    """Where a robot sent to a goal came to rest: its true and estimated (amcl's, through the
    locator's getRobotPosXYPhi) distance [m] from the goal's position, and the estimate's error."""

    true_distance: float
    estimated_distance: float
    localization_error: float

    @property
    def ok(self):
        """The estimate within ARRIVAL_TOL of the goal and within LOCALIZATION_TOL of the truth."""
        return self.estimated_distance <= ARRIVAL_TOL and self.localization_error <= LOCALIZATION_TOL

    def __str__(self):
        return (f"{self.true_distance:.3f} m from it by ground truth, {self.estimated_distance:.3f} m by amcl's "
                f"estimate (<= {ARRIVAL_TOL:.2f}), which is {self.localization_error:.3f} m off the truth "
                f"(<= {LOCALIZATION_TOL:.2f})")


def arrival(truth, estimate, goal):
    """:class:`Arrival` of a robot at rest at ``truth`` (x, y, ...), estimated at ``estimate`` (x,
    y, ...), sent to ``goal`` (x, y, ...)."""
    return Arrival(math.dist(truth[:2], goal[:2]), math.dist(estimate[:2], goal[:2]),
                   math.dist(truth[:2], estimate[:2]))


def nearest_person(track, people_log, since=-math.inf, until=math.inf):
    """Least distance [m] between the robot (track rows t, x, y, ...) and any person over [since, until],
    each robot row against the people message nearest in time; (distance, t, person id)."""
    best = (math.inf, math.nan, "")
    if not people_log or len(track) == 0:
        return best
    stamps = np.array([t for t, _ in people_log])
    for row in track:
        t = row[0]
        if not since <= t <= until:
            continue
        k = int(np.clip(np.searchsorted(stamps, t), 0, len(stamps) - 1))
        if k > 0 and abs(stamps[k - 1] - t) < abs(stamps[k] - t):
            k -= 1
        for pid, person in people_log[k][1].items():
            d = math.hypot(person[0] - row[1], person[1] - row[2])
            if d < best[0]:
                best = (d, float(t), pid)
    return best


def time_to_stop(track, since, speed=0.02, turn=0.05, hold=0.3):
    """Simulated seconds from ``since`` until the robot's speed (columns 4, 5: v [m/s], w [rad/s])
    stays below ``speed`` and ``turn`` for ``hold`` s; None if it never does."""
    rows = track[track[:, 0] >= since]
    still = (np.abs(rows[:, 4]) < speed) & (np.abs(rows[:, 5]) < turn)
    for i in range(len(rows)):
        if still[i]:
            j = i
            while j < len(rows) and still[j]:
                if rows[j, 0] - rows[i, 0] >= hold:
                    return float(rows[i, 0] - since)
                j += 1
    return None


def turned(track, since=-math.inf, until=math.inf, signed=False):
    """Rotation [rad] of the robot over [since, until]: the sum of the absolute heading changes (every
    turn, back and forth), or with ``signed`` the net turn (counter-clockwise positive)."""
    rows = track[(track[:, 0] >= since) & (track[:, 0] <= until)]
    if len(rows) < 2:
        return 0.0
    steps = angles.diff(rows[1:, 3], rows[:-1, 3])
    return float(np.sum(steps) if signed else np.sum(np.abs(steps)))


def percentile(values, q):
    values = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.percentile(values, q)) if values else None
