"""The collision monitor's rule (collision_monitor.monitor): its zones, moving away, turning in
place, the footprint, and the rule closed around a braking robot."""

import math

import numpy as np
import pytest
from collision_monitor.monitor import (
    CLEAR,
    SLOW,
    STOP,
    TURN,
    MonitorConfig,
    arc_poses,
    braking_speed,
    clearances,
    decide,
    polygon_clearance,
    stopping_distance,
)

pytestmark = pytest.mark.unit

CFG = MonitorConfig(robot_radius=0.18, stop_distance=0.05)  # decel 0.5, latency 0.2


def wall(x, y0=-1.0, y1=1.0, spacing=0.01):
    """Points of a wall across the robot's path at x [m] (base frame)."""
    ys = np.arange(y0, y1 + 1e-9, spacing)
    return np.column_stack([np.full_like(ys, x), ys])


def side_wall(y, x0=-1.0, x1=2.0, spacing=0.01):
    xs = np.arange(x0, x1 + 1e-9, spacing)
    return np.column_stack([xs, np.full_like(xs, y)])


def test_free_space_passes_unchanged():
    d = decide(np.zeros((0, 2)), 0.5, 0.3, CFG)
    assert (d.state, d.v, d.w, d.scale) == (CLEAR, 0.5, 0.3, 1.0)
    d = decide(wall(3.0), 0.5, 0.0, CFG)  # far beyond the horizon
    assert (d.state, d.v, d.w) == (CLEAR, 0.5, 0.0)


@pytest.mark.parametrize("x, state", [
    (1.2, CLEAR),   # 1.02 m of clearance: 0.5 m/s stops in 0.35 m
    (0.5, SLOW),    # 0.32 m of clearance: 0.5 m/s would not stop in time
    (0.25, SLOW),   # 0.07 m: a crawl
    (0.232, STOP),  # 0.052 m: 2 mm from the stop zone
    (0.2, STOP),    # 0.02 m: inside it
])
def test_zones_ahead(x, state):
    d = decide(wall(x), 0.5, 0.0, CFG)
    assert d.state == state, d
    assert d.clearance == pytest.approx(x - 0.18, abs=1e-6)
    if state == SLOW:
        assert 0 < d.v < 0.5 and d.v == pytest.approx(braking_speed(d.stop_path, 0.5, 0.2))
    if state == STOP:
        assert d.v == 0.0


def test_slows_then_stops_as_the_wall_nears():
    speeds = [decide(wall(x), 0.5, 0.0, CFG).v for x in np.arange(1.0, 0.2, -0.02)]
    assert speeds[0] == 0.5 and speeds[-1] == 0.0
    assert np.all(np.diff(speeds) <= 1e-12), "the allowed speed never grows as the wall nears"
    assert sum(0 < s < 0.5 for s in speeds) >= 10, "it slows over a stretch, not at once"


def test_slowing_keeps_the_path():
    d = decide(wall(0.45), 0.4, 0.4, CFG)
    assert d.state == SLOW
    assert d.w / d.v == pytest.approx(0.4 / 0.4)


def test_turning_in_place_is_never_blocked():
    pts = np.vstack([wall(0.2), wall(-0.2), side_wall(0.19), side_wall(-0.19)])  # boxed in
    d = decide(pts, 0.0, 1.5, CFG)
    assert (d.state, d.v, d.w) == (TURN, 0.0, 1.5)
    # a stopped command keeps its turn: the robot may turn away from what stopped it
    d = decide(wall(0.2), 0.3, -0.8, CFG)
    assert (d.state, d.v, d.w) == (STOP, 0.0, -0.8)


def test_moving_away_is_never_blocked():
    inside = wall(0.21)  # 0.03 m: inside the stop zone in front
    assert decide(inside, -0.2, 0.0, CFG).state == CLEAR  # backing away
    assert decide(inside, 0.2, 0.0, CFG).state == STOP
    # a wall on the left, inside the stop zone: steering right and away passes, left is stopped
    left = side_wall(0.21)
    assert decide(left, 0.3, -1.0, CFG).state == CLEAR
    assert decide(left, 0.3, 1.0, CFG).state == STOP
    # sliding along it does not bring the robot nearer: it passes
    assert decide(left, 0.3, 0.0, CFG).state == CLEAR
    # moving away from one wall toward another is judged by the other: the robot may not come
    # nearer to it than it is to the first now
    corridor = np.vstack([wall(0.21), wall(-0.5)])
    d = decide(corridor, -0.5, 0.0, CFG)
    assert d.state == SLOW and d.stop_path == pytest.approx(0.5 - 0.18 - 0.03, abs=0.005)


