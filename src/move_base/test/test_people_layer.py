"""People in the costmaps (move_base.people_layer): the proxemic cost against ProxemicLayer's
formula, its stretch ahead of a walker, the lapse of a lost track, bad input, the lethal core and
the robot's own cell, the trail of a walker; the local planner's rule (approaches); where to give
way (give_way_cells); and the keep-out layer and LayeredCostmap's views without the sensors."""

import math

import numpy as np
import pytest
from move_base.costmap_2d import FREE_SPACE, INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION, Costmap2D
from move_base.layers import KeepoutLayer, LayeredCostmap, ObservationSource
from move_base.navfn import compute_potential, translate_costs
from move_base.people_layer import (
    GIVE_WAY_FAN,
    HEADING_KEEP,
    SENT_TO_ID,
    Person,
    ProxemicLayer,
    RecentPoints,
    approach_exemption,
    approaches,
    backs_toward,
    blocked_plan_reason,
    braking_positions,
    give_way_cells,
    near_walks,
    walking_away,
)

pytestmark = pytest.mark.unit


def grid(size=100, res=0.05, origin=-2.5):
    return Costmap2D(size, size, res, origin, origin)


def ros_gaussian(x, y, x0, y0, amplitude, varx, vary, skew):
    """social_navigation_layers' gaussian(), for comparison."""
    dx, dy = x - x0, y - y0
    h = math.hypot(dx, dy)
    angle = math.atan2(dy, dx)
    mx, my = math.cos(angle - skew) * h, math.sin(angle - skew) * h
    return amplitude * math.exp(-(mx * mx / (2 * varx) + my * my / (2 * vary)))


def test_standing_person_is_a_round_gaussian_as_ros_computes_it():
    layer = ProxemicLayer()
    layer.set_people([Person(0.0, 0.0, 0.0, 0.0, seen=10.0)], stamp=10.0)
    c = grid()
    layer.update_costs(c, now=10.0)
    for x, y in [(0.025, 0.025), (0.325, 0.025), (-0.325, 0.225), (0.525, -0.525)]:
        want = ros_gaussian(x, y, 0.0, 0.0, 77.0, 0.25, 0.25, 0.0)
        got = c.cost_at(x, y)
        assert got == (int(want) if want >= 10.0 else 0), (x, y)
    assert c.cost_at(0.025, 0.025) == 76
    assert c.cost_at(1.5, 0.0) == FREE_SPACE  # beyond the cutoff


def test_a_walker_stretches_the_cost_ahead_only():
    layer = ProxemicLayer()
    layer.set_people([Person(0.0, 0.0, 0.5, 0.0, seen=0.0)], stamp=0.0)  # walking +x at 0.5 m/s
    c = grid()
    layer.update_costs(c, now=0.0)
    ahead, behind = c.cost_at(1.025, 0.025), c.cost_at(-0.975, 0.025)
    assert ahead == int(ros_gaussian(1.025, 0.025, 0.0, 0.0, 77.0, 0.25 * (1 + 0.5 * 5.0), 0.25, 0.0))
    assert behind == int(ros_gaussian(-0.975, 0.025, 0.0, 0.0, 77.0, 0.25, 0.25, 0.0))
    assert ahead > 3 * behind
    assert layer.radius(0.5) > layer.radius(0.0)


def test_the_person_is_carried_along_and_lapses_when_the_track_is_gone():
    layer = ProxemicLayer(keep_time=0.75)
    layer.set_people([Person(0.0, 0.0, 1.0, 0.0, seen=5.0, id=1)], stamp=5.0)
    people, ids = layer.current(5.4)
    assert people[0, :2] == pytest.approx([0.4, 0.0]) and ids == [1]  # walked on 0.4 s
    assert layer.current(5.7)[0][0, 0] == pytest.approx(0.5)  # carried 0.5 s at most
    assert len(layer.current(5.76)[0]) == 0  # not seen for more than keep_time
    c = grid()
    layer.update_costs(c, now=6.0)
    assert int(c.costs.max()) == 0
    # the tracker's next messages no longer hold the person (its sensors lost them): they stay
    # until keep_time after they were last seen
    layer.set_people([Person(0.0, 0.0, 0.0, 0.0, seen=7.0, id=2)], stamp=7.0)
    layer.set_people([], stamp=7.3)
    assert layer.current(7.5)[1] == [2]
    layer.set_people([], stamp=7.8)
    assert layer.current(7.8)[1] == []
    c = grid()
    layer.update_costs(c, now=7.8)
    assert int(c.costs.max()) == 0


