"""The tracker on synthetic detection streams: crossing paths, occlusion, leaving and
re-entering, laser hand-off, laser-only confirmation, Stop."""

import math

import numpy as np
import pytest
from user_tracker_ni.tracker import KINECT, LASER, Detection, Tracker, TrackerParams

from user_tracker_ni import reid

pytestmark = pytest.mark.unit

RED = reid.signature(np.tile([[200, 20, 20]], (200, 1)))
BLUE = reid.signature(np.tile([[20, 40, 200]], (200, 1)))
GREEN = reid.signature(np.tile([[30, 180, 40]], (200, 1)))
RATE = 15.0  # [Hz] Kinect frames


def kinect(x, y, sig, rng):
    return Detection(x + rng.normal(0, 0.03), y + rng.normal(0, 0.03), KINECT, 0.08, sig)


def laser(x, y, rng, free=True):
    """A leg pair; ``free``: in floor the laser saw free before (a walking person's next step)."""
    return Detection(x + rng.normal(0, 0.02), y + rng.normal(0, 0.02), LASER, 0.05, free=free)


def by_position(tracker, x, y):
    """The published track nearest (x, y)."""
    tracks = tracker.published()
    return min(tracks, key=lambda tr: math.hypot(tr.position[0] - x, tr.position[1] - y))


def test_crossing_paths_keep_their_ids():
    rng = np.random.default_rng(1)
    tracker = Tracker()
    ids = {"a": set(), "b": set()}
    for k in range(int(8 * RATE)):
        t = k / RATE
        a = (0.5 * t, 0.0)  # east along y = 0
        b = (2.0, -2.0 + 0.5 * t)  # north along x = 2: both at (2, 0) at t = 4 s
        tracker.update(t, [kinect(*a, RED, rng), kinect(*b, BLUE, rng)], KINECT)
        if t > 0.5 and math.hypot(a[0] - b[0], a[1] - b[1]) > 0.3:
            ids["a"].add(by_position(tracker, *a).pid)
            ids["b"].add(by_position(tracker, *b).pid)
    assert len(tracker.published()) == 2
    assert len(ids["a"]) == 1 and len(ids["b"]) == 1 and ids["a"] != ids["b"], ids


def test_a_short_occlusion_keeps_the_track():
    rng = np.random.default_rng(2)
    tracker = Tracker()
    seen = set()
    for k in range(int(6 * RATE)):
        t = k / RATE
        occluded = 2.0 <= t < 2.6  # 0.6 s behind furniture: shorter than the 1 s timeout
        tracker.update(t, [] if occluded else [kinect(1.0 + 0.4 * t, 1.0, RED, rng)], KINECT)
        seen |= {(tr.ni_id, tr.pid) for tr in tracker.published()}
    assert len(seen) == 1
    (track,) = tracker.published()
    assert track.position[0] == pytest.approx(1.0 + 0.4 * (6 - 1 / RATE), abs=0.1)
    assert track.velocity[0] == pytest.approx(0.4, abs=0.1)


def test_leaving_and_returning_gets_the_old_persistent_id_and_a_new_ni_id():
    rng = np.random.default_rng(3)
    tracker = Tracker()
    for k in range(int(2 * RATE)):
        tracker.update(k / RATE, [kinect(2.0, 0.0, RED, rng), kinect(2.0, 1.5, GREEN, rng)], KINECT)
    (red, green) = sorted(tracker.published(), key=lambda tr: tr.position[1])
    first_red, first_green = (red.pid, red.ni_id), (green.pid, green.ni_id)
    # red walks out of view for 3 s (dropped after 1 s); a blue stranger arrives meanwhile
    for k in range(int(2 * RATE), int(5 * RATE)):
        tracker.update(k / RATE, [kinect(2.0, 1.5, GREEN, rng), kinect(3.0, -1.0, BLUE, rng)], KINECT)
    assert {tr.pid for tr in tracker.published()} == {first_green[0], max(first_red[0], first_green[0]) + 1}
    for k in range(int(5 * RATE), int(7 * RATE)):
        tracker.update(k / RATE, [kinect(2.5, 0.3, RED, rng), kinect(2.0, 1.5, GREEN, rng),
                                  kinect(3.0, -1.0, BLUE, rng)], KINECT)
    back = by_position(tracker, 2.5, 0.3)
    assert back.pid == first_red[0], "the returning person gets their persistent id back"
    assert back.ni_id != first_red[1], "and a new per-appearance id, as OpenNI's"
    assert by_position(tracker, 2.0, 1.5).ni_id == first_green[1], "the one who stayed keeps hers"


def test_laser_carries_a_person_the_kinect_lost():
    rng = np.random.default_rng(4)
    tracker = Tracker()
    t = 0.0
    for _ in range(10):  # seen by both
        tracker.update(t, [kinect(1.5, 0.0, RED, rng)], KINECT)
        tracker.update(t + 0.01, [laser(1.5, 0.0, rng)], LASER)
        t += 0.1
    (track,) = tracker.published()
    ids = (track.pid, track.ni_id)
    for k in range(50):  # walks beside the robot, out of the Kinect's view: the laser alone for 5 s
        tracker.update(t, [], KINECT)
        tracker.update(t + 0.01, [laser(1.5 - 0.03 * k, 0.02 * k, rng)], LASER)
        t += 0.1
    (track,) = tracker.published()
    assert (track.pid, track.ni_id) == ids
    assert track.position == pytest.approx((1.5 - 0.03 * 49, 0.02 * 49), abs=0.1)


