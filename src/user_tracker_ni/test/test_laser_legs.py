"""Leg detection on synthetic scans: two legs, a wall, a person by a wall, table legs, the
inverted laser, NaN and inf."""

import math

import numpy as np
import pytest
from user_tracker_ni.laser_legs import (
    LegParams,
    detect,
    find_legs,
    in_view,
    pair_legs,
    partner_beyond_edge,
    partner_hidden,
    scan_points,
)

from florence_common import pose

pytestmark = pytest.mark.unit

N = 683  # URG-04LX: -120..120 deg at 1024 steps a turn
INC = 2 * math.pi / 1024
AMIN = -(N - 1) / 2 * INC
P = LegParams().validate()
IDENTITY = np.eye(4)


def render(circles, walls=(), max_range=5.6):
    """Ranges of a laser at the origin (x forward) seeing circles (x, y, r) and walls x = c."""
    a = AMIN + INC * np.arange(N)
    d = np.stack([np.cos(a), np.sin(a)], 1)
    best = np.full(N, np.inf)
    for cx, cy, r in circles:
        b = d @ np.array([cx, cy])
        disc = b * b - (cx * cx + cy * cy - r * r)
        t = b - np.sqrt(np.where(disc >= 0, disc, np.nan))
        best = np.fmin(best, np.where((disc >= 0) & (t > 0), t, np.inf))
    for wx in walls:
        with np.errstate(divide="ignore"):
            t = np.where(d[:, 0] > 1e-6, wx / d[:, 0], np.inf)
        best = np.fmin(best, t)
    return np.where(best <= max_range, best, np.inf)


def run(ranges, laser_pose=IDENTITY):
    return detect(ranges, AMIN, INC, 0.02, 5.6, laser_pose, P)


def test_two_legs_make_one_person_between_them():
    legs, people = run(render([(2.0, 0.10, 0.065), (2.0, -0.10, 0.065)]))
    assert len(legs) == 2 and len(people) == 1
    assert people[0] == pytest.approx((2.0, 0.0), abs=0.02)  # the legs' centres, not their near sides


def test_two_people_side_by_side():
    _, people = run(render([(2.0, 0.6, 0.06), (2.0, 0.4, 0.06), (2.0, -0.4, 0.06), (2.0, -0.6, 0.06)]))
    assert sorted(np.round(people[:, 1], 1)) == pytest.approx([-0.5, 0.5], abs=0.06)


def test_a_wall_and_wide_objects_are_not_legs():
    legs, people = run(render([(2.0, 1.0, 0.25)], walls=[3.0]))  # a 0.5 m pot and a wall
    assert len(legs) == 0 and len(people) == 0


def test_a_person_in_front_of_a_wall_is_seen():
    _, people = run(render([(2.0, 0.1, 0.065), (2.0, -0.1, 0.065)], walls=[2.6]))
    assert len(people) == 1


def test_a_person_at_a_slant_is_both_legs_though_one_hides_part_of_the_other():
    """The far leg goes on behind the near one: it stands out on one side only. Dropped, the person
    was the near leg alone, 0.08 m short of their centre (florence_sim: a person 1 m ahead facing
    41 deg off the line of sight, the robot 1 cm aside), and follow_me stood 1.08 m behind her."""
    near, far = (1.0, -0.066), (1.15, 0.05)
    legs, people = run(render([(*near, 0.065), (*far, 0.065)], walls=[3.0]))
    assert len(legs) == 2 and len(people) == 1
    centre = (np.array(near) + far) / 2
    assert people[0] == pytest.approx(centre, abs=0.03)
    # a slice of wall seen between two legs in front of it stands out on neither side: no leg
    legs, _ = run(render([(2.0, -0.1, 0.065), (2.0, 0.1, 0.065)], walls=[2.2]))
    assert len(legs) == 2


def test_a_leg_touching_the_wall_is_not_seen():
    """Standing against the wall, a leg does not stand out from it: missed (the Kinect's job)."""
    legs, _ = run(render([(2.5, 0.0, 0.065)], walls=[2.56]))
    assert len(legs) == 0


def test_the_inverted_laser_through_its_pose():
    """Rolled by pi (the Florence mount): the scan runs clockwise; the pose puts points right."""
    inverted = pose.transform_matrix((0.06, 0.0, 0.15), (1.0, 0.0, 0.0, 0.0))
    ranges = render([(2.0, 0.6, 0.065), (2.0, 0.4, 0.065)])[::-1]  # what an upside-down laser reports
    _, people = run(ranges, inverted)
    assert people[0] == pytest.approx((2.06, 0.5), abs=0.02)  # on the robot's left, where they stand