def test_a_person_out_of_view_is_held_until_the_sensors_look_and_do_not_find_them():
    layer = ProxemicLayer(keep_time=8.0, unseen_keep_time=30.0, view_angle=math.radians(240.0), view_range=4.0)
    layer.set_people([Person(2.0, 0.0, 0.0, 0.0, seen=0.0, id=1)], stamp=0.0)
    layer.set_people([], stamp=1.0)  # the tracker dropped them: the robot turned its back
    assert layer.observe(9.0, 0.0, 0.0, math.pi) == 1  # past keep_time, behind the robot: held
    assert layer.current(9.0)[1] == [1]
    layer.set_people([], stamp=9.5)
    assert layer.observe(20.0, 0.0, 0.0, 0.0, hidden=lambda *line: True) == 1  # in the view, behind a wall
    assert layer.current(20.0)[1] == [1]
    assert layer.observe(20.2, 0.0, 0.0, math.pi / 2.0, hidden=lambda *line: False) == 0  # looked: gone
    assert layer.current(20.2)[1] == []
    # never looked at: held unseen_keep_time after they were last seen, then gone
    layer.set_people([Person(2.0, 0.0, 0.0, 0.0, seen=40.0, id=2)], stamp=40.0)
    assert layer.observe(60.0, -3.0, 0.0, 0.0) == 1  # 5 m away: beyond view_range
    assert layer.observe(70.1, -3.0, 0.0, 0.0) == 0
    assert layer.current(70.1)[1] == []


def test_without_unseen_keep_time_a_lost_person_lapses_after_keep_time_wherever_they_are():
    layer = ProxemicLayer(keep_time=8.0)
    layer.set_people([Person(2.0, 0.0, 0.0, 0.0, seen=0.0, id=1)], stamp=0.0)
    assert layer.observe(9.0, 0.0, 0.0, math.pi) == 0
    assert layer.current(9.0)[1] == []


def test_people_held_out_of_view_can_be_released():
    layer = ProxemicLayer(keep_time=1.0, unseen_keep_time=30.0, lethal_radius=0.3)
    layer.set_people([Person(1.0, 0.0, 0.0, 0.0, seen=0.0, id=1), Person(-1.0, 0.0, 0.0, 0.0, seen=4.5, id=2)],
                     stamp=4.5)
    layer.observe(5.0, 0.0, 0.0, math.pi)  # 1 behind the robot (held), 2 in front and tracked
    assert layer.release_unseen() == 1
    assert layer.current(5.0)[1] == [2]


def test_the_person_the_robot_is_sent_to_stands_while_announced_tracked_or_not():
    layer = ProxemicLayer(keep_time=8.0, lethal_radius=0.3)
    layer.set_people([Person(1.0, 0.0, 0.0, 0.0, seen=1.0, id=7)], stamp=1.0)
    layer.sent_to(1.1, 0.1, until=3.0)  # approach_me_map's place of her, 0.14 m off her track
    assert layer.current(2.0)[1] == [7]  # tracked: her track, not a second person
    # the robot turned its back on her: her track lapsed, she is still there while announced
    layer.set_people([], stamp=9.5)
    layer.sent_to(1.1, 0.1, until=10.0)
    people, ids = layer.current(9.5)
    assert ids == [SENT_TO_ID] and people.tolist() == [[1.1, 0.1, 0.0, 0.0]]
    c = grid()
    layer.update_costs(c, now=9.5)
    assert c.cost_at(1.125, 0.125) == LETHAL_OBSTACLE  # a plan keeps off her as it did while she was tracked
    # no longer announced (the approach ended): gone
    assert layer.current(10.5)[1] == []
    layer.sent_to(math.nan, 0.0, until=20.0)  # ignored
    assert layer.current(10.5)[1] == []
    layer.clear()
    layer.sent_to(1.1, 0.1, until=12.0)
    layer.clear()
    assert layer.current(11.0)[1] == []


def test_recent_points_are_remembered_for_a_moment():
    mem = RecentPoints(keep=1.5)
    mem.add(10.0, [[1.0, 2.0]])
    mem.add(10.5, np.zeros((0, 2)))
    mem.add(11.0, [[3.0, 4.0], [5.0, 6.0]])
    assert len(mem.get(11.0)) == 3
    assert mem.get(11.6).tolist() == [[3.0, 4.0], [5.0, 6.0]]
    assert len(mem.get(13.0)) == 0


def test_nan_people_are_left_out():
    layer = ProxemicLayer()
    dropped = layer.set_people([Person(math.nan, 0.0, 0.0, 0.0, 1.0), Person(1.0, 1.0, math.inf, 0.0, 1.0),
                                Person(0.0, 0.0, 0.0, 0.0, 1.0)], stamp=1.0)
    assert dropped == 2
    assert len(layer.current(1.0)[0]) == 1


def test_unknown_cells_stay_unknown_and_old_costs_are_kept():
    layer = ProxemicLayer()
    layer.set_people([Person(0.0, 0.0, 0.0, 0.0, 0.0)], stamp=0.0)
    c = grid()
    c.costs[50, 50] = NO_INFORMATION
    c.costs[50, 52] = 200
    layer.update_costs(c, now=0.0)
    assert c.costs[50, 50] == NO_INFORMATION and c.costs[50, 52] == 200


def test_lethal_core_keeps_clear_of_the_robot():
    layer = ProxemicLayer(lethal_radius=0.3)
    layer.set_people([Person(0.0, 0.0, 0.0, 0.0, 0.0)], stamp=0.0)
    c = grid()
    layer.update_costs(c, now=0.0, robot=(0.45, 0.0, 0.25))
    assert c.cost_at(0.025, 0.025) == LETHAL_OBSTACLE
    assert c.cost_at(-0.275, 0.025) == LETHAL_OBSTACLE
    assert c.cost_at(0.275, 0.025) != LETHAL_OBSTACLE  # within 0.25 m of the robot's centre
    assert c.cost_at(0.375, 0.025) < LETHAL_OBSTACLE