def test_laser_alone_confirms_only_legs_that_walk():
    rng = np.random.default_rng(5)
    tracker = Tracker()
    t = 0.0
    for k in range(40):  # 4 s: a table's legs at (3, 3) and (3, 3.5); a person walking from (0, 2)
        tracker.update(t, [laser(3.0, 3.0, rng, free=False), laser(3.0, 3.5, rng, free=False),
                           laser(0.0 + 0.05 * k, 2.0, rng)], LASER)
        t += 0.1
    (walker,) = tracker.published()
    assert walker.position == pytest.approx((0.05 * 39, 2.0), abs=0.1)
    assert walker.origin == LASER
    assert walker.pid is not None  # no colour yet: a new persistent id after id_wait


def test_a_person_who_stops_in_free_floor_is_confirmed_by_the_laser_alone():
    """A resident walks 0.2 m and halts in front of the robot, too near for the Kinect: her legs
    stand where the laser saw free floor, so the dwell rule confirms her after laser_dwell_hits
    scans; the same legs where the beams always ended (a table's) never confirm."""
    rng = np.random.default_rng(11)
    p = TrackerParams()
    tracker = Tracker(p)
    t, confirmed_at = 0.0, None
    for k in range(30):
        x = 1.0 + 0.05 * min(k, 4)  # 0.2 m, then still
        tracker.update(t, [laser(x, 0.5, rng), laser(3.0, 3.0, rng, free=False)], LASER)
        people = tracker.people()
        if people and confirmed_at is None:
            confirmed_at = k
        t += 0.1
    assert confirmed_at == p.laser_dwell_hits - 1  # her 10th scan
    (person,) = tracker.people()
    assert person.position == pytest.approx((1.2, 0.5), abs=0.1)
    assert person.travelled < p.laser_confirm_distance


def test_a_dwelling_track_needs_nearly_all_its_legs_in_free_floor():
    """Legs that were in free floor in 8 of 10 scans (a chair leg at the edge of the floor the
    laser saw) are not confirmed by the dwell rule (90 %), nor by the walking one (no travel)."""
    rng = np.random.default_rng(12)
    tracker = Tracker()
    t = 0.0
    for k in range(10):
        tracker.update(t, [laser(2.0, 1.0, rng, free=k % 5 != 0)], LASER)
        t += 0.1
    assert tracker.people() == [] and len(tracker.tracks) == 1


def test_people_are_every_confirmed_track_published_or_not():
    """people() has a laser-confirmed walker at once; published() only once it has an id
    (id_wait after its confirmation), under the same ni id."""
    rng = np.random.default_rng(13)
    p = TrackerParams()
    tracker = Tracker(p)
    t, seen = 0.0, []
    for k in range(40):
        tracker.update(t, [laser(0.05 * k, 2.0, rng)], LASER)
        seen.append((t, [tr.ni_id for tr in tracker.people()], [tr.ni_id for tr in tracker.published()]))
        t += 0.1
    first_person = next(t for t, people, _ in seen if people)
    first_user = next(t for t, _, users in seen if users)
    assert first_user - first_person == pytest.approx(p.id_wait, abs=0.11)
    assert seen[-1][1] == seen[-1][2] and len(seen[-1][1]) == 1


def test_a_person_back_beside_the_robot_gets_their_id_once_the_kinect_sees_them():
    """Red is seen by the Kinect, leaves, and comes back beside the robot, where only the laser
    sees her walking legs: a provisional id, then her own once the Kinect sees her shirt; a blue
    stranger who comes the same way keeps the provisional id as his own."""
    rng = np.random.default_rng(8)
    tracker = Tracker(TrackerParams(id_wait=0.5))
    t = 0.0
    for _ in range(20):
        tracker.update(t, [kinect(2.0, 0.0, RED, rng)], KINECT)
        t += 1 / RATE
    (red,) = tracker.published()
    red_id = red.pid
    t += 3.0  # gone: the track times out
    tracker.update(t, [], KINECT)
    assert tracker.published() == []
    for k in range(30):  # walking in from beside the robot: laser only for 3 s
        tracker.update(t, [laser(0.3 + 0.05 * k, 1.2, rng)], LASER)
        t += 0.1
    (back,) = tracker.published()
    assert back.provisional and back.pid != red_id
    provisional = back.pid
    for _ in range(3):
        tracker.update(t, [kinect(0.3 + 0.05 * 30, 1.2, RED, rng)], KINECT)
        tracker.update(t + 0.01, [laser(0.3 + 0.05 * 30, 1.2, rng)], LASER)
        t += 1 / RATE
    (back,) = tracker.published()
    assert back.pid == red_id and not back.provisional
    assert provisional not in tracker.gallery.signatures, "the provisional id is forgotten"
    tracker.reset()
    for k in range(30):  # a stranger the same way
        tracker.update(t, [laser(0.3 + 0.05 * k, -1.2, rng)], LASER)
        t += 0.1
    (stranger,) = tracker.published()
    own = stranger.pid
    for _ in range(3):
        tracker.update(t, [kinect(1.8, -1.2, BLUE, rng)], KINECT)
        tracker.update(t + 0.01, [laser(1.8, -1.2, rng)], LASER)
        t += 1 / RATE
    (stranger,) = tracker.published()
    assert stranger.pid == own != red_id and not stranger.provisional


