"""CLEAR MOT by hand-counted examples."""

import pytest
from florence_eval.mot import MotAccumulator

pytestmark = pytest.mark.unit


def test_perfect_tracking():
    acc = MotAccumulator(gate=0.5)
    for t in range(10):
        acc.update(t, {"a": (t * 0.1, 0.0), "b": (0.0, 2.0)}, {1: (t * 0.1 + 0.05, 0.0), 2: (0.0, 2.1)})
    s = acc.summary()
    assert (s["objects"], s["matches"], s["misses"], s["false_positives"], s["id_switches"]) == (20, 20, 0, 0, 0)
    assert s["mota"] == 1.0 and s["motp_m"] == pytest.approx(0.075)


def test_misses_false_positives_and_a_switch():
    acc = MotAccumulator(gate=0.5)
    acc.update(0, {"a": (0, 0)}, {1: (0.1, 0)})  # match
    acc.update(1, {"a": (0, 0)}, {})  # miss
    acc.update(2, {"a": (0, 0)}, {2: (0.1, 0), 3: (5, 5)})  # match under id 2 (switch) + 1 false positive
    acc.update(3, {"a": (0, 0)}, {2: (0.2, 0)})  # keeps 2: no new switch
    s = acc.summary()
    assert (s["objects"], s["misses"], s["false_positives"], s["id_switches"]) == (4, 1, 1, 1)
    assert s["mota"] == pytest.approx(1 - 3 / 4)
    assert acc.switch_log == [(2, "a", 1, 2)]


def test_a_returning_person_under_a_new_id_is_a_switch_even_after_a_gap():
    acc = MotAccumulator()
    acc.update(0, {"a": (0, 0)}, {7: (0, 0)})
    for t in range(1, 5):
        acc.update(t, {}, {})  # out of view
    acc.update(5, {"a": (1, 1)}, {8: (1, 1)})
    assert acc.summary()["id_switches"] == 1


def test_previous_correspondence_wins_over_a_nearer_hypothesis():
    acc = MotAccumulator(gate=0.5)
    acc.update(0, {"a": (0, 0)}, {1: (0.0, 0.0)})
    acc.update(1, {"a": (0, 0)}, {1: (0.4, 0.0), 2: (0.05, 0.0)})  # 1 still within the gate: kept
    s = acc.summary()
    assert s["id_switches"] == 0 and s["false_positives"] == 1


def test_objects_outside_the_region_of_interest_count_for_nothing():
    acc = MotAccumulator()
    acc.update(0, {"a": (0, 0), "far": (6, 0)}, {1: (0, 0), 2: (6, 0)}, care={"a": True, "far": False})
    acc.update(1, {"a": (0, 0), "far": (6, 0)}, {1: (0, 0)}, care={"a": True, "far": False})
    s = acc.summary()
    assert (s["objects"], s["misses"], s["false_positives"]) == (2, 0, 0)


def test_nothing_to_track():
    acc = MotAccumulator()
    acc.update(0, {}, {})
    acc.update(1, {}, {5: (1, 1)})
    s = acc.summary()
    assert s["mota"] is None and s["false_positives"] == 1 and s["false_positives_per_1000_frames"] == 500.0


def test_hypotheses_outside_the_region_of_interest_are_no_false_positives_but_are_counted():
    acc = MotAccumulator()
    acc.update(0, {"a": (0, 0)}, {1: (0, 0), 2: (-3, 0), 3: (2, 0)}, care={"a": True},
               hyp_care={1: True, 2: False, 3: True})
    s = acc.summary()
    assert (s["false_positives"], s["unmatched_anywhere"]) == (1, 2)


def test_ids_out_of_the_region_of_interest_do_not_make_switches():
    """Out of view a person is carried under a provisional id 9; back in view under her old 7."""
    acc = MotAccumulator()
    acc.update(0, {"a": (0, 0)}, {7: (0, 0)}, care={"a": True})
    acc.update(1, {"a": (3, 3)}, {9: (3, 3)}, care={"a": False})
    acc.update(2, {"a": (0, 0)}, {7: (0, 0)}, care={"a": True})
    acc.update(3, {"a": (0, 0)}, {8: (0, 0)}, care={"a": True})
    assert acc.switch_log == [(3, "a", 7, 8)]