def test_trail_of_a_walker():
    layer = ProxemicLayer(trail_time=2.0, trail_radius=0.3)
    for k in range(30):  # walking +x at 0.5 m/s, 10 messages a second
        t = 0.1 * k
        layer.set_people([Person(0.05 * k, 0.0, 0.5, 0.0, seen=t)], stamp=t)
    trail = layer.trail(2.9)
    assert trail[:, 2] == pytest.approx(0.3)
    assert trail[:, 0].min() == pytest.approx(0.45, abs=0.06) and trail[:, 0].max() == pytest.approx(1.45, abs=0.11)
    assert len(trail) < 10  # thinned
    assert len(ProxemicLayer(trail_time=0.0).trail(0.0)) == 0


def test_who_walks_away():
    people = np.array([[1.0, 0.0, 0.4, 0.0],  # ahead, walking on
                       [1.0, 0.0, -0.4, 0.0],  # ahead, coming back
                       [0.0, 1.0, 0.3, 0.3],  # 45 degrees off the line from the robot: 0.3 m/s away
                       [0.0, 1.0, 0.3, 0.0],  # across the line
                       [1.0, 0.0, 0.0, 0.0],  # standing
                       [0.0, 0.0, 0.4, 0.0]])  # at the robot's centre
    assert walking_away(people, 0.0, 0.0, 0.2).tolist() == [True, False, True, False, False, False]
    assert walking_away(people, 0.0, 0.0, 0.35).tolist() == [True, False, False, False, False, False]
    assert walking_away(np.zeros((0, 4)), 0.0, 0.0, 0.2).shape == (0,)


def test_legs_seen_along_a_walk():
    walker = np.array([[2.0, 0.0, 0.4, 0.0]])  # 0.6 m walked in the last 1.5 s: from x 1.4
    points = np.array([[2.1, 0.1], [1.5, -0.2], [1.2, 0.0], [1.45, 0.35], [2.4, 0.0]])
    assert near_walks(points, walker, 0.3, 1.5).tolist() == [True, True, True, False, False]
    standing = np.array([[2.0, 0.0, 0.0, 0.0]])
    assert near_walks(points, standing, 0.3, 1.5).tolist() == [True, False, False, False, False]
    assert not near_walks(points, np.zeros((0, 4)), 0.3, 1.5).any()


def test_a_person_walking_away_is_followed_not_walled_off():
    layer = ProxemicLayer(lethal_radius=0.3, follow_speed=0.2)
    robot = (-1.0, 0.0, 0.25)
    for vx, lethal in ((0.4, False), (-0.4, True), (0.0, True), (0.1, True)):
        layer.set_people([Person(0.0, 0.0, vx, 0.0, 0.0)], stamp=0.0)
        c = grid()
        layer.update_costs(c, now=0.0, robot=robot)
        assert (c.cost_at(0.025, 0.025) == LETHAL_OBSTACLE) == lethal, vx
        assert 0 < c.cost_at(-0.275, 0.025) < LETHAL_OBSTACLE or lethal  # the Gaussian stays
        assert len(layer.followed(0.0, robot[:2])) == (0 if lethal else 1)
    # off (ROS and Florence's default): lethal whoever walks away
    off = ProxemicLayer(lethal_radius=0.3)
    off.set_people([Person(0.0, 0.0, 0.4, 0.0, 0.0)], stamp=0.0)
    c = grid()
    off.update_costs(c, now=0.0, robot=robot)
    assert c.cost_at(0.025, 0.025) == LETHAL_OBSTACLE and len(off.followed(0.0, robot[:2])) == 0


def test_a_corridor_with_a_walker_ahead_is_open_behind_them():
    """The laser sees the legs of a resident walking ahead along a 1.3 m corridor: with follow_speed
    their marks and core are freed and a plan leads along the corridor behind them; coming the other
    way, they close it."""
    src = ObservationSource("scan", clearing=True)
    results = {}
    for follow_speed in (0.0, 0.2):
        for vx in (0.4, -0.4):
            lay = LayeredCostmap(120, 40, 0.05, 0.0, 0.0, static_map=True, sources=[src], inflation_radius=0.4,
                                 proxemic={"lethal_radius": 0.3, "follow_speed": follow_speed, "trail_time": 0.0})
            static = np.zeros((40, 120), dtype=np.int8)
            static[3, :] = static[29, :] = 100  # walls at y 0.15 and 1.45: a corridor 1.3 m wide
            lay.set_static_map(static.ravel(), 120, 40, 0.05, 0.0, 0.0)
            legs = np.array([[3.0, 0.7, 0.165], [3.0, 0.9, 0.165]])
            lay.obstacles.add_observation("scan", (1.0, 0.8, 0.165), legs, stamp=0.0)
            lay.people.set_people([Person(3.0, 0.8, vx, 0.0, 0.0)], stamp=0.0)
            lay.update(1.0, 0.8, 0.0, now=0.0)
            cell = lay.costmap.world_to_map(1.0, 0.8)
            potential = compute_potential(translate_costs(lay.costmap.costs, False, cell), cell)
            results[follow_speed, vx] = bool(np.isfinite(potential[16, 100]))  # (5.0, 0.8), beyond them
            if results[follow_speed, vx]:
                assert lay.costmap.cost_at(3.0, 0.7) < INSCRIBED_INFLATED_OBSTACLE
    assert results == {(0.0, 0.4): False, (0.0, -0.4): False, (0.2, 0.4): True, (0.2, -0.4): False}