def test_legs_that_seem_to_walk_where_the_floor_was_never_free_do_not_confirm():
    """A tentative track hopping along a wall seen at a grazing angle, or from chair leg to chair
    leg, moves as far as a walker but never through floor the laser saw free."""
    rng = np.random.default_rng(9)
    tracker = Tracker()
    t = 0.0
    for k in range(40):
        tracker.update(t, [laser(1.0 + 0.05 * k, 3.0, rng, free=False)], LASER)
        t += 0.1
    assert tracker.published() == []
    assert max(tr.travelled for tr in tracker.tracks) > 1.0


def test_legs_that_sat_under_a_chair_and_then_walk_into_free_floor_confirm():
    """The seated user's legs among her chair's: the laser pairs them into a tentative track that
    never confirms (the floor there was never free). When she gets up and walks 0.8 m into free
    floor, that track carries her: its latest laser_free_window detections judge the walk, not the
    100 at her seat (florence_sim: over the whole life 34 of 196 free, unconfirmed at 0.9 m from
    the robot, where the Kinect does not see her upper body, in 2 of 5 tries). The same track
    sliding on where the floor was never free does not."""
    def sit_then_walk(free_walk, params=None):
        rng = np.random.default_rng(4)
        tracker = Tracker(params)
        first = None
        for k in range(140):
            y = 0.03 * min(max(k - 100, 0), 27)  # 10 s seated, then 0.8 m at 0.3 m/s, then still
            free = free_walk and 100 < k <= 127
            tracker.update(0.1 * k, [laser(1.0, y, rng, free=free)], LASER)
            if first is None and tracker.people():
                first = k
        return first

    first = sit_then_walk(True)
    assert first is not None and 100 + 17 <= first <= 127  # once she walked 0.5 m, while walking
    assert sit_then_walk(False) is None
    assert sit_then_walk(True, TrackerParams(laser_free_window=1000)) is None  # the whole life: never
    with pytest.raises(ValueError, match="laser_free_window"):
        TrackerParams(laser_free_window=3).validate()


def broken_walk(params, free_while_walking=True):
    """The laser's view of a walker close to the robot: 3 scans at her seat (floor the laser never
    saw free), 12 scans up +y at 0.3 m/s, 8 scans unseen (past tentative_timeout: her first track is
    dropped) while she turns to +x, 6 scans on along +x, then standing still where the floor is no
    longer free (her own feet end the beams). Neither piece walks laser_confirm_distance (0.36 and
    0.18 m) nor dwells on laser_dwell_hits free scans; together they end 0.55 m from her seat.
    Returns the tracker and the scan at which she was first published (None: never)."""
    rng = np.random.default_rng(3)
    tracker = Tracker(params)
    first, x, y = None, 1.0, 0.0
    for k in range(60):
        if 3 <= k < 15:
            y += 0.03
        elif 15 <= k < 29:
            x += 0.03
        free = free_while_walking and 3 <= k < 29
        tracker.update(0.1 * k, [laser(x, y, rng, free=free)] if not 15 <= k < 23 else [], LASER)
        if first is None and tracker.people():
            first = k
    return tracker, first


def test_a_walk_the_laser_tracks_in_pieces_confirms_when_the_pieces_together_walked_far_enough():
    """Close to the robot a walker's legs pair badly for a few scans and her laser track breaks up
    (florence_sim: the day's user, up from her seat 0.5 m from the robot and 0.8 m away, stood
    unconfirmed at 1.05 m in 1 of 5 tries: tracks of 0.42, 0.25 and 0.10 m). The track that
    carries on where the dropped one lost her legs takes over its walk (laser_stitch_time)."""
    p = TrackerParams()
    tracker, first = broken_walk(p)
    assert first is not None and 23 <= first < 29  # while she walks on, not never
    (person,) = tracker.people()
    assert person.stitched and person.travelled >= p.laser_confirm_distance
    assert math.hypot(person.position[0] - 1.42, person.position[1] - 0.36) < 0.1
    _, first = broken_walk(TrackerParams(laser_stitch_time=0.0))  # each piece alone: never
    assert first is None
    _, first = broken_walk(p, free_while_walking=False)  # chair legs chained that way: never free floor
    assert first is None
    with pytest.raises(ValueError, match="laser_stitch_time"):
        TrackerParams(laser_stitch_time=-1.0).validate()


def test_clutter_seen_once_never_confirms():
    rng = np.random.default_rng(6)
    tracker = Tracker(TrackerParams(confirm_hits=3))
    for k in range(30):  # a false Kinect detection every fourth frame, never twice in a row
        tracker.update(k / RATE, [kinect(2.0, 2.0, GREEN, rng)] if k % 4 == 0 else [], KINECT)
    assert tracker.published() == []