def test_driving_along_a_wall_passes():
    d = decide(side_wall(0.35), 0.5, 0.0, CFG)  # 0.17 m of clearance, kept
    assert d.state == CLEAR


def test_an_arc_is_judged_along_the_arc():
    # an obstacle ahead-left: straight on passes it, turning left runs into it
    post = np.array([[0.4, 0.35]])
    straight, arc = decide(post, 0.3, 0.0, CFG), decide(post, 0.3, 0.8, CFG)
    assert straight.state == CLEAR and straight.stop_path == math.inf
    assert arc.stop_path < 0.4
    assert decide(post, 0.5, 1.33, CFG).state == SLOW


def test_a_slow_command_is_checked_over_min_lookahead():
    d = decide(wall(0.3), 0.01, 0.0, CFG)  # 0.12 m clearance; 0.01 m/s goes 1.5 cm in the horizon
    assert d.state == CLEAR and d.stop_path < 0.15  # seen, and slow enough already


def test_polygon_footprint():
    nose = MonitorConfig(stop_distance=0.05,
                         footprint=((-0.16, -0.16), (-0.16, 0.16), (0.19, 0.16), (0.24, 0.0), (0.19, -0.16)))
    assert nose.reach == pytest.approx(math.hypot(0.19, 0.16))
    assert polygon_clearance(np.array([[0.3, 0.0], [0.0, 0.0], [0.0, 0.2]]), np.array(nose.footprint)) == \
        pytest.approx([0.06, -0.16, 0.04])
    assert decide(wall(0.28), 0.3, 0.0, nose).state == STOP  # 0.04 m from the nose
    assert decide(wall(0.28), 0.3, 0.0, CFG).state == SLOW  # 0.10 m from the circle
    # turning the polygon is judged by its corners
    poses = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, math.pi / 2]])
    c = clearances(np.array([[0.0, 0.3]]), poses, nose)
    assert c[0, 0] == pytest.approx(0.14) and c[1, 0] == pytest.approx(0.06)


def test_bad_points_are_ignored_and_bad_settings_refused():
    pts = np.array([[np.nan, 0.0], [np.inf, 1.0], [0.21, 0.0]])
    assert decide(pts, 0.3, 0.0, CFG).state == STOP
    for bad in ({"stop_distance": 0.0}, {"deceleration": -1.0}, {"time_horizon": math.nan},
                {"footprint": ((1.0, 1.0), (2.0, 1.0), (2.0, 2.0))}, {"footprint": ((0.0, 0.0), (1.0, 0.0))}):
        with pytest.raises(ValueError):
            MonitorConfig(**bad)


def test_braking_speed_and_stopping_distance_are_inverse():
    for v in (0.05, 0.2, 0.5):
        assert braking_speed(stopping_distance(v, 0.5, 0.2), 0.5, 0.2) == pytest.approx(v)
    assert braking_speed(0.0, 0.5, 0.2) == 0.0


def test_arc_poses():
    poses, s = arc_poses(0.5, 0.5, math.pi, 0.02, 0.05)  # radius 1: half a circle
    assert s[-1] == pytest.approx(math.pi)
    assert poses[-1] == pytest.approx([0.0, 2.0, math.pi], abs=1e-9)
    back, _ = arc_poses(-0.2, 0.0, 0.3, 0.02, 0.05)
    assert back[-1] == pytest.approx([-0.3, 0.0, 0.0])


@pytest.mark.parametrize("speed, period", [(0.5, 0.2), (0.3, 0.1), (0.5, 0.1)])
def test_closed_loop_a_braking_robot_stops_short_of_the_wall(speed, period):
    """A robot commanded at ``speed`` toward a wall 2 m ahead, the command judged every ``period``
    s and held in between, braking at velocity_filter's 1 m/s^2: it slows, stops near the stop
    zone's edge and never touches."""
    x, v, dt = 0.0, 0.0, 0.01
    least = math.inf
    wall_x = 2.0
    cmd = 0.0
    for k in range(int(12.0 / dt)):
        if k % round(period / dt) == 0:
            cmd = decide(wall(wall_x - x), speed, 0.0, CFG).v
        v = min(cmd, v + 1.0 * dt) if cmd >= v else max(cmd, v - 1.0 * dt)
        x += v * dt
        least = min(least, wall_x - x - 0.18)
    assert v == pytest.approx(0.0, abs=1e-9)
    assert 0.0 < least <= 0.05 + 0.01, f"stopped {least:.3f} m from the wall, beyond the stop zone's edge"
    assert least >= 0.05 - 0.03, f"the stop zone was entered by {0.05 - least:.3f} m"