# --- the local planner's rule --------------------------------------------------------------------
def straight(v, heading=0.0, steps=20, dt=0.1, x0=0.0):
    t = np.arange(steps) * dt
    return np.stack([x0 + v * t * math.cos(heading), v * t * math.sin(heading), np.full(steps, heading)], axis=1), t


def test_approaching_a_person_is_refused_moving_away_and_turning_are_not():
    person = np.array([[1.0, 0.0, 0.0, 0.0]])
    toward, t = straight(0.5)
    away, _ = straight(-0.3)
    turn = np.column_stack([np.zeros(20), np.zeros(20), np.linspace(0, 1, 20)])
    past, _ = straight(0.5, heading=math.pi / 2)  # sideways: never nearer than 1 m
    points = np.stack([toward, away, turn, past])
    times = np.tile(t, (4, 1))
    refused = approaches(points, times, person, 0.6)
    assert refused.tolist() == [True, False, False, False]
    # a person who walked up to 0.45 m: the robot may still back away or turn, not come nearer
    close = np.array([[0.45, 0.0, 0.0, 0.0]])
    assert approaches(points, times, close, 0.6).tolist() == [True, False, False, False]


def test_a_walker_is_judged_where_they_will_be():
    walker = np.array([[1.0, 1.0, 0.0, -0.5]])  # crossing the robot's way 1 m ahead in 2 s
    toward, t = straight(0.5, steps=30)
    assert approaches(toward[None], t[None], walker, 0.6).tolist() == [True]
    assert approaches(toward[None], t[None], np.array([[1.0, 1.0, 0.0, 0.0]]), 0.6).tolist() == [False]


def test_braking_is_never_refused():
    person = np.array([[0.9, 0.0, 0.0, 0.0]])
    t = np.arange(20) * 0.1
    bx, by = braking_positions(t, (0.0, 0.0, 0.0), 0.5, 0.5)  # stops after 0.25 m
    braking = np.column_stack([bx, by, np.zeros(20)])
    assert bx[-1] == pytest.approx(0.25)
    faster = np.column_stack([np.minimum(bx * 1.5, 0.45), by, np.zeros(20)])
    points = np.stack([braking, faster])
    brake = (0.0, 0.0, 0.0, 0.5, 0.5)
    assert approaches(points, np.tile(t, (2, 1)), person, 0.7, brake=brake).tolist() == [False, True]
    # against standing still instead (brake None) the braking path itself would be refused
    assert approaches(points, np.tile(t, (2, 1)), person, 0.7).tolist() == [True, True]


def test_curving_past_a_person_is_no_way_to_close_in():
    """A robot driving toward a person's legs may brake (turning as it brakes, too) but not curve
    on past them nearer than it stands now, though each step stays about as far as braking straight
    on would be (bench/nav.py seed 3: 0.53 m to 0.42 m between centres so)."""
    t = np.arange(16) * 0.1
    brake = (0.0, 0.0, math.pi, 0.26, 0.5)  # driving west at 0.26 m/s
    legs = np.array([[-0.3, -0.32]])  # 0.44 m away to the south-west
    bx, by = braking_positions(t, brake[:3], brake[3], brake[4])
    th = math.pi - 1.2 * t  # curving north, away from them, at full speed
    cx = np.concatenate([[0.0], np.cumsum(0.026 * np.cos(th[:-1]))])
    cy = np.concatenate([[0.0], np.cumsum(0.026 * np.sin(th[:-1]))])
    curve = np.column_stack([cx, cy, th])
    d = np.hypot(cx - legs[0, 0], cy - legs[0, 1])
    assert np.min(d - np.hypot(bx - legs[0, 0], by - legs[0, 1])) > -0.01  # as far as braking, within tolerance
    assert d.min() < 0.42  # but nearer than now
    ds = np.diff(bx, prepend=0.0)  # braking while turning north at 1.2 rad/s
    braking_turn = np.column_stack([np.cumsum(ds * np.cos(th)), np.cumsum(ds * np.sin(th)), th])
    braking = np.column_stack([bx, by, np.full(16, math.pi)])
    points, times = np.stack([braking, braking_turn, curve]), np.tile(t, (3, 1))
    nobody = np.zeros((0, 4))
    assert approaches(points, times, nobody, 0.6, brake=brake, still=legs).tolist() == [False, False, True]
    # a tracked person standing there: the same
    person = np.array([[-0.3, -0.32, 0.0, 0.0]])
    assert approaches(points, times, person, 0.5, brake=brake).tolist() == [False, False, True]
    # from rest: driving north, away from them, is allowed, south-west toward them is not
    rest = (0.0, 0.0, math.pi, 0.0, 0.5)
    north = np.column_stack([np.zeros(16), 0.2 * t, np.full(16, math.pi / 2)])
    toward = np.column_stack([-0.1 * t, -0.1 * t, np.full(16, -3 * math.pi / 4)])
    assert approaches(np.stack([north, toward]), np.tile(t, (2, 1)), nobody, 0.6, brake=rest,
                      still=legs).tolist() == [False, True]