def test_reset_forgets_tracks_but_not_people():
    rng = np.random.default_rng(7)
    tracker = Tracker()
    for k in range(10):
        tracker.update(k / RATE, [kinect(1.0, 1.0, RED, rng)], KINECT)
    (before,) = tracker.published()
    tracker.reset()
    assert tracker.published() == [] and tracker.tracks == []
    for k in range(10, 20):
        tracker.update(k / RATE, [kinect(1.0, 1.0, RED, rng)], KINECT)
    (after,) = tracker.published()
    assert after.pid == before.pid and after.ni_id != before.ni_id


def test_nan_detections_are_ignored():
    tracker = Tracker()
    tracker.update(0.0, [Detection(math.nan, 1.0, KINECT), Detection(1.0, math.inf, LASER)], KINECT)
    assert tracker.tracks == []


def test_params_are_validated():
    with pytest.raises(ValueError, match="kinect_gate"):
        Tracker(TrackerParams(kinect_gate=0.0))


def test_colours_keep_two_people_apart_where_their_positions_do_not():
    """Red and blue walk up to each other, stand 0.1 m apart for a second (positions alone cannot
    tell them apart), and go back the way they came: each shirt keeps its track."""
    for seed in range(5):
        rng = np.random.default_rng(100 + seed)
        tracker = Tracker()

        def at(t):
            """Red's and blue's positions at t [s]: 2 s in, 1 s still, 2 s back."""
            walk = min(t, 2.0) - max(0.0, t - 3.0)
            return (1.0 + 0.5 * walk, 0.05), (3.0 - 0.5 * walk, -0.05)

        t = 0.0
        while t < 5.0:
            red, blue = at(t)
            tracker.update(t, [kinect(*red, RED, rng), kinect(*blue, BLUE, rng)], KINECT)
            if 0.5 < t < 1.0:
                ids = (by_position(tracker, *red).pid, by_position(tracker, *blue).pid)
            t += 1 / RATE
        red, blue = at(5.0)
        assert (by_position(tracker, *red).pid, by_position(tracker, *blue).pid) == ids, f"seed {seed}"


def test_a_leg_pair_between_two_people_moves_neither():
    rng = np.random.default_rng(11)
    tracker = Tracker()
    t = 0.0
    for _ in range(10):
        tracker.update(t, [kinect(2.0, 0.15, RED, rng), kinect(2.0, -0.15, BLUE, rng)], KINECT)
        t += 1 / RATE
    before = {tr.pid: tr.position for tr in tracker.published()}
    for _ in range(5):  # legs of both paired at their midpoint, 0.15 m from each
        tracker.update(t, [laser(2.0, 0.0, rng)], LASER)
        t += 0.1
    after = {tr.pid: tr.position for tr in tracker.published()}
    assert all(math.dist(before[p], after[p]) < 0.08 for p in before), (before, after)


def test_a_track_the_kinect_has_in_clear_view_but_does_not_see_is_dropped():
    """A track the laser keeps on a spot where the Kinect plainly sees nobody."""
    rng = np.random.default_rng(12)
    tracker = Tracker(TrackerParams(unseen_timeout=1.0, timeout=5.0))
    t = 0.0
    for _ in range(10):
        tracker.update(t, [kinect(2.0, 0.0, RED, rng)], KINECT)
        tracker.update(t, [laser(2.0, 0.0, rng)], LASER)
        t += 0.1
    for k in range(20):  # the laser goes on seeing "legs" there; the Kinect, in clear view, nothing
        tracker.update(t, [laser(2.0, 0.0, rng)], LASER)
        tracker.update(t, [], KINECT)
        tracker.in_clear_view(t, list(tracker.tracks))
        if k < 9:
            assert len(tracker.published()) == 1
        t += 0.1
    assert tracker.published() == []
    assert tracker.dropped == {"in the Kinect's clear view, not detected": 1}  # the node's diagnostics say why


def _seen_by_the_kinect(tracker, rng, frames=10):
    """A person at (2, 0) in ``frames`` Kinect frames 0.1 s apart; returns the time after them."""
    t = 0.0
    for _ in range(frames):
        tracker.update(t, [kinect(2.0, 0.0, RED, rng)], KINECT)
        t += 0.1
    return t


def test_a_confirmed_track_no_sensor_updates_is_dropped_and_counted():
    tracker = Tracker(TrackerParams(timeout=1.0))
    t = _seen_by_the_kinect(tracker, np.random.default_rng(15))
    assert len(tracker.published()) == 1
    for _ in range(12):
        tracker.update(t, [], LASER)
        t += 0.1
    assert tracker.published() == [] and tracker.dropped == {"no update": 1}


def test_out_of_clear_view_the_laser_keeps_the_track():
    rng = np.random.default_rng(13)
    tracker = Tracker(TrackerParams(unseen_timeout=1.0))
    t = _seen_by_the_kinect(tracker, rng)
    for _ in range(30):
        tracker.update(t, [laser(2.0, 0.0, rng)], LASER)
        tracker.update(t, [], KINECT)
        tracker.in_clear_view(t, [])  # beside the robot, or hidden
        t += 0.1
    assert len(tracker.published()) == 1


