"""The people tracker's core against florence_sim's core in one process (people_offline): a
regression test of the bench's scenarios, judged as bench/people.py judges them, repeatable
(seed 1). The ROS runs are test_people_sim.py and bench/people.py."""

import math

import numpy as np
import pytest
from florence_eval.people_scenarios import by_name

from florence_common import pose
from florence_eval import people_offline, people_scenarios

pytestmark = [pytest.mark.unit, pytest.mark.slow]


@pytest.mark.timeout(300)
@pytest.mark.parametrize("name", ["two_crossing", "leave_and_return", "beside_the_robot", "residents"])
def test_scenario_meets_the_bench_targets(name):
    (scenario,) = by_name([name])
    result = people_offline.evaluate(scenario, people_offline.run(scenario, seed=1))
    assert result["mota"] >= 0.9, result
    assert result["motp_m"] <= 0.1, result
    assert result["id_switches"] == 0, result
    assert result["false_positives_per_1000_frames"] <= 1.0, result
    assert result["returns_with_old_id"] == result["returns"], result
    if scenario.beside:
        assert result["beside_tracked_share"] >= 0.95, result


@pytest.mark.timeout(300)
def test_a_walker_by_the_driving_robot_is_on_tracked_people():
    """A resident held up just behind and beside the robot, mostly out of the Kinect's view: the
    laser confirms her walking and standing (0.71 of the frames with the walking rule alone), and
    tracked_people, which move_base reads, has her in >= 90 % of the frames she is near."""
    (scenario,) = by_name(["walker_by_the_robot"])
    result = people_offline.evaluate(scenario, people_offline.run(scenario, seed=1))
    assert result["near_frames"] > 300, result
    assert result["near_tracked_share"] >= 0.9, result
    assert result["false_positives"] == 0 and result["id_switches"] == 0, result


@pytest.mark.timeout(300)
def test_clutter_alone_makes_no_track():
    (scenario,) = by_name(["clutter_only"])
    result = people_offline.evaluate(scenario, people_offline.run(scenario, seed=1))
    assert result["tracks_seen"] == [] and result["detections"].get("kinect", 0) == 0, result


def test_unknown_scenarios_are_named():
    with pytest.raises(KeyError, match="no scenario 'nope'"):
        by_name(["nope"])


@pytest.mark.timeout(300)
def test_the_seated_user_stays_tracked_at_her_centre_as_the_robot_comes_close():
    """The robot drives up to the seated user from 2.4 m to 0.65 m (approach_me_map's way): the image cuts
    her top off from about 1.7 m, and her upper body nearer than 1.1 m. One track throughout, at her centre,
    not on her shins (before, her track was replaced at 1.7 m and ended 0.11-0.12 m toward the robot: gotoUser
    stopped 0.39 m from her)."""
    scenario = people_scenarios.SEATED_APPROACH
    (x, y, _), = [spec["pose"] for spec in scenario.people.values()]
    run = people_offline.run(scenario, seed=1)
    errors, ids = [], set()
    for (_, tracks, _), truth, odom in zip(run.tracks, run.truth[1], run.odom[1], strict=True):
        map_from_odom = pose.compose(tuple(truth), pose.inverse(tuple(odom)))
        for pid, xy in tracks.items():
            mx, my = pose.transform_points(map_from_odom, [xy])[0]
            errors.append((math.hypot(truth[0] - x, truth[1] - y), math.hypot(mx - x, my - y)))
            ids.add(pid)
    errors = np.array(errors)
    near = errors[errors[:, 0] < 1.2]
    assert len(ids) == 1 and len(near) > 50, (ids, len(near))
    assert np.max(near[:, 1]) < 0.05, near[np.argmax(near[:, 1])]


def test_the_seated_user_stays_tracked_while_the_robot_turns_beside_her():
    """The robot comes to the seated user from her back (make demo's gotoUser ends there when her front is out
    of reach) and turns to and fro 0.6-0.85 m from her for 24 s, as move_base and the last half metre do: the
    laser sees her lower legs as one block, no pair of legs, and the Kinect loses her at each turn. Her track
    was dropped 10 s in (nothing had updated it for 1 s), and the next one, without a seat, stood on her legs
    0.12-0.17 m beyond her centre (make demo: the robot ended 0.39 m from her, the tracker saying 0.54 m).
    Now one track throughout, within 0.05 m of her, in the robot's frame."""
    seat = people_scenarios.SEAT
    back = seat[2] + math.pi
    robot = (seat[0] + 1.85 * math.cos(back), seat[1] + 1.85 * math.sin(back), back - math.pi)
    drive = [(0.0, 0.0, 1.0), (0.2, 0.0, 5.0)] + [(0.0, 0.6, 2.5), (0.0, -0.6, 2.5), (0.1, 0.3, 3.0),
                                                  (-0.1, -0.3, 3.0)] * 2
    scenario = people_scenarios.Scenario("turning_beside_the_seated", robot, {"erin": {
        "pose": list(seat), "posture": "sitting", "shirt": people_scenarios.RED, "height": 1.63, "build": 0.9}}, 30.0,
        drive=drive)
    run = people_offline.run(scenario, seed=1)
    errors, ids, missing = [], set(), 0
    for (t, tracks, _), truth, odom in zip(run.tracks, run.truth[1], run.odom[1], strict=True):
        true_rel = pose.transform_points(pose.inverse(tuple(truth)), [seat[:2]])[0]
        if t > 1.0 and not tracks:
            missing += 1
        for pid, xy in tracks.items():
            rel = pose.transform_points(pose.inverse(tuple(odom)), [xy])[0]
            errors.append(math.hypot(*(rel - true_rel)))
            ids.add(pid)
    assert len(ids) == 1 and missing == 0, (ids, missing)
    assert max(errors) < 0.05, max(errors)