def test_a_walker_closing_in_is_given_way_to():
    """walker_yield_speed: the robot, at rest or driving, only brakes and turns on the spot while a
    walker would come within the distance; moving away from them is refused too unless they stay
    out of it, and a person standing still is judged as before."""
    rest = (0.0, 0.0, 0.0, 0.0, 0.5)
    t = np.arange(20) * 0.1
    away, _ = straight(-0.3)  # backing away west from a walker overtaking from the east
    along, _ = straight(0.3, heading=math.pi / 2)  # driving north, across their way
    turn = np.column_stack([np.zeros(20), np.zeros(20), np.linspace(0, 1, 20)])
    points, times = np.stack([away, along, turn]), np.tile(t, (3, 1))
    walker = np.array([[0.9, 0.0, -0.5, 0.0]])  # walking west at 0.5 m/s, toward the robot
    assert approaches(points, times, walker, 0.6, brake=rest).tolist() == [False, False, False]
    assert approaches(points, times, walker, 0.6, brake=rest, yield_speed=0.25).tolist() == [True, True, False]
    # slower than yield_speed, or standing: moving away and along stay allowed
    assert approaches(points, times, walker * [1, 1, 0.4, 1], 0.6, brake=rest, yield_speed=0.25).tolist() == \
        [False, False, False]
    # a walker passing 1 m away never comes within 0.6 m of any of them
    passing = np.array([[0.9, 1.0, -0.5, 0.0]])
    assert approaches(points[[0, 2]], times[[0, 2]], passing, 0.6, brake=rest, yield_speed=0.25).tolist() == \
        [False, False]
    # braking from 0.3 m/s while turning a little is braking
    bx, by = braking_positions(t, (0.0, 0.0, 0.0), 0.3, 0.5)
    th = 1.0 * t  # turning at 1 rad/s as it brakes: the arc of the distance braking covers
    ds = np.diff(bx, prepend=0.0)
    curving = np.column_stack([np.cumsum(ds * np.cos(th)), np.cumsum(ds * np.sin(th)), th])
    assert 0.01 < np.hypot(curving[:, 0] - bx, curving[:, 1] - by).max() < 0.05
    on = np.stack([curving, np.column_stack([bx + 0.1 * t, by, np.zeros(20)])])
    brake = (0.0, 0.0, 0.0, 0.3, 0.5)
    assert approaches(on, np.tile(t, (2, 1)), walker, 0.6, brake=brake, yield_speed=0.25).tolist() == [False, True]
    # without brake (the final approach's paths) the rule is off
    assert approaches(points, times, walker, 0.6, yield_speed=0.25).tolist() == [False, False, False]


def test_still_points_count_as_people():
    toward, t = straight(0.5)
    legs = np.array([[1.0, 0.1], [1.0, -0.1]])
    assert approaches(toward[None], t[None], np.zeros((0, 4)), 0.6, still=legs).tolist() == [True]
    short, t_short = straight(0.5, steps=9)  # to 0.4 m: 0.6 m from the legs, more than 0.6 - 0.1
    assert approaches(short[None], t_short[None], np.zeros((0, 4)), 0.6, still=legs).tolist() == [False]
    assert approaches(toward[None], t[None], np.zeros((0, 4)), 0.6, still=legs + 3.0).tolist() == [False]


def test_the_person_approached_on_purpose_is_kept_at_her_own_distance():
    """approach_me_map's user (move_base/approach_target): the tracked person nearest the announced
    point within 0.5 m gets approach_person_distance, the others min_person_distance; her legs
    (within 0.6 m of her) are hers, a stranger's stay."""
    people = np.array([[1.0, 0.0, 0.0, 0.0], [3.0, 0.0, 0.0, 0.0]])
    still = np.array([[0.75, 0.1], [0.75, -0.1], [2.7, 0.0]])  # her shins; a leg near the other
    dist, kept, her = approach_exemption(people, still, (1.1, 0.05), 0.45, 0.6)  # her track 0.11 m off
    assert her == 0 and dist.tolist() == [0.45, 0.6]
    assert kept.tolist() == [[2.7, 0.0]]
    # a robot driving at her to 0.5 m from her centre: allowed for her, refused for anybody else
    toward, t = straight(0.25)  # 0 .. 0.475 m along x
    assert approaches(toward[None], t[None], people[:1], 0.6, per_person=dist[:1]).tolist() == [False]
    assert approaches(toward[None], t[None], people[:1], 0.6).tolist() == [True]
    assert approaches(toward[None], t[None], people[:1], 0.6, per_person=[0.6]).tolist() == [True]
    # nearer than approach_person_distance is refused for her too
    on, t_on = straight(0.35)  # to 0.665 m: 0.335 m from her
    assert approaches(on[None], t_on[None], people[:1], 0.6, per_person=dist[:1]).tolist() == [True]
    # her legs would refuse the drive if still counted
    assert approaches(toward[None], t[None], np.zeros((0, 4)), 0.6, still=still[:2]).tolist() == [True]