def test_a_coasting_track_is_published_no_further_than_the_coast_limit():
    rng = np.random.default_rng(14)
    tracker = Tracker(TrackerParams(coast_limit=0.3, timeout=2.0))
    t = 0.0
    for _ in range(30):  # walking at 1 m/s along x
        tracker.update(t, [kinect(1.0 + 1.0 * t, 0.0, RED, rng)], KINECT)
        t += 1 / RATE
    last_x = 1.0 + 1.0 * (t - 1 / RATE)
    tracker.update(t + 1.0, [], KINECT)  # a second without a detection
    (track,) = tracker.published()
    assert track.position[0] == pytest.approx(last_x + 1.0, abs=0.25)  # the filter coasts on
    assert track.output(0.3)[0] == pytest.approx(last_x + 0.3, abs=0.15)  # what is published does not


def _confirmed_walker(tracker, rng, t=0.0, speed=0.4):
    """A person walking toward -x at ``speed`` from x = 2, seen by both sensors for 1 s."""
    for _ in range(10):
        x = 2.0 - speed * t
        tracker.update(t, [kinect(x, 0.0, RED, rng)], KINECT)
        tracker.update(t, [laser(x, 0.0, rng)], LASER)
        t += 0.1
    (track,) = tracker.published()
    return track, t


def test_a_person_behind_the_robot_is_kept_standing_where_they_were_going():
    """The robot turned its back on them: not seeing them says nothing."""
    rng = np.random.default_rng(21)
    tracker = Tracker(TrackerParams(timeout=1.0, hidden_timeout=10.0, coast_limit=0.3))
    track, t = _confirmed_walker(tracker, rng)
    last = 2.0 - 0.4 * (t - 0.1)
    for _ in range(90):  # 9 s out of the laser's view, no detection
        tracker.out_of_view(t, [track])
        tracker.update(t, [], LASER)
        tracker.update(t, [], KINECT)
        t += 0.1
    assert tracker.published() == [track]
    assert track.standing
    assert track.output(0.3)[0] == pytest.approx(last - 0.4 * 0.3, abs=0.1)  # where they were going
    assert track.position == pytest.approx(track.output(0.3), abs=0.05)  # the filter stands there too
    assert track.velocity == pytest.approx((0.0, 0.0), abs=0.05)
    # back in view, there: the laser's legs update the same track
    x = track.position[0]
    for _ in range(5):
        tracker.update(t, [laser(x, 0.0, rng, free=False)], LASER)
        t += 0.1
    assert tracker.published() == [track] and not track.standing


def test_a_person_behind_the_robot_is_dropped_after_hidden_timeout_or_once_in_view():
    rng = np.random.default_rng(22)
    tracker = Tracker(TrackerParams(timeout=1.0, hidden_timeout=5.0))
    track, t = _confirmed_walker(tracker, rng)
    start = t
    while tracker.published():  # out of view for good
        tracker.out_of_view(t, [track])
        tracker.update(t, [], LASER)
        t += 0.1
        assert t - start < 6.0
    assert t - start == pytest.approx(5.0, abs=0.25)
    # out of view for 3 s, then in view with nobody there: dropped a timeout later
    track, t = _confirmed_walker(tracker, rng, t)
    start = t
    for _ in range(30):
        tracker.out_of_view(t, [track])
        tracker.update(t, [], LASER)
        t += 0.1
    back = t
    while tracker.published():
        tracker.update(t, [], LASER)
        t += 0.1
        assert t - back < 2.0
    assert t - back == pytest.approx(1.0, abs=0.25)


def test_without_hidden_timeout_a_person_behind_the_robot_is_dropped_as_before():
    rng = np.random.default_rng(23)
    tracker = Tracker(TrackerParams(timeout=1.0, hidden_timeout=0.0))
    track, t = _confirmed_walker(tracker, rng)
    start = t
    while tracker.published():
        tracker.out_of_view(t, [track])
        tracker.update(t, [], LASER)
        t += 0.1
    assert t - start == pytest.approx(1.0, abs=0.25)
    with pytest.raises(ValueError):
        Tracker(TrackerParams(hidden_timeout=-1.0))


def test_detections_on_the_maps_walls_are_nobody():
    tracker = Tracker()
    for k in range(10):
        tracker.update(k / RATE, [Detection(1.0, 1.0, KINECT, 0.08, RED, on_structure=True)], KINECT)
    assert tracker.tracks == []


def test_a_tentative_track_cannot_hop_faster_than_a_person_walks():
    """Legs 0.35 m apart seen in turn (a chair's, a wall's end): each scan's detection is too far
    from the last for a walker, so no tentative track travels."""
    tracker = Tracker()
    t = 0.0
    for k in range(30):
        tracker.update(t, [Detection(1.0 + 0.35 * (k % 2), 2.0, LASER, 0.05, free=True)], LASER)
        t += 0.1
    assert tracker.published() == []
    assert max(tr.travelled for tr in tracker.tracks) < 0.1


