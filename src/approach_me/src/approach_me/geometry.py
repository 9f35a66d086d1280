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


def approach_path(robot_xy, person, goal, turn_sign=0.0, spacing=0.15):
    """Waypoints [(x, y), ...] from ``robot_xy`` to ``goal`` on a logarithmic spiral about the person:
    the distance to them shrinks (or grows) evenly with the angle swept round them, so that the
    person stays at one bearing from the robot's way all along, in its sensors' view (a circle round
    them would keep them abeam, at the edge of the laser's +-90 degrees, where the tracker loses a
    standing person for good). Straight in when the goal lies on the robot's side of the person.
    ``turn_sign``: which way round (+1 counter-clockwise) when the goal is about opposite the robot;
    0 = the shorter way. Waypoints every ``spacing`` m or so, the goal last."""
    px, py = person
    r0 = math.hypot(robot_xy[0] - px, robot_xy[1] - py)
    r1 = math.hypot(goal[0] - px, goal[1] - py)
    a0 = math.atan2(robot_xy[1] - py, robot_xy[0] - px)
    delta = diff(math.atan2(goal[1] - py, goal[0] - px), a0)
    if turn_sign and abs(delta) > math.pi - 0.5 and math.copysign(1.0, delta) != math.copysign(1.0, turn_sign):
        delta += math.copysign(2.0 * math.pi, turn_sign)
    if r0 < 1e-6:
        return [tuple(goal)]
    length = abs(delta) * 0.5 * (r0 + r1) + abs(r0 - r1)  # about the spiral's length
    n = max(1, math.ceil(length / spacing))
    k = np.arange(1, n + 1) / n
    r = r0 * (r1 / r0) ** k  # geometric in the angle: a logarithmic spiral
    a = a0 + delta * k
    pts = [(float(px + ri * math.cos(ai)), float(py + ri * math.sin(ai))) for ri, ai in zip(r, a, strict=True)]
    pts[-1] = tuple(goal)
    return pts


def spiral_bearing(r0, r1, sweep):
    """The person's bearing [rad] from the way of a spiral from distance ``r0`` to ``r1`` [m] over
    ``sweep`` [rad] round them: pi/2 - atan(ln(r0 / r1) / |sweep|) (0 straight in, pi/2 abeam)."""
    if sweep == 0:
        return 0.0 if r0 >= r1 else math.pi
    return math.pi / 2 - math.atan(math.log(r0 / r1) / abs(sweep))