def test_padding_makes_a_points_clearance_count_less():
    seat = wall(0.40)  # 0.22 m of clearance
    assert decide(seat, 0.3, 0.0, CFG).state == CLEAR
    d = decide(seat, 0.3, 0.0, CFG, padding=np.full(len(seat), 0.08))
    assert d.clearance == pytest.approx(0.40 - 0.18 - 0.08) and d.state == SLOW
    assert decide(wall(0.30), 0.1, 0.0, CFG, padding=np.full(len(wall(0.30)), 0.08)).state == STOP


def jamb(x, y, depth=0.12, spacing=0.01):
    """A door jamb's end face beside the robot: points from (x, y) to (x + depth, y), and the wall going on away
    from the robot (y more negative when y < 0)."""
    face = np.column_stack([np.arange(x, x + depth + 1e-9, spacing), np.full(round(depth / spacing) + 1, y)])
    side = np.sign(y) if y else 1.0
    wall_pts = np.column_stack([np.full(30, x), y + side * np.arange(1, 31) * spacing])
    return np.vstack([face, wall_pts])


def test_steer_clear_leaves_a_door_jamb_the_straight_command_would_graze():
    """follow_me's demo case (26 Nov): in a doorway, a jamb 0.20 m to the right-front, the robot already inside
    its stop zone, the law steering straight on past it: the straight command is stopped, and the law would
    ask for it for ever. Steered, the robot turns away on the spot, then arcs past, and is through the door
    and on toward the goal beyond it, never nearer to anything than at the start."""
    from collision_monitor.monitor import steer_clear

    pts = jamb(0.10, -0.20)
    straight = decide(pts, 0.4, 0.0, CFG)
    assert straight.state in (STOP, SLOW) and straight.v < 0.05, straight  # stopped, or at a crawl
    x, y, yaw, dt = 0.0, 0.0, 0.0, 0.1
    goal = (1.2, -0.45)  # beyond the wall, to the right
    start = least = clearances(pts, np.zeros((1, 3)), CFG).min()
    for _ in range(150):
        c, s = math.cos(yaw), math.sin(yaw)
        local = np.column_stack([c * (pts[:, 0] - x) + s * (pts[:, 1] - y), -s * (pts[:, 0] - x) + c * (pts[:, 1] - y)])
        gx, gy = c * (goal[0] - x) + s * (goal[1] - y), -s * (goal[0] - x) + c * (goal[1] - y)
        if math.hypot(gx, gy) < 0.1:
            break
        d = steer_clear(local, 0.3, max(-1.5, min(1.5, 1.5 * math.atan2(gy, gx))), CFG, max_w=1.5)
        x, y, yaw = x + d.v * dt * math.cos(yaw + d.w * dt / 2), y + d.v * dt * math.sin(yaw + d.w * dt / 2), \
            yaw + d.w * dt
        least = min(least, clearances(pts, np.array([[x, y, yaw]]), CFG).min())
    assert math.hypot(goal[0] - x, goal[1] - y) < 0.1, (x, y, yaw)
    assert least >= start - 1e-3, (least, start)


def test_steer_clear_leaves_a_passing_command_and_a_blocked_one_as_they_are():
    from collision_monitor.monitor import steer_clear

    free = steer_clear(np.zeros((0, 2)), 0.3, 0.2, CFG, max_w=1.5)
    assert (free.state, free.v, free.w) == (CLEAR, 0.3, 0.2)
    ahead = wall(0.25, -2.0, 2.0)  # a wall right ahead: no arc helps, the command is judged as it is
    assert steer_clear(ahead, 0.3, 0.0, CFG, max_w=1.5) == decide(ahead, 0.3, 0.0, CFG)
    pts = jamb(0.10, -0.20)  # no arc within +-0.1 rad/s passes: a turn on the spot away from the jamb, as slow
    capped = steer_clear(pts, 0.4, 0.0, CFG, max_w=0.1)
    assert (capped.state, capped.v, capped.w) == (TURN, 0.0, 0.1)