def test_a_person_who_turns_where_the_track_went_on_keeps_the_id():
    """Red walks away at 1 m/s, is not seen for half a second at the end of the Kinect's range
    while she turns, and comes back: her track coasted on (constant velocity), a new track starts
    on her and takes her persistent id from the coasting one, which ends."""
    rng = np.random.default_rng(15)
    tracker = Tracker()
    t = 0.0
    for _ in range(30):
        tracker.update(t, [kinect(1.0 + 1.0 * t, 0.0, RED, rng)], KINECT)
        t += 1 / RATE
    (red,) = tracker.published()
    turn_x = 1.0 + 1.0 * t
    for _ in range(8):  # half a second unseen
        tracker.update(t, [], KINECT)
        t += 1 / RATE
    for k in range(10):  # back toward the robot
        tracker.update(t, [kinect(turn_x - 0.25 - 1.0 * k / RATE, 0.0, RED, rng)], KINECT)
        t += 1 / RATE
    (back,) = tracker.published()
    assert back.pid == red.pid and back.ni_id != red.ni_id


def test_a_seated_person_faces_where_the_kinect_said_and_a_walking_one_the_way_they_walk():
    rng = np.random.default_rng(4)
    tracker, p = Tracker(), TrackerParams()
    facing = math.radians(160)
    t = 0.0
    for k in range(int(2 * RATE)):  # seated at (2, 1): the shins say 160 deg give or take 20
        t = k / RATE
        det = kinect(2.0, 1.0, RED, rng)
        tracker.update(t, [Detection(det.x, det.y, KINECT, 0.08, RED, facing=facing + rng.normal(0, 0.35),
                                     posture="sitting")], KINECT)
    (track,) = tracker.published()
    assert abs(math.remainder(track.facing(p) - facing, 2 * math.pi)) < math.radians(15)
    for k in range(1, int(2 * RATE)):  # gets up and walks off along -y at 0.6 m/s, the Kinect saying nothing of it
        tracker.update(t + k / RATE, [kinect(2.0, 1.0 - 0.6 * k / RATE, RED, rng)], KINECT)
    (track,) = tracker.published()
    assert abs(math.remainder(track.facing(p) + math.pi / 2, 2 * math.pi)) < math.radians(20)
    assert track.facing_count == 0  # walking cleared what the Kinect said


def test_a_person_last_seen_standing_has_no_facing():
    """Close up the image cuts a standing person's top off (posture "unknown") and depth_people may read
    her legs under her torso as shins: once the Kinect saw her standing, however well such frames agree,
    she faces nowhere known (bench/locator.py: a standing user given a facing 180 deg off hers, and
    approach_me_map went to her back). A person seen only close up (a seated one the robot came to) keeps
    what they say, and one seen sitting after standing faces where her shins say."""
    p = TrackerParams()

    def seen(postures):
        tracker, rng = Tracker(), np.random.default_rng(4)
        for k, posture in enumerate(postures):
            det = kinect(2.0, 1.0, RED, rng)
            facing = None if posture == "standing" else 2.5  # depth_people gives a standing person none
            tracker.update(k / RATE, [Detection(det.x, det.y, KINECT, 0.08, RED, facing=facing, posture=posture)],
                           KINECT)
        (track,) = tracker.published()
        return track.facing(p)

    n = int(2 * RATE)
    assert seen(["standing"] * n + ["unknown"] * n) is None
    assert seen(["unknown"] * n) == pytest.approx(2.5)
    assert seen(["standing"] * n + ["sitting"] * 2 + ["unknown"] * n) == pytest.approx(2.5)


def test_facing_stays_unknown_until_enough_frames_agree():
    rng = np.random.default_rng(5)
    tracker, p = Tracker(), TrackerParams()
    for k in range(int(2 * RATE)):  # frames that disagree (a seat's edge, a table leg taken for shins)
        det = kinect(2.0, 1.0, RED, rng)
        tracker.update(k / RATE, [Detection(det.x, det.y, KINECT, 0.08, RED, facing=k * 2.4)], KINECT)
    (track,) = tracker.published()
    assert track.facing_count > p.facing_frames and track.facing(p) is None
    tracker = Tracker()
    for k in range(int(RATE)):  # nothing said
        tracker.update(k / RATE, [kinect(2.0, 1.0, RED, rng)], KINECT)
    assert tracker.published()[0].facing(p) is None


@pytest.mark.parametrize("flagged", [True, False])
def test_a_person_partly_hidden_keeps_their_track_on_their_line(flagged):
    """A person 2.5 m from the camera (at the origin) walks across its view at 0.45 m/s; for 0.5 s
    somebody nearer hides their leading side, and the Kinect's detections are the trailing side's
    centroid, up to 0.25 m behind them; then for 0.4 s nobody sees them. Flagged as partly hidden (the
    range good, the side not: across_std; the velocity not taught), the track keeps their speed and
    ends 0.18 m behind them; taken at face value, it is dragged back and slowed, and ends 0.45 m off."""
    rng = np.random.default_rng(3)
    tracker = Tracker()
    speed, k_hidden, k_gone, k_end = 0.45, int(3 * RATE), int(3.5 * RATE), int(3.9 * RATE)
    for k in range(k_end):
        t = k / RATE
        y = -1.0 + speed * t
        if k < k_hidden:
            dets = [kinect(2.5, y, RED, rng)]
        elif k < k_gone:
            seen_y = y - 0.25 * (k - k_hidden + 1) / (k_gone - k_hidden)  # less and less of them in view
            dets = [Detection(2.5 + rng.normal(0, 0.03), seen_y, KINECT, 0.08, RED,
                              across_std=1.0 if flagged else None, sight=(2.5, seen_y) if flagged else None)]
        else:
            dets = []
        tracker.update(t, dets, KINECT)
    (track,) = tracker.published()
    error = math.hypot(track.output(tracker.params.coast_limit)[0] - 2.5,
                       track.output(tracker.params.coast_limit)[1] - (-1.0 + speed * (k_end - 1) / RATE))
    if flagged:
        assert error < 0.22, error
        assert track.velocity[1] > 0.3, track.velocity
    else:  # what the flag is for
        assert error > 0.35, error