def test_no_exemption_without_a_tracked_person_at_the_target_but_her_legs_are_still_hers():
    people = np.array([[3.0, 0.0, 0.0, 0.0]])
    still = np.array([[0.8, 0.1], [3.2, 0.0]])
    dist, kept, her = approach_exemption(people, still, (1.0, 0.0), 0.45, 0.6)  # the tracker lost her
    assert her == -1 and dist.tolist() == [0.6]
    assert kept.tolist() == [[3.2, 0.0]]
    for target in (None, (math.nan, 0.0)):
        dist, kept, her = approach_exemption(people, still, target, 0.45, 0.6)
        assert her == -1 and dist.tolist() == [0.6] and len(kept) == 2
    dist, kept, her = approach_exemption(np.zeros((0, 4)), None, (1.0, 0.0), 0.45, 0.6)
    assert her == -1 and dist.shape == (0,) and kept.shape == (0, 2)


# --- giving way ----------------------------------------------------------------------------------
def corridor_with_a_door():
    """A corridor along x (y 0..1.2 free) with a door going south at x 1.0..1.9 into a room."""
    c = Costmap2D(120, 80, 0.05, -1.0, -2.0)
    c.costs[...] = LETHAL_OBSTACLE
    c.costs[40:64, :] = FREE_SPACE  # corridor y 0.0 .. 1.2
    c.costs[0:40, 40:58] = FREE_SPACE  # door and room x 1.0 .. 1.9, south of the corridor
    c.costs[0:2, :] = LETHAL_OBSTACLE
    return c


def test_give_way_leaves_the_corridor_through_the_door_behind():
    c = corridor_with_a_door()
    robot = (2.6, 0.6)  # east of the door
    person = np.array([[3.2, 0.6, 0.0, 0.0]])  # standing in the corridor east of the robot, waiting
    c.costs[40:64, 82:86] = LETHAL_OBSTACLE  # the person's lethal core blocks the corridor
    cell = c.world_to_map(*robot)
    potential = compute_potential(translate_costs(c.costs, True, cell), cell)
    target = give_way_cells(potential, c, robot, person, keep_off=0.75, min_distance=1.0)
    assert target is not None
    x, y = target
    assert 1.0 <= x <= 1.9 and y <= 0.6 - 0.75 + 1e-9  # in the door, off the corridor's line
    # nowhere to go: a corridor without a door
    c.costs[0:40, :] = LETHAL_OBSTACLE
    potential = compute_potential(translate_costs(c.costs, True, cell), cell)
    assert give_way_cells(potential, c, robot, person, keep_off=0.75, min_distance=1.0) is None



def test_give_way_from_a_waiting_person_keeps_off_the_way_they_go_on_beyond_the_robot():
    """Nav bench seed 1: a resident waited at the kitchen door for the robot, which gave way 0.96 m
    to the side of her line but 1.5 m on into the kitchen, where she then walked. Beyond the robot a
    still person's way widens (GIVE_WAY_FAN)."""
    c = Costmap2D(140, 120, 0.05, -1.5, -3.0)
    c.costs[...] = LETHAL_OBSTACLE
    c.costs[52:68, 10:70] = FREE_SPACE  # a corridor y -0.4 .. 0.4, x -1.0 .. 2.0 (the door)
    c.costs[10:110, 70:130] = FREE_SPACE  # the room beyond: x 2.0 .. 5.0, y -2.5 .. 2.5
    person = np.array([[0.2, 0.0, 0.0, 0.0]])  # waiting in the corridor
    robot = (1.2, 0.0)
    cell = c.world_to_map(*robot)
    potential = compute_potential(translate_costs(c.costs, True, cell), cell)
    x, y = give_way_cells(potential, c, robot, person, keep_off=0.75, min_distance=1.0)
    along = x - 0.2
    assert x >= 2.0  # no room in the corridor: into the room
    assert abs(y) >= 0.75 + (along - 1.0) * GIVE_WAY_FAN - 1e-9
    assert abs(y) > 1.2  # not just beside her line at the room's edge (the old rule's (2.0, 0.75))

def test_a_person_who_stopped_keeps_the_heading_they_walked_on():
    layer = ProxemicLayer(keep_time=2.0, unseen_keep_time=30.0)
    layer.set_people([Person(0.0, 0.0, -0.5, 0.0, seen=1.0, id=3), Person(2.0, 2.0, 0.0, 0.1, seen=1.0, id=4)],
                     stamp=1.0)
    layer.set_people([Person(-0.5, 0.0, 0.0, 0.0, seen=2.0, id=3), Person(2.0, 2.1, 0.0, 0.0, seen=2.0, id=4)],
                     stamp=2.0)  # she stopped (for the robot); he never walked faster than 0.1 m/s
    headings = layer.headings([3, 4, 99])
    assert headings[0] == pytest.approx([-1.0, 0.0])
    assert np.isnan(headings[1:]).all()
    layer.set_people([Person(-0.5, 0.0, 0.0, 0.0, seen=1.0 + HEADING_KEEP + 0.5, id=3)], stamp=1.0 + HEADING_KEEP + 0.5)
    assert np.isnan(layer.headings([3])).all()  # walked too long ago
    layer.clear()
    assert np.isnan(layer.headings([3])).all()


