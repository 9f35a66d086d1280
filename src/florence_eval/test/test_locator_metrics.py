"""florenceLocator's measures (florence_eval.locator_metrics) and the bench's placements."""

import math

import numpy as np
import pytest

from florence_eval import locator_metrics as lm

pytestmark = pytest.mark.unit


@pytest.mark.parametrize("robot, user, distance, facing_deg, side", [
    ((0.5, 0.0, math.pi), (0.0, 0.0, 0.0, "sitting"), 0.5, 0.0, "front"),  # head-on, facing the user
    ((0.0, 0.5, -math.pi / 2 + 0.2), (0.0, 0.0, 0.0, "standing"), 0.5, 11.5, "left"),  # at the user's left
    ((0.35, -0.35, 3 * math.pi / 4), (0.0, 0.0, 0.0, "sitting"), math.hypot(0.35, 0.35), 0.0, "front-right"),
    ((-0.5, 0.0, 0.0), (0.0, 0.0, 0.0, "standing"), 0.5, 0.0, "behind"),
    ((1.0, 1.5, math.pi), (1.0, 1.0, math.pi / 2, "sitting"), 0.5, -90.0, "front"),  # the user faces +y
])
def test_approach(robot, user, distance, facing_deg, side):
    a = lm.approach(robot, user)
    assert a.distance == pytest.approx(distance)
    assert math.degrees(a.facing_error) == pytest.approx(facing_deg, abs=0.1)
    assert a.side_name == side
    assert a.as_dict()["posture"] == user[3]


def test_nearest_person_matches_times():
    track = np.array([[0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0], [2.0, 2.0, 0.0, 0.0]])
    people = [(0.0, {"a": (3.0, 0.0, 0.0, "standing")}), (1.9, {"a": (2.3, 0.0, 0.0, "standing"),
                                                                 "b": (5.0, 5.0, 0.0, "sitting")})]
    d, t, pid = lm.nearest_person(track, people)
    assert (round(d, 6), t, pid) == (0.3, 2.0, "a")
    assert lm.nearest_person(track, people, until=1.0)[0] == pytest.approx(1.3)  # at t = 1, the 1.9 s message
    assert lm.nearest_person(track, [])[0] == math.inf


def test_time_to_stop_and_turned():
    t = np.arange(0.0, 3.0, 0.1)
    v = np.clip(0.5 - 0.5 * (t - 1.0), 0.0, 0.5)  # braking from t = 1 s at 0.5 m/s^2: at rest at t = 2 s
    yaw = np.concatenate([np.linspace(0, 2 * math.pi, 20, endpoint=False), np.full(10, 0.3)])
    track = np.column_stack([t, t, t, yaw, v, np.zeros_like(t)])
    assert lm.time_to_stop(track, 1.0) == pytest.approx(1.0, abs=0.11)
    assert lm.time_to_stop(track[:15], 1.0) is None
    assert lm.turned(track, until=1.95) == pytest.approx(2 * math.pi * 19 / 20)
    wobble = np.column_stack([t[:4], t[:4], t[:4], [0.0, 0.2, 0.1, 0.3], t[:4], t[:4]])
    assert lm.turned(wobble) == pytest.approx(0.5) and lm.turned(wobble, signed=True) == pytest.approx(0.3)


def test_bench_placements_are_free_and_apart():
    from florence_eval.locator_bench import free_points, placements
    from florence_locator.places import Rooms
    from map_server.mapfile import load_map

    from florence_common.maps import map_file

    grid = load_map(map_file("apartment", "apartment.yaml"))
    rooms = Rooms.load(map_file("apartment", "rooms.yaml"))
    out = placements(rooms, grid, 30, np.random.default_rng(3))
    assert len(out) == 30 and len({room for room, _, _ in out}) == 5
    free = free_points(grid, 0.5)
    for room, user, robot in out:
        ux, uy, _ = user["pose"]
        assert rooms.room_at(ux, uy) == room and rooms.room_at(robot[0], robot[1]) not in (room, "unknown")
        assert np.min(np.hypot(free[:, 0] - ux, free[:, 1] - uy)) < 0.05
        assert user["posture"] in ("sitting", "standing")


def test_arrival_judges_the_estimate_at_the_goal_and_against_the_truth():
    goal = (2.0, 1.0, 0.0)
    # 0.2 m short by the estimate, which is 0.05 m off: 0.25 m by the truth
    end = lm.arrival((1.75, 1.0, 0.0), (1.8, 1.0), goal)
    assert (end.true_distance, end.estimated_distance, end.localization_error) == pytest.approx((0.25, 0.2, 0.05))
    assert end.ok and "0.250 m from it by ground truth" in str(end)
    assert not lm.arrival((1.7, 1.0), (1.7, 1.0), goal).ok  # 0.3 m from it: beyond the tolerance
    assert not lm.arrival((2.0, 1.15), (2.0, 1.0), goal).ok  # at it by an estimate 0.15 m off