def seated_then_close(tracker, rng, posture="sitting", seconds=2.0):
    """A person seated at (2, 1) facing west: 2 s of Kinect detections of her torso (``posture``) with
    the laser seeing her shins 0.15 m in front of her (1.85, 1); then the robot comes close, the Kinect
    loses her upper body, and for 3 s only the laser sees her shins. Returns her track's positions
    over those 3 s."""
    t, out = 0.0, []
    for k in range(int(seconds * RATE)):
        t = k / RATE
        det = kinect(2.0, 1.0, RED, rng)
        tracker.update(t, [Detection(det.x, det.y, KINECT, 0.08, RED, posture=posture)], KINECT)
        tracker.update(t + 0.5 / RATE, [laser(1.85, 1.0, rng, free=False)], LASER)
    for k in range(1, int(3 * RATE)):
        tracker.update(t + k / RATE, [laser(1.85, 1.0, rng, free=False)], LASER)
        (track,) = tracker.published()
        out.append(track.position)
    return np.array(out)


@pytest.mark.parametrize("seat_hold, returns, kept", [(10.0, True, True), (10.0, False, False), (0.0, True, False)])
def test_a_seated_person_is_kept_while_the_laser_shows_something_at_her_seat(seat_hold, returns, kept):
    """Close to a seated person the laser sees her lower legs as one block, no pair of legs, and the Kinect
    loses her whenever the robot turns: without hold_seated her track went within timeout (1 s). With
    returns at her seat it is kept, not moved, until seat_hold since the Kinect last saw her; without
    them, or with seat_hold 0, it goes."""
    tracker, rng = Tracker(TrackerParams(seat_hold=seat_hold)), np.random.default_rng(3)
    t = 0.0
    for k in range(int(2 * RATE)):  # seated at (2, 1), the Kinect and her shins in front of her
        t = k / RATE
        det = kinect(2.0, 1.0, RED, rng)
        tracker.update(t, [Detection(det.x, det.y, KINECT, 0.08, RED, posture="sitting")], KINECT)
        tracker.update(t + 0.5 / RATE, [laser(1.85, 1.0, rng, free=False)], LASER)
    (track,) = tracker.tracks
    assert track.seat is not None
    block = np.column_stack([np.full(8, 1.88), np.linspace(0.9, 1.1, 8)])  # her legs' near side, one block
    last_kinect, alive = t, []
    for k in range(1, int(14 * RATE)):  # no detection at all for 14 s: scans with or without returns there
        now = t + k / RATE
        tracker.hold_seated(now, block if returns else np.zeros((0, 2)))
        tracker.update(now, [], LASER)
        alive.append((now - last_kinect, len(tracker.tracks)))
    alive = np.array(alive)
    if kept:
        assert np.all(alive[alive[:, 0] <= seat_hold - 0.1, 1] == 1)  # kept up to seat_hold ...
        assert np.all(alive[alive[:, 0] >= seat_hold + 1.2, 1] == 0)  # ... and no longer
        assert track.position == pytest.approx((2.0, 1.0), abs=0.05)  # where the Kinect placed her
    else:
        assert np.all(alive[alive[:, 0] >= 1.2, 1] == 0)


def test_a_seated_person_stays_where_the_kinect_placed_her_when_only_her_shins_are_seen():
    """The laser sees a seated person's shins in front of her: it keeps her track alive but does not
    drag it onto her legs (the robot coming to her would end that much nearer). Standing, it moves
    the track as before; with seated_reach 0 too."""
    seated = seated_then_close(Tracker(), np.random.default_rng(6))
    assert np.max(np.hypot(seated[:, 0] - 2.0, seated[:, 1] - 1.0)) < 0.04, seated[-1]
    standing = seated_then_close(Tracker(), np.random.default_rng(6), posture="standing")
    assert math.hypot(standing[-1, 0] - 1.85, standing[-1, 1] - 1.0) < 0.06, standing[-1]
    off = seated_then_close(Tracker(TrackerParams(seated_reach=0.0)), np.random.default_rng(6))
    assert math.hypot(off[-1, 0] - 1.85, off[-1, 1] - 1.0) < 0.06, off[-1]
    # a track walking at 0.5 m/s that the Kinect says sits (a short person, a misjudged top) gets no seat
    walker, rng = Tracker(), np.random.default_rng(8)
    for k in range(int(2 * RATE)):
        det = kinect(1.0 + 0.5 * k / RATE, 1.0, RED, rng)
        walker.update(k / RATE, [Detection(det.x, det.y, KINECT, 0.08, RED, posture="sitting")], KINECT)
    (track,) = walker.published()
    assert track.sitting_count > 2 and track.seat is None and not track.seated(walker.params)
    # her top cut off by the image ("unknown") says nothing: still seated
    unknown = Tracker()
    seated_then_close(unknown, np.random.default_rng(6))
    (track,) = unknown.published()
    unknown.update(10.0, [Detection(2.0, 1.0, KINECT, 0.08, RED, posture="unknown")], KINECT)
    assert track.seat is not None