def test_give_way_keeps_off_the_way_a_stopped_walker_was_going():
    """Nav bench seed 2: Alice, walking west through the kitchen's opening, stopped 0.5 m from the
    robot; the line from her to the robot ran south-west, and the robot gave way 1 m west of her,
    on the line she had been walking, where 8 s later the two were 17 mm apart between bodies."""
    c = Costmap2D(120, 120, 0.05, -3.0, -3.0)
    c.costs[...] = LETHAL_OBSTACLE
    c.costs[46:72, :] = FREE_SPACE  # a passage along x, y -0.7 .. 0.6
    person = np.array([[0.0, 0.0, 0.0, 0.0]])  # standing
    robot = (-0.25, -0.42)
    cell = c.world_to_map(*robot)
    potential = compute_potential(translate_costs(c.costs, True, cell), cell)
    heading = np.array([[-1.0, 0.0]])  # she had been walking west
    x, y = give_way_cells(potential, c, robot, person, keep_off=0.75, min_distance=1.0, headings=heading)
    assert x > 1.0  # behind her: the passage has no room beside her way on
    # and off the line toward the robot as before
    ux, uy = np.array(robot) / math.hypot(*robot)
    along, across = x * ux + y * uy, abs(-x * uy + y * ux)
    assert across >= 0.75 + max(0.0, along - math.hypot(*robot)) * GIVE_WAY_FAN - 1e-9 or along < -1.0
    # without her heading the nearest place is on her way on, west of her: what the robot did
    x0, y0 = give_way_cells(potential, c, robot, person, keep_off=0.75, min_distance=1.0)
    assert x0 < -0.5 and abs(y0) < 0.75
    # giving way is a step aside: the place behind her is out of a 0.9 m reach, so none
    assert give_way_cells(potential, c, robot, person, keep_off=0.75, min_distance=1.0, headings=heading,
                          reach=0.9) is None
    # an unknown heading (NaN) changes nothing
    assert give_way_cells(potential, c, robot, person, keep_off=0.75, min_distance=1.0,
                          headings=np.full((1, 2), np.nan)) == (x0, y0)


# --- keep-out ------------------------------------------------------------------------------------
def test_keepout_marks_lethal_before_inflation_and_changes_nothing_else():
    lay = LayeredCostmap(40, 40, 0.05, 0.0, 0.0, static_map=True, inflation_radius=0.3, keepout=True)
    static = np.zeros((40, 40), dtype=np.int8)
    lay.set_static_map(static.ravel(), 40, 40, 0.05, 0.0, 0.0)
    keep = np.full((40, 40), -1, dtype=np.int8)  # unknown: no say
    keep[20, 20] = 100
    keep[5, 5] = 0
    assert lay.set_keepout_map(keep.ravel(), 40, 40, 0.05, 0.0, 0.0) is True
    lay.update(0.0, 0.0)
    assert lay.costmap.costs[20, 20] == LETHAL_OBSTACLE
    assert lay.costmap.costs[20, 22] == INSCRIBED_INFLATED_OBSTACLE or lay.costmap.costs[20, 22] > 100
    assert lay.costmap.costs[5, 5] == FREE_SPACE and lay.costmap.costs[0, 0] == FREE_SPACE


def test_keepout_of_another_resolution_is_placed_by_its_own_origin():
    lay = LayeredCostmap(40, 40, 0.05, 0.0, 0.0, static_map=True, inflation_radius=0.0, keepout=True)
    lay.set_static_map(np.zeros(1600, dtype=np.int8), 40, 40, 0.05, 0.0, 0.0)
    keep = np.zeros((10, 10), dtype=np.int8)
    keep[5, 5] = 100  # x 1.0..1.2, y 1.0..1.2 at 0.2 m cells
    assert lay.set_keepout_map(keep.ravel(), 10, 10, 0.2, 0.0, 0.0) is False
    lay.update(0.0, 0.0)
    assert lay.costmap.cost_at(1.1, 1.1) == LETHAL_OBSTACLE
    assert lay.costmap.cost_at(1.25, 1.1) == FREE_SPACE
    assert int(np.count_nonzero(lay.costmap.costs == LETHAL_OBSTACLE)) == 16  # 4 x 4 cells of 5 cm
    assert KeepoutLayer().has_map is False


