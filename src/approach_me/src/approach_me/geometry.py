"""ApproachMe's geometry (seed 4.3; the README's figure shows it): where the robot ends, facing which
way, and the way there around the person (ROS-free).

All in one fixed frame (odom) [m, rad], REP 103 (angles counter-clockwise):

- P: the person; R0: the robot when the goal arrived.
- ``desired_distance`` d: the final distance between the robot's and the person's centres.
- ``desired_p2r_orientation`` (p2r): the angle, at the person, from the line P -> R0 to the line
  P -> G (G the final robot position): 0 = straight between the person and where the robot came
  from, positive counter-clockwise. So G = P + d (cos(phi0 + p2r), sin(phi0 + p2r)) with
  phi0 = atan2(R0 - P). The direction phi0 + p2r is fixed when the goal arrives: a person who shifts
  slightly carries G along, not its direction.
- ``desired_r2p_orientation`` (r2p): the robot's final heading relative to the line robot -> person:
  yaw = atan2(P - R) + r2p (0 = facing the person; positive: turned counter-clockwise from them,
  so that the person is seen at bearing -r2p).
"""

import math

import numpy as np

from florence_common.angles import diff, wrap


def approach_direction(person, robot0, p2r):
    """The fixed direction [rad] from the person to the final position: phi0 + p2r."""
    return wrap(math.atan2(robot0[1] - person[1], robot0[0] - person[0]) + p2r)


def goal_position(person, direction, distance):
    """G = P + d (cos, sin)(direction)."""
    return person[0] + distance * math.cos(direction), person[1] + distance * math.sin(direction)


def final_heading(robot_xy, person, r2p):
    """The heading [rad] the robot at ``robot_xy`` ends with: atan2(P - R) + r2p."""
    return wrap(math.atan2(person[1] - robot_xy[1], person[0] - robot_xy[0]) + r2p)


def segment_distance(point, a, b):
    """Distance [m] of ``point`` from the segment a-b."""
    p, a, b = (np.asarray(v, dtype=float) for v in (point, a, b))
    ab = b - a
    t = 0.0 if not ab.any() else float(np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0))
    return float(np.linalg.norm(p - (a + t * ab)))


def approach_path(robot_xy, person, goal, radius, final_leg=0.3, turn_sign=0.0, spacing=0.3):
    """Waypoints [(x, y), ...] from ``robot_xy`` to ``goal`` that keep the robot's centre at least
    ``radius`` from the person and end with a straight ``final_leg`` [m] toward the person, so
    that the robot arrives facing them (with the person in front, in its sensors' view, and only
    r2p left to turn). The final leg starts at Q, ``final_leg`` beyond the goal on the ray from the
    person. Straight to Q when that keeps clear of the person; otherwise on to the circle through Q
    (along the tangent, or straight out from inside it), around it every ``spacing`` rad to Q.
    ``turn_sign``: which way around (+1 counter-clockwise) when the goal is about opposite the
    robot; 0 = the shorter way. A robot already on the final leg goes straight to the goal."""
    px, py = person
    a_g = math.atan2(goal[1] - py, goal[0] - px)
    reach = math.hypot(goal[0] - px, goal[1] - py) + final_leg  # Q's distance from the person
    q = (px + reach * math.cos(a_g), py + reach * math.sin(a_g))
    rng = math.hypot(robot_xy[0] - px, robot_xy[1] - py)
    a_r = math.atan2(robot_xy[1] - py, robot_xy[0] - px)
    if rng <= reach + 0.1 and abs(diff(a_r, a_g)) * rng <= 0.1:  # on the final leg (or just short of it)
        return [tuple(goal)]
    if segment_distance(person, robot_xy, q) >= radius - 1e-6:
        return [q, tuple(goal)]
    r = max(radius, reach)
    delta = diff(a_g, a_r)
    if turn_sign and abs(delta) > math.pi - 0.5 and math.copysign(1.0, delta) != math.copysign(1.0, turn_sign):
        delta += math.copysign(2.0 * math.pi, turn_sign)
    sign = 1.0 if delta >= 0 else -1.0
    # where the robot meets the circle: its tangent point (outside), or straight out (inside)
    start = a_r + sign * math.acos(min(1.0, r / rng)) if rng > r else a_r
    sweep = delta - (start - a_r)
    if sign * sweep <= 0:  # the tangent point is already past the goal's side
        return [q, tuple(goal)]
    n = max(1, math.ceil(abs(sweep) / spacing))
    arc = [(px + r * math.cos(start + sweep * k / n), py + r * math.sin(start + sweep * k / n)) for k in range(n + 1)]
    return [*arc, tuple(goal)]