@pytest.mark.parametrize("posture, reach, seated", [("sitting", 0.3, True), ("standing", 0.3, False),
                                                     ("sitting", 0.0, True)])
def test_a_track_is_seated_when_the_kinect_said_so_while_it_stood_still(posture, reach, seated):
    """What tracked_users' ``seated`` says: whether the Kinect's last detections of a still person said she
    sits, whether her seat holds her track or not (seated_reach 0)."""
    tracker = Tracker(TrackerParams(seated_reach=reach))
    seated_then_close(tracker, np.random.default_rng(6), posture=posture)
    (track,) = tracker.published()
    assert track.seated(tracker.params) is seated


def test_a_seated_person_who_gets_up_and_walks_is_followed_by_the_laser():
    """Her track, not a new one: the seat's reach is within the laser's gate, so her legs leaving
    it are still hers (with a reach beyond the gate her track stood at the seat until dropped)."""
    rng = np.random.default_rng(7)
    tracker = Tracker()
    seated_then_close(tracker, rng)
    (seated,) = tracker.published()
    assert seated.seat is not None
    t0 = seated.last_update
    for k in range(1, int(3 * RATE)):  # up and away along +y at 0.5 m/s, the laser alone seeing her
        tracker.update(t0 + k / RATE, [laser(1.85, 1.0 + 0.5 * k / RATE, rng)], LASER)
    end = (1.85, 1.0 + 0.5 * (int(3 * RATE) - 1) / RATE)
    assert tracker.published() == [seated]
    assert seated.seat is None and math.hypot(seated.position[0] - end[0], seated.position[1] - end[1]) < 0.15
    assert not seated.seated(tracker.params)
    with pytest.raises(ValueError, match="laser_gate"):  # a reach at the gate: her track would stand at the seat
        TrackerParams(seated_reach=TrackerParams.laser_gate).validate()


SKIN_AND_SHIRT = reid.signature(np.vstack([np.tile([[222, 184, 153]], (150, 1)), np.tile([[200, 20, 20]], (50, 1))]))


def test_a_seated_person_whose_top_the_image_cuts_off_keeps_her_track_and_seat():
    """Close up the image cuts a seated person's top off ("unknown"): the band of colours it keeps above her
    hips is mostly her head's, unlike her shirt. At her seat that detection is hers whatever its colours, and
    they are not learnt; a standing person's track, or a detection away from the seat, keeps the colour gate
    (a new track starts). Before, the seated user's track ended there and the new one stood on her shins."""
    assert reid.distance(SKIN_AND_SHIRT, RED) > TrackerParams().appearance_gate

    def close_up(posture, at=(2.0, 1.0)):
        tracker, rng = Tracker(), np.random.default_rng(6)
        seated_then_close(tracker, rng, posture=posture, seconds=2.0)
        (track,) = tracker.published()
        learnt, t0 = track.signature.copy(), track.last_update
        for k in range(1, int(2 * RATE)):
            tracker.update(t0 + k / RATE, [Detection(at[0], at[1], KINECT, 0.08, SKIN_AND_SHIRT, posture="unknown")],
                           KINECT)
        return tracker, track, learnt

    tracker, track, learnt = close_up("sitting")
    assert [tr for tr in tracker.tracks] == [track] and track.seat is not None
    assert math.hypot(track.position[0] - 2.0, track.position[1] - 1.0) < 0.04
    assert reid.distance(track.signature, learnt) < 1e-6
    for posture, at in (("standing", (2.0, 1.0)), ("sitting", (2.0, 1.45))):  # 0.45 m off her seat: somebody else
        tracker, track, _ = close_up(posture, at)
        assert any(tr is not track for tr in tracker.tracks), posture
        assert reid.distance(track.signature, RED) < 0.1, posture


def test_two_tracks_on_one_still_persons_legs_are_merged_into_the_senior():
    """A person standing still seen as two people 0.17 m apart (a leg each, each a confirmed track):
    every leg pair near them lies within the laser's gate of both tracks, so the laser updates
    neither. The junior track goes and the person keeps their id; people crossing (moving apart
    the other way) are not merged (test_crossing_paths_keep_their_ids)."""
    def run(params):
        rng = np.random.default_rng(4)
        tracker = Tracker(params)
        for k in range(int(2 * RATE)):
            tracker.update(k / RATE, [kinect(2.0, 0.0, RED, rng)], KINECT)
        (first,) = tracker.published()
        for k in range(int(2 * RATE), int(5 * RATE)):
            tracker.update(k / RATE, [kinect(2.0, -0.085, RED, rng), kinect(2.0, 0.085, RED, rng)], KINECT)
        return first, [tr for tr in tracker.tracks if tr.confirmed], tracker
    first, confirmed, tracker = run(TrackerParams())
    assert confirmed == [first] and first.pid is not None
    assert tracker.dropped["merged into a nearer track (one person's)"] >= 1
    _, confirmed, _ = run(TrackerParams(merge_distance=0.0))
    assert len(confirmed) == 2