def test_a_person_behind_a_wall_of_the_map_is_held_and_forgotten_on_demand():
    proxemic = {"keep_time": 1.0, "unseen_keep_time": 30.0, "lethal_radius": 0.3}
    lay = LayeredCostmap(60, 40, 0.05, 0.0, 0.0, static_map=True, inflation_radius=0.0, proxemic=proxemic)
    static = np.zeros((40, 60), dtype=np.int8)
    static[:, 30] = 100  # a wall at x 1.5
    lay.set_static_map(static.ravel(), 60, 40, 0.05, 0.0, 0.0)
    assert lay.map_hides(0.5, 1.0, 2.5, 1.0) and not lay.map_hides(0.5, 1.0, 1.2, 1.0)
    assert not lay.map_hides(2.0, 1.0, 2.5, 1.0)
    lay.people.set_people([Person(2.5, 1.0, 0.0, 0.0, seen=0.0, id=1)], stamp=0.0)
    lay.update(0.5, 1.0, 0.0, now=5.0)  # facing the person, 2 m away, the wall between
    assert lay.costmap.cost_at(2.5, 1.0) == LETHAL_OBSTACLE
    assert lay.forget_unseen_people() == 1
    assert lay.costmap.cost_at(2.5, 1.0) == FREE_SPACE
    lay.people.set_people([Person(1.2, 1.0, 0.0, 0.0, seen=0.0, id=2)], stamp=0.0)
    lay.update(0.5, 1.0, 0.0, now=5.0)  # on the robot's side of the wall, in view: lapsed
    assert lay.costmap.cost_at(1.2, 1.0) == FREE_SPACE and lay.forget_unseen_people() == 0


def test_map_only_and_unmapped_marks():
    src = ObservationSource("scan", clearing=True)
    lay = LayeredCostmap(40, 40, 0.05, 0.0, 0.0, static_map=True, sources=[src], inflation_radius=0.2, keepout=True)
    static = np.zeros((40, 40), dtype=np.int8)
    static[:, 30] = 100  # a wall at x 1.5
    lay.set_static_map(static.ravel(), 40, 40, 0.05, 0.0, 0.0)
    lay.set_keepout_map(np.zeros(1600, dtype=np.int8), 40, 40, 0.05, 0.0, 0.0)
    # the laser sees the wall (a little off, as the localization is) and a person's two legs
    wall = np.column_stack([np.full(10, 1.53), np.linspace(0.2, 1.8, 10), np.full(10, 0.165)])
    legs = np.array([[0.8, 0.9, 0.165], [0.8, 1.1, 0.165]])
    lay.obstacles.add_observation("scan", (0.2, 1.0, 0.165), np.vstack([wall, legs]), stamp=0.0)
    lay.update(0.2, 1.0)
    marks = lay.unmapped_marks(0.2, 1.0, 2.0)
    assert len(marks) == 2 and np.allclose(np.sort(marks[:, 1]), [0.925, 1.125])
    # the person walked on: the laser sees only the wall now, the legs' old marks do not count
    lay.obstacles.add_observation("scan", (0.2, 1.0, 0.165), wall, stamp=0.1)
    assert len(lay.unmapped_marks(0.2, 1.0, 2.0)) == 0
    assert lay.costmap.cost_at(0.82, 0.92) == LETHAL_OBSTACLE
    only = lay.map_only()
    assert only.cost_at(0.82, 0.92) == FREE_SPACE and only.cost_at(1.52, 1.0) == LETHAL_OBSTACLE


# --- why a failed plan is people's doing ----------------------------------------------------------
def test_a_failed_plan_is_blocked_by_people_only_where_the_maps_have_a_way():
    near = "a person at (1.00, 2.00), 0.80 m away"
    assert blocked_plan_reason(near, True) == f"{near} stands in the way (the map has a way)"
    assert blocked_plan_reason(near, False) == ""  # the maps have no way either: not people's doing
    assert blocked_plan_reason("", False, waiting=True) == ""


def test_marks_out_of_view_keep_a_wait_going_but_start_none():
    assert blocked_plan_reason("", True) == ""  # a stale mark: the recoveries clear it at once
    why = blocked_plan_reason("", True, waiting=True)  # turned away from the people waited for
    assert "out of their view now" in why and "the map has a way" in why


def test_backing_up_toward_a_person_behind_is_told():
    heading = 0.3
    start = np.array([1.0, 2.0, heading])
    u = np.array([math.cos(heading), math.sin(heading)])
    def traj(d):  # straight, d [m] along the heading
        end = start[:2] + d * u
        return np.array([start, [*end, heading]])
    points = np.stack([traj(-0.1), traj(0.2), traj(0.0)])
    behind = [*(start[:2] - 1.0 * u), 0.0, 0.0]
    assert backs_toward(points, [behind], 1.5).tolist() == [True, False, False]
    assert backs_toward(points, [behind], 0.8).tolist() == [False, False, False]  # farther than the distance
    ahead = [*(start[:2] + 1.0 * u), 0.0, 0.0]
    assert backs_toward(points, [ahead], 1.5).tolist() == [False, False, False]
    assert backs_toward(points, np.zeros((0, 4)), 1.5).tolist() == [False, False, False]


def test_a_held_person_who_lapsed_is_not_counted_as_held_any_more():
    layer = ProxemicLayer(keep_time=1.0, unseen_keep_time=5.0)
    layer.set_people([Person(1.0, 0.0, 0.0, 0.0, seen=0.0, id=1)], stamp=0.0)
    assert layer.observe(2.0, 0.0, 0.0, math.pi) == 1  # behind the robot: held
    layer.set_people([], stamp=6.0)  # past unseen_keep_time: gone with the next message
    assert layer.release_unseen() == 0