def test_what_lies_outside_the_scans_bearings_is_out_of_view():
    """-120..+120 degrees of the laser: behind the robot it sees nothing, upright or upside down."""
    amax = AMIN + INC * (N - 1)
    at = [(math.cos(math.radians(b)), math.sin(math.radians(b))) for b in (0, 100, -100, 125, -125, 180)]
    expected = [True, True, True, False, False, False]
    assert in_view(at, AMIN, amax, IDENTITY).tolist() == expected
    # the Florence mount: rolled by pi at the robot's front; bearings from the laser itself
    inverted = pose.transform_matrix((0.06, 0.0, 0.15), (1.0, 0.0, 0.0, 0.0))
    shifted = [(x + 0.06, y) for x, y in at]
    assert in_view(shifted, AMIN, amax, inverted).tolist() == expected
    # turned: the robot faces +y in the output frame
    turned = pose.transform_matrix((1.0, 2.0, 0.15), (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)))
    assert in_view([(1.0, 3.0), (1.0, 1.0), (2.0, 2.0)], AMIN, amax, turned).tolist() == [True, False, True]
    # a margin inside either end; a scan all round sees every bearing
    edge = [(math.cos(math.radians(118)), math.sin(math.radians(118)))]
    assert in_view(edge, AMIN, amax, IDENTITY, margin=0.0).tolist() == [True]
    assert in_view(edge, AMIN, amax, IDENTITY, margin=0.1).tolist() == [False]
    assert in_view([(-1.0, 0.0)], -math.pi, math.pi, IDENTITY).tolist() == [True]
    assert in_view(np.zeros((0, 2)), AMIN, amax, IDENTITY).shape == (0,)


def test_a_lone_leg_at_the_end_of_the_view_may_have_its_partner_beyond_it():
    amax = AMIN + INC * (N - 1)
    legs = [(2.0 * math.cos(math.radians(b)), 2.0 * math.sin(math.radians(b))) for b in (0, 90, 115, -115, -108, -100)]
    # at 2 m a 0.5 m stride is 14 degrees across: within it of the 120 degree ends
    assert partner_beyond_edge(legs, AMIN, amax, IDENTITY, P).tolist() == [False, False, True, True, True, False]
    near = [(0.5 * math.cos(math.radians(75)), 0.5 * math.sin(math.radians(75)))]  # 45 degrees off at 0.5 m
    assert partner_beyond_edge(near, AMIN, amax, IDENTITY, P).tolist() == [True]
    assert partner_beyond_edge(np.zeros((0, 2)), AMIN, amax, IDENTITY, P).shape == (0,)


def test_nan_inf_and_empty_scans():
    ranges = render([(2.0, 0.1, 0.065), (2.0, -0.1, 0.065)])
    ranges[::7] = np.nan
    ranges[3::11] = np.inf
    _, people = run(ranges)
    assert len(people) == 1
    assert [len(x) for x in run(np.full(N, np.nan))] == [0, 0]
    assert [len(x) for x in detect([], AMIN, INC, 0.02, 5.6, IDENTITY, P)] == [0, 0]


def test_pairing_is_a_matching():
    legs = np.array([[0.0, 0.0], [0.3, 0.0], [0.6, 0.0], [3.0, 3.0]])
    people = pair_legs(legs, P)
    assert len(people) == 3  # (0, 0.3) paired, 0.6 and (3, 3) alone; no leg counted twice
    assert people[0] == pytest.approx((0.15, 0.0))


def test_scan_points_places_returns():
    xy, valid = scan_points([1.0, np.nan, 2.0], 0.0, math.pi / 2, 0.02, 5.6, IDENTITY)
    assert valid.tolist() == [True, False, True]
    assert xy[0] == pytest.approx((1.0, 0.0)) and xy[2] == pytest.approx((-2.0, 0.0), abs=1e-9)
    assert len(find_legs(xy, valid, (0.0, 0.0), P)) == 0


def test_chair_and_table_legs_are_too_thin_for_shins():
    """3 and 5 cm legs (a chair's, a table's, a lamp's pole) are no legs; 10 cm shins are."""
    legs, _ = run(render([(2.0, 0.5, 0.015), (2.0, 0.1, 0.025), (2.0, -0.4, 0.05)]))
    assert len(legs) == 1 and legs[0] == pytest.approx((2.0, -0.4), abs=0.03)


def test_a_beam_without_a_return_does_not_split_a_leg():
    ranges = render([(2.0, 0.1, 0.065), (2.0, -0.1, 0.065)])
    hit = np.flatnonzero(np.isfinite(ranges))
    ranges[hit[2]] = np.nan  # a dropout inside the first leg
    legs, people = run(ranges)
    assert len(legs) == 2 and len(people) == 1


def test_beam_ends_for_free_space():
    from user_tracker_ni.laser_legs import beam_ends

    ends, hit = beam_ends([1.0, np.inf, np.nan, 0.01], 0.0, math.pi / 2, 0.02, 5.6, IDENTITY, 5.0)
    assert hit.tolist() == [True, False, False, False]
    assert ends[0] == pytest.approx((1.0, 0.0)) and ends[1] == pytest.approx((0.0, 5.0), abs=1e-9)
    assert np.isnan(ends[2]).all() and np.isnan(ends[3]).all()


def test_pairs_know_their_legs():
    people, members = pair_legs(np.array([[0.0, 0.0], [0.3, 0.0], [3.0, 3.0]]), P, members=True)
    assert members == [(0, 1), (2,)] and people[0] == pytest.approx((0.15, 0.0))


def test_a_lone_leg_whose_partner_another_person_may_hide_is_told():
    """Two people crossing, as the laser sees them: Alice's legs 1.9 m away; of Bob, 2.5 m away and
    beside her line of sight, one leg in view and the other behind her. Bob's lone leg is told (his
    centre may be a stride off it, toward her); a lone leg with nothing nearer beside it (its partner
    behind itself), and a leg with a wall behind it, are not."""
    ranges = render([(1.9, 0.1, 0.065), (1.9, -0.08, 0.065), (2.5, -0.3, 0.065)], walls=[3.5])
    xy, valid = scan_points(ranges, AMIN, INC, 0.02, 5.6, IDENTITY)
    legs = find_legs(xy, valid, (0.0, 0.0), P)
    bob = legs[np.argmax(legs[:, 0])]
    assert bob == pytest.approx((2.5, -0.3), abs=0.05)
    assert partner_hidden(xy, valid, (0.0, 0.0), [bob], P).tolist() == [True]
    alone = render([(2.5, -0.3, 0.065)], walls=[3.5])
    xy, valid = scan_points(alone, AMIN, INC, 0.02, 5.6, IDENTITY)
    (leg,) = find_legs(xy, valid, (0.0, 0.0), P)
    assert partner_hidden(xy, valid, (0.0, 0.0), [leg], P).tolist() == [False]
    assert partner_hidden(xy, valid, (0.0, 0.0), np.zeros((0, 2)), P).tolist() == []


def test_a_person_standing_side_on_is_placed_behind_their_one_leg_in_view():
    """Side-on, one leg hides the other: the person's centre lies behind the leg in view, not at it.
    Not so for a lone leg whose partner something nearer may hide (where the partner is nobody knows),
    one with something beside it about as far (the partner may be that, not taken for a leg) or both
    legs seen as one (its centre is theirs already)."""
    def people_of(circles, walls=(3.5,), params=P):
        ranges = render(circles, walls=walls)
        xy, valid = scan_points(ranges, AMIN, INC, 0.02, 5.6, IDENTITY)
        _, widths = find_legs(xy, valid, (0.0, 0.0), params, widths=True)
        return detect(ranges, AMIN, INC, 0.02, 5.6, IDENTITY, params)[1], widths

    centre = np.array([1.1, 0.3])
    along = centre / np.linalg.norm(centre)
    side_on = [(*(centre - 0.1 * along), 0.065), (*(centre + 0.1 * along), 0.065)]
    (person,), (width,) = people_of(side_on)
    assert width < P.lone_width
    assert np.linalg.norm(person - centre) == pytest.approx(0.1 - P.lone_shift, abs=0.015)
    (at_leg,), _ = people_of(side_on, params=LegParams(lone_shift=0.0))
    assert np.linalg.norm(at_leg - centre) == pytest.approx(0.1, abs=0.015)
    # Bob's leg beside Alice's line of sight: his partner may be behind her, not behind his leg
    people, _ = people_of([(1.9, 0.1, 0.065), (1.9, -0.08, 0.065), (2.5, -0.3, 0.065)])
    bob = people[np.argmax(people[:, 0])]
    assert bob == pytest.approx((2.5, -0.3), abs=0.05)
    # a leg with something beside it about as far (its partner, maybe, seen but not taken for a leg) is not
    people, _ = people_of([(2.0, -0.1, 0.065), (2.1, 0.25, 0.16)])
    assert len(people) == 1 and people[0] == pytest.approx((2.0, -0.1), abs=0.03)
    # a wide cluster (both legs as one) is not moved
    people, widths = people_of([(2.0, 0.0, 0.1)])
    assert widths[0] > P.lone_width and people[0] == pytest.approx((2.0, 0.0), abs=0.04)
    with pytest.raises(ValueError):
        LegParams(lone_shift=0.6).validate()
