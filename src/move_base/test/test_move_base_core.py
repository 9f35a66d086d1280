"""move_base's state machine with fake planners, controllers and recoveries (no ROS)."""

import math
from dataclasses import dataclass

import numpy as np
import pytest
from move_base.move_base_core import CLEARING, CONTROLLING, PLANNING, MoveBaseCore, core_params
from move_base.recovery import ClearCostmapRecovery, RotateRecovery, default_recovery_specs

pytestmark = pytest.mark.unit


@dataclass
class Plan:
    ok: bool
    poses: object = None
    reason: str = ""
    permanent: bool = False


class FakePlanner:
    def __init__(self, answers):
        self.answers = list(answers)
        self.calls = 0

    def __call__(self, start, goal):
        self.calls += 1
        answer = self.answers[min(self.calls - 1, len(self.answers) - 1)]
        return answer


class FakeController:
    def __init__(self, ok=True, reached_after=None):
        self.ok = ok
        self.reached_after = reached_after
        self.plans = []
        self.calls = 0

    def set_plan(self, poses):
        self.plans.append(poses)

    def compute_velocity(self, pose):
        self.calls += 1
        if self.ok:
            return True, (0.3, 0.0, 0.1), ""
        return False, (0.0, 0.0, 0.0), "no valid trajectory (all samples collide)"

    def is_goal_reached(self):
        return self.reached_after is not None and self.calls >= self.reached_after


class FakeRecovery:
    def __init__(self, name, steps=1):
        self.name = name
        self.steps = steps
        self.started = 0
        self.stepped = 0

    def start(self, now, pose):
        self.started += 1
        self._left = self.steps

    def step(self, now, pose):
        self.stepped += 1
        self._left -= 1
        return self._left <= 0, (0.0, 0.0, 0.5)


GOOD = Plan(True, np.zeros((3, 3)))
POSE = (0.0, 0.0, 0.0)


def run(core, pose=POSE, t0=0.0, dt=0.2, n=200):
    """Cycle until an outcome; returns (outcome, text, time, results)."""
    results = []
    for i in range(n):
        now = t0 + i * dt
        r = core.cycle(now, pose(now) if callable(pose) else pose)
        results.append(r)
        if r.outcome:
            return r.outcome, r.text, now, results
    return None, "", t0 + n * dt, results


def test_plan_then_control_then_succeed():
    ctrl = FakeController(reached_after=5)
    core = MoveBaseCore(core_params(), FakePlanner([GOOD]), ctrl, [])
    core.set_goal((1.0, 0.0, 0.0), 0.0, POSE)
    first = core.cycle(0.0, POSE)
    assert core.state == CONTROLLING and first.cmd == (0.3, 0.0, 0.1) and first.new_plan is GOOD
    outcome, text, _, results = run(core)
    assert outcome == "succeeded" and text == "Goal reached."
    assert results[-1].cmd == (0.0, 0.0, 0.0)
    assert not core.active


def test_planner_patience_then_recoveries_then_abort_with_reason():
    planner = FakePlanner([Plan(False, reason="no path from (0.00, 0.00) to (5.00, 0.00)")])
    recs = [FakeRecovery("conservative_reset"), FakeRecovery("rotate_recovery", steps=3)]
    core = MoveBaseCore(core_params(planner_patience=1.0), planner, FakeController(), recs)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, t_end, results = run(core)
    assert outcome == "aborted"
    assert "Failed to find a valid plan even after executing recovery behaviors" in text
    assert "no path from" in text
    assert [r.started for r in recs] == [1, 1] and recs[1].stepped == 3
    # each recovery comes after planner_patience of failed planning: at least 2 x 1 s
    assert t_end >= 2.0
    # the rotation's commands went out while it ran
    assert any(r.cmd == (0.0, 0.0, 0.5) for r in results)
    # a recovery that says how it ended has that in the text the node logs; one that does not, just "done"
    assert "recovery conservative_reset done" in [r.text for r in results]
    told = FakeRecovery("rotate_recovery")
    told.outcome = "rotation in collision 0.02 rad ahead after 0.00 rad, stopping"
    core = MoveBaseCore(core_params(planner_patience=1.0), planner, FakeController(), [told])
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    _, _, _, results = run(core)
    assert f"recovery rotate_recovery done: {told.outcome}" in [r.text for r in results]


def test_max_planning_retries_counts_attempts():
    planner = FakePlanner([Plan(False, reason="no path")])
    core = MoveBaseCore(core_params(planner_patience=100.0, max_planning_retries=2, recovery_behavior_enabled=False),
                        planner, FakeController(), [FakeRecovery("r")])
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, _, _ = run(core)
    assert outcome == "aborted" and "recovery behaviours disabled" in text
    assert planner.calls == 3


def test_permanent_planning_failure_aborts_at_once():
    planner = FakePlanner([Plan(False, reason="the goal (50.00, 0.00) is off the global costmap", permanent=True)])
    core = MoveBaseCore(core_params(), planner, FakeController(), [FakeRecovery("r")])
    core.set_goal((50.0, 0.0, 0.0), 0.0, POSE)
    r = core.cycle(0.0, POSE)
    assert r.outcome == "aborted" and "off the global costmap" in r.text


def test_controller_failure_replans_then_clears_after_patience():
    ctrl = FakeController(ok=False)
    planner = FakePlanner([GOOD])
    rec = FakeRecovery("conservative_reset")
    core = MoveBaseCore(core_params(controller_patience=3.0), planner, ctrl, [rec])
    core.set_goal((1.0, 0.0, 0.0), 0.0, POSE)
    r = core.cycle(0.0, POSE)
    assert r.cmd == (0.0, 0.0, 0.0) and core.state == PLANNING  # no command: plan again
    outcome, text, t_end, _ = run(core, t0=0.2)
    assert outcome == "aborted"
    assert text.startswith("Failed to find a valid control even after executing recovery behaviors")
    assert "all samples collide" in text
    assert rec.started == 1
    # patience before the recovery; after it (as ROS) the next failure goes on to the next recovery
    assert 3.0 < t_end < 4.0
    assert planner.calls > 5  # it replanned between failures


def test_oscillation_timeout():
    ctrl = FakeController()
    core = MoveBaseCore(core_params(oscillation_timeout=2.0, oscillation_distance=0.5), FakePlanner([GOOD]), ctrl,
                        [FakeRecovery("r")])
    core.set_goal((3.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, t_end, _ = run(core)  # the robot never moves
    assert outcome == "aborted" and text.startswith("Robot is oscillating")
    assert 4.0 <= t_end <= 5.0


def test_moving_resets_the_oscillation_clock():
    ctrl = FakeController(reached_after=60)
    core = MoveBaseCore(core_params(oscillation_timeout=2.0), FakePlanner([GOOD]), ctrl, [])
    core.set_goal((30.0, 0.0, 0.0), 0.0, POSE)
    outcome, _, _, _ = run(core, pose=lambda t: (0.3 * t, 0.0, 0.0))  # 0.3 m/s: 0.5 m every 1.7 s
    assert outcome == "succeeded"


def test_stale_sensors_stop_the_robot_then_abort_saying_so():
    fresh = {"ok": True}
    core = MoveBaseCore(core_params(controller_patience=2.0), FakePlanner([GOOD]), FakeController(), [],
                        sensors_current=lambda: (fresh["ok"], "scan (/filtered_scan) last seen 3.1 s ago"))
    core.set_goal((3.0, 0.0, 0.0), 0.0, POSE)
    assert core.cycle(0.0, POSE).cmd == (0.3, 0.0, 0.1)
    fresh["ok"] = False
    r = core.cycle(0.2, POSE)
    assert r.cmd == (0.0, 0.0, 0.0) and "out of date" in r.text and r.outcome is None
    outcome, text, _, _ = run(core, t0=0.4)
    assert outcome == "aborted" and "Sensor data is out of date" in text and "/filtered_scan" in text


@pytest.mark.parametrize("blind", ["sensors", "pose"])
def test_standing_blind_does_not_count_toward_oscillation(blind):
    """A new goal, then 10 s with stale sensors (or no pose), then the sensors are back and the robot
    drives off: standing for them is not oscillating (oscillation_timeout 10 s, controller_patience 15 s).
    The ROS rule (the clock runs on) sent such a robot into its recoveries at once."""
    fresh = {"ok": False}
    rec = FakeRecovery("conservative_reset")
    core = MoveBaseCore(core_params(oscillation_timeout=10.0, controller_patience=15.0), FakePlanner([GOOD]),
                        FakeController(reached_after=200), [rec],
                        sensors_current=lambda: (fresh["ok"] or blind != "sensors", "scan last seen 3.1 s ago"))
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    for i in range(55):  # 11 s blind
        r = core.cycle(i * 0.2, None if blind == "pose" else POSE)
        assert r.outcome is None and r.cmd == (0.0, 0.0, 0.0)
    fresh["ok"] = True
    drove = []
    for i in range(55, 90):  # the sensors back; the robot sets off, slowly (0.1 m in the first 7 s)
        t = i * 0.2
        r = core.cycle(t, (0.015 * (t - 11.0), 0.0, 0.0))
        drove.append(r.cmd)
    assert rec.started == 0 and core.state == CONTROLLING, core.state
    assert all(c == (0.3, 0.0, 0.1) for c in drove)
    # the clock ran again from the moment the robot could drive (11 s): never 0.5 m on, the recoveries
    # come 10 s later
    for i in range(90, 200):
        core.cycle(i * 0.2, (0.1, 0.0, 0.0))
        if rec.started:
            break
    assert rec.started == 1 and 21.0 - 0.3 <= i * 0.2 <= 21.0 + 0.5, i * 0.2


def test_no_pose_is_a_transform_timeout():
    core = MoveBaseCore(core_params(controller_patience=1.0), FakePlanner([GOOD]), FakeController(), [])
    core.set_goal((3.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, _, _ = run(core, pose=None)
    assert outcome == "aborted" and text.startswith("Transform timeout")


def test_reset_mid_recovery_stops_stepping():
    planner = FakePlanner([Plan(False, reason="no path")])
    rec = FakeRecovery("rotate_recovery", steps=100)
    core = MoveBaseCore(core_params(planner_patience=0.0), planner, FakeController(), [rec])
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    for i in range(5):
        core.cycle(i * 0.2, POSE)
    assert core.state == CLEARING and rec.stepped > 0
    stepped = rec.stepped
    core.reset()
    assert core.cycle(2.0, POSE).cmd is None and rec.stepped == stepped


@pytest.mark.parametrize("bad", [{"controller_frequency": 0.0}, {"planner_patience": -1.0},
                                 {"oscillation_distance": math.nan}])
def test_params_are_validated(bad):
    with pytest.raises(ValueError, match=next(iter(bad))):
        core_params(**bad)


# --- recoveries --------------------------------------------------------------------------------
def test_default_recovery_list_is_rosses():
    specs = default_recovery_specs(3.0, 0.25, True)
    assert [s[0] for s in specs] == ["conservative_reset", "rotate_recovery", "aggressive_reset", "rotate_recovery"]
    assert specs[0][2] == 3.0 and specs[2][2] == pytest.approx(1.0)
    assert [s[0] for s in default_recovery_specs(3.0, 0.25, False)] == ["conservative_reset", "aggressive_reset"]


class FakeCostmap:
    def __init__(self, pose):
        self.pose = pose
        self.cleared = []

    def get_robot_pose(self):
        return self.pose

    def clear_outside(self, x, y, size):
        self.cleared.append((x, y, size))


def test_clear_costmap_recovery_clears_each_costmap_round_its_own_pose():
    a, b = FakeCostmap((1.0, 2.0, 0.0)), FakeCostmap((-3.0, 0.5, 1.0))
    rec = ClearCostmapRecovery("conservative_reset", [a, b], 3.0)
    rec.start(0.0, (0, 0, 0))
    assert rec.step(0.0, (0, 0, 0)) == (True, None)
    assert a.cleared == [(1.0, 2.0, 3.0)] and b.cleared == [(-3.0, 0.5, 3.0)]
    assert rec.outcome == "cleared obstacles farther than 1.50 m"


def simulate_rotation(rec, collide_at=None, dt=0.05):
    """Integrate the recovery's commands; returns the total turn [rad] and the commands."""
    state = {"yaw": 0.3}
    rec.costmap_check = lambda x, y, yaw: -1.0 if collide_at is not None and yaw - 0.3 >= collide_at else 0.0
    rec.pose_in_local = lambda: (0.0, 0.0, state["yaw"])
    rec.start(0.0, (0.0, 0.0, 0.0))
    cmds = []
    for i in range(2000):
        done, cmd = rec.step(i * dt, None)
        cmds.append(cmd)
        if done:
            break
        state["yaw"] += cmd[2] * dt
    return state["yaw"] - 0.3, cmds


def test_rotate_recovery_turns_once_within_limits():
    rec = RotateRecovery("rotate_recovery", None, None, acc_lim_th=3.0, max_rotational_vel=1.5,
                         min_in_place_rotational_vel=1.0)
    turned, cmds = simulate_rotation(rec)
    assert 2 * math.pi - 0.2 <= turned <= 2 * math.pi + 0.1
    speeds = [c[2] for c in cmds[:-1]]
    assert min(speeds) >= 1.0 and max(speeds) <= 1.5
    assert cmds[-1] == (0.0, 0.0, 0.0)
    assert rec.outcome.startswith("turned 6.")


def test_rotate_recovery_stops_before_a_collision():
    rec = RotateRecovery("rotate_recovery", None, None, max_rotational_vel=1.0, min_in_place_rotational_vel=0.4)
    turned, cmds = simulate_rotation(rec, collide_at=1.0)
    assert turned < 1.0
    assert cmds[-1] == (0.0, 0.0, 0.0)
    # how it ended, for the node's log: the collision ahead and the turn made
    assert rec.outcome.startswith("rotation in collision ") and f"after {turned:.2f} rad" in rec.outcome
    _, cmds = simulate_rotation(rec, collide_at=0.0)  # blocked at once
    assert len(cmds) == 1 and rec.outcome == "rotation in collision 0.02 rad ahead after 0.00 rad, stopping"
    rec.pose_in_local = lambda: None
    rec.start(0.0, None)
    assert rec.step(0.0, None) == (True, (0.0, 0.0, 0.0)) and rec.outcome.startswith("no robot pose")


def test_max_recovery_restarts_ends_a_robot_shuffling_on_the_spot():
    """Regression (bench/nav.py leg in a doorway): the robot moved 0.5 m now and then, which restarts
    the recovery list (ROS's rule), so the goal never ended; with max_recovery_restarts it does."""
    ctrl = FakeController()
    recs = [FakeRecovery("conservative_reset"), FakeRecovery("rotate_recovery")]

    def shuffle(t):  # back and forth by 0.6 m every 12 s: never oscillation_timeout-free for long
        return (0.6 if int(t // 12) % 2 else 0.0, 0.0, 0.0)

    core = MoveBaseCore(core_params(oscillation_timeout=5.0, max_recovery_restarts=2), FakePlanner([GOOD]), ctrl,
                        recs)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, _, _ = run(core, pose=shuffle, n=5000)
    assert outcome == "aborted" and "started over 3 times" in text and text.startswith("Robot is oscillating")
    unlimited = MoveBaseCore(core_params(oscillation_timeout=5.0), FakePlanner([GOOD]), FakeController(),
                             [FakeRecovery("a"), FakeRecovery("b")])
    unlimited.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    assert run(unlimited, pose=shuffle, n=5000)[0] is None  # ROS: on and on


def test_a_plan_that_leads_nowhere_does_not_restart_the_recoveries():
    """Regression (test_nav_sim, a person standing in a doorway for good): conservative_reset cleared
    the person, the planner found a way through them, the controller found no trajectory, planning
    failed again; ROS's rule restarted the list at every plan found, so the rotations never ran and
    the goal ended on max_recovery_restarts after conservative_reset alone."""
    cleared = {"fresh": False}

    class ClearingRecovery(FakeRecovery):
        def start(self, now, pose):
            super().start(now, pose)
            cleared["fresh"] = self.name == "conservative_reset"

    def planner(start, goal):
        ok, cleared["fresh"] = cleared["fresh"], False
        return GOOD if ok else Plan(False, reason="no path from (0.00, 0.00) to (5.00, 0.00)")

    recs = [ClearingRecovery("conservative_reset"), ClearingRecovery("rotate_recovery", steps=3)]
    core = MoveBaseCore(core_params(planner_patience=1.0, max_recovery_restarts=2), planner,
                        FakeController(ok=False), recs)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, _, _ = run(core, n=1000)
    assert outcome == "aborted" and text.startswith("Failed to find a valid plan even after executing"), text
    assert "started over" not in text
    assert [r.started for r in recs] == [1, 1]
    # a robot that got on (here: 0.6 m a cycle) between the recovery and the plan made progress,
    # and the list starts over, up to max_recovery_restarts
    recs = [ClearingRecovery("conservative_reset"), ClearingRecovery("rotate_recovery", steps=3)]
    core = MoveBaseCore(core_params(planner_patience=1.0, max_recovery_restarts=2), planner,
                        FakeController(ok=False), recs)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, _, _ = run(core, pose=lambda t: (3.0 * t, 0.0, 0.0), n=1000)
    assert outcome == "aborted" and "started over 3 times" in text, text
    assert [r.started for r in recs] == [3, 0]


# --- Florence: waiting for people ------------------------------------------------------------------
class FakePeople:
    """People in the way while ``blocked(now)``; give way to ``aside`` (or nowhere)."""

    def __init__(self, blocked, aside=None):
        self.blocked = blocked
        self.aside = aside
        self.now = 0.0
        self.give_way_asked = 0

    def blocking(self, pose, goal, reason, waiting=False):
        return "a person at (1.00, 0.00), 1.00 m away stands in the way" if self.blocked(self.now) else ""

    def give_way(self, pose):
        self.give_way_asked += 1
        return self.aside

    def clear(self, pose, poses):
        return not self.blocked(self.now)

    def plan_to(self, start, pose):
        return GOOD


class WaitingPlanner:
    """No plan while the people block; then the way."""

    def __init__(self, people):
        self.people = people
        self.calls = 0

    def __call__(self, start, goal):
        self.calls += 1
        return Plan(False, reason="no path") if self.people.blocked(self.people.now) else GOOD


class GivingWayController(FakeController):
    """Refuses to drive into the people while they block (as the local planner's
    min_person_distance), except on a plan that gives way."""

    def __init__(self, people, **kw):
        super().__init__(**kw)
        self.people = people
        self.giving_way = []

    def set_plan(self, poses, giving_way=False):
        self.plans.append(poses)
        self.giving_way.append(giving_way)
        self.calls_on_plan = 0

    def is_goal_reached(self):
        if self.giving_way and self.giving_way[-1]:
            return self.calls_on_plan >= 5  # out of the way after 5 cycles
        return super().is_goal_reached()

    def compute_velocity(self, pose):
        self.calls_on_plan = getattr(self, "calls_on_plan", 0) + 1
        if self.people.blocked(self.people.now) and not self.giving_way[-1]:
            self.calls += 1
            return False, (0.0, 0.0, 0.0), "no valid trajectory: the others would come nearer than ..."
        return super().compute_velocity(pose)


def run_people(core, people, n=400, dt=0.2, pose=POSE):
    results = []
    for i in range(n):
        now = i * dt
        people.now = now
        r = core.cycle(now, pose)
        results.append((now, core.state, r))
        if r.outcome:
            return r.outcome, r.text, now, results
    return None, "", n * dt, results


def test_a_person_in_the_way_makes_the_robot_wait_then_go_on():
    people = FakePeople(lambda now: 1.0 <= now < 21.0)
    ctrl = GivingWayController(people, reached_after=40)
    recs = [FakeRecovery("conservative_reset")]
    core = MoveBaseCore(core_params(planner_patience=1.0, person_wait_timeout=60.0), WaitingPlanner(people), ctrl,
                        recs, people=people)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, _, results = run_people(core, people)
    assert outcome == "succeeded", text
    assert recs[0].started == 0  # no recovery while a person was merely in the way
    waiting = [now for now, state, _ in results if state == "WAITING"]
    assert waiting and min(waiting) < 2.0 and 20.0 <= max(waiting) < 21.5
    assert all(r.cmd == (0.0, 0.0, 0.0) for now, state, r in results if state == "WAITING")


def test_without_person_wait_timeout_ros_runs_its_recoveries():
    people = FakePeople(lambda now: 1.0 <= now < 21.0)
    recs = [FakeRecovery("conservative_reset")]
    core = MoveBaseCore(core_params(planner_patience=1.0, controller_patience=2.0), WaitingPlanner(people),
                        GivingWayController(people, reached_after=40), recs, people=people)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, _, _, _ = run_people(core, people)
    assert outcome == "aborted" and recs[0].started == 1


def test_waiting_ends_in_the_recoveries_after_person_wait_timeout():
    people = FakePeople(lambda now: now >= 1.0)  # for good
    recs = [FakeRecovery("conservative_reset"), FakeRecovery("rotate_recovery")]
    core = MoveBaseCore(core_params(planner_patience=1.0, person_wait_timeout=10.0), WaitingPlanner(people),
                        GivingWayController(people), recs, people=people)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, t_end, results = run_people(core, people)
    assert outcome == "aborted"
    assert text.startswith("Failed to find a valid plan even after executing recovery behaviors: no path")
    assert "people stood in the way for 10 s (person_wait_timeout 10 s): a person at (1.00, 0.00)" in text
    assert [r.started for r in recs] == [1, 1]
    first_recovery = min(now for now, _, r in results if r.started_recovery)
    assert 11.0 <= first_recovery <= 12.0  # waited, then ROS's way (not waited for again)
    assert t_end < 20.0


def giving_way_core(people, ctrl):
    """A core with a goal 5 m ahead that waits for ``people`` and gives way after 3 s."""
    core = MoveBaseCore(core_params(planner_patience=1.0, person_wait_timeout=60.0, give_way_after=3.0),
                        WaitingPlanner(people), ctrl, [], people=people)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    return core


def test_giving_way_after_give_way_after():
    people = FakePeople(lambda now: 1.0 <= now < 15.0, aside=(-1.0, 1.0, 2.0))
    ctrl = GivingWayController(people, reached_after=None)
    core = giving_way_core(people, ctrl)
    results = run_people(core, people, n=90)[3]
    assert people.give_way_asked >= 1
    assert True in ctrl.giving_way  # the controller got the plan out of the way as such
    giving = [r for now, state, r in results if r.text == "giving way to people"]
    assert any(r.cmd != (0.0, 0.0, 0.0) for r in giving)  # it drove there
    first_ask = min(now for now, state, r in results if r.text == "giving way to people")
    assert 4.0 <= first_ask <= 4.5  # waited from 1.0 s, gave way 3 s later
    # the way free again: back to the goal's plan, not giving way
    assert ctrl.giving_way[-1] is False and results[-1][1] == CONTROLLING


class StuckGivingWay(GivingWayController):
    """A give-way plan the robot never gets along: valid zero commands (pressed against a jamb)."""

    def set_plan(self, poses, giving_way=False):
        super().set_plan(poses, giving_way)
        self.plan_times = [*getattr(self, "plan_times", []), (self.people.now, giving_way)]

    def is_goal_reached(self):
        return False if self.giving_way and self.giving_way[-1] else super().is_goal_reached()

    def compute_velocity(self, pose):
        if self.giving_way and self.giving_way[-1]:
            return True, (0.0, 0.0, 0.0), ""
        return super().compute_velocity(pose)


def test_a_give_way_move_that_gets_nowhere_ends():
    """The person waited for walks off while the robot stands in its give-way move: the move ends
    after GIVE_WAY_PATIENCE without progress, and the robot goes on once the way is free."""
    from move_base.move_base_core import GIVE_WAY_PATIENCE

    people = FakePeople(lambda now: 1.0 <= now < 12.0, aside=(-1.0, 1.0, 2.0))
    ctrl = StuckGivingWay(people, reached_after=None)
    core = giving_way_core(people, ctrl)
    results = run_people(core, people, n=150)[3]
    giving = [now for now, state, r in results if r.text == "giving way to people"]
    assert 4.0 <= min(giving) <= 4.5  # 3 s into the wait
    # each move (a plan out of the way) gives up GIVE_WAY_PATIENCE after it began; 3 at most
    starts = [t for t, aside in ctrl.plan_times if aside]
    assert 1 <= len(starts) <= 3
    for k, s0 in enumerate(starts):
        s1 = starts[k + 1] if k + 1 < len(starts) else math.inf
        assert max(n for n in giving if s0 <= n < s1) - s0 <= GIVE_WAY_PATIENCE + 0.3
    # before, the first move ran until the person it waited for came back, and the robot with it
    going_on = min(now for now, state, r in results if state == CONTROLLING and now > 12.0)
    assert going_on < 12.0 + GIVE_WAY_PATIENCE + 0.5
    # a move that makes progress is not cut short: the robot 0.1 m nearer every second
    people = FakePeople(lambda now: 1.0 <= now < 40.0, aside=(-3.0, 0.0, 0.0))
    ctrl = StuckGivingWay(people, reached_after=None)
    core = giving_way_core(people, ctrl)
    results = []
    for i in range(150):
        now = i * 0.2
        people.now = now
        results.append((now, core.cycle(now, (-0.1 * max(0.0, now - 4.0), 0.0, 0.0))))
    giving = [now for now, r in results if r.text == "giving way to people"]
    assert min(giving) <= 4.5 and max(giving) >= 29.0


def test_waiting_goes_on_only_with_nobody_close_in_front():
    """The way round the person exists (the plan and the controller agree), but the person stands
    close in front: the robot keeps waiting rather than creep past them."""
    people = FakePeople(lambda now: 1.0 <= now < 9.0)
    people.clear = lambda pose, poses: people.now >= 15.0
    people.blocking = lambda pose, goal, reason, waiting=False: "" if people.now >= 15.0 else "a person ..."
    ctrl = GivingWayController(people, reached_after=None)
    core = MoveBaseCore(core_params(person_wait_timeout=60.0), WaitingPlanner(people), ctrl, [], people=people)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    results = run_people(core, people, n=100)[3]
    waiting = [now for now, state, _ in results if state == "WAITING"]
    assert min(waiting) < 1.5 and 14.5 < max(waiting) < 15.5
    assert results[-1][1] == CONTROLLING


def test_no_give_way_when_there_is_nowhere_to_go():
    people = FakePeople(lambda now: now >= 1.0, aside=None)
    core = MoveBaseCore(core_params(person_wait_timeout=10.0, give_way_after=3.0), WaitingPlanner(people),
                        GivingWayController(people), [], people=people)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, _, _, results = run_people(core, people)
    assert outcome == "aborted" and people.give_way_asked == 3  # at 3, 6 and 9 s of waiting
    assert all(r.cmd == (0.0, 0.0, 0.0) for now, state, r in results if state == "WAITING")


def test_while_waiting_a_turn_toward_the_people_is_not_going_on():
    from move_base.move_base_core import _goes_on

    plan_ahead = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0]])
    plan_behind = np.array([[0.0, 0.0, math.pi], [-0.5, 0.0, math.pi], [-1.0, 0.0, math.pi]])
    assert _goes_on((0.2, 0.0, 0.0), (0.0, 0.0, 0.0), plan_ahead)
    assert not _goes_on((0.0, 0.0, 0.8), (0.0, 0.0, 0.0), plan_ahead)
    assert _goes_on((0.0, 0.0, 0.8), (0.0, 0.0, 0.0), plan_behind)  # it must turn first
    assert _goes_on((0.0, 0.0, 0.8), (0.0, 0.0, 0.0), plan_ahead[:1])  # at the goal: its yaw


class TurningController(FakeController):
    """Only a turn on the spot while the people block (the local planner refuses every way forward
    toward them but never a turn on the spot), then forward."""

    def __init__(self, people, **kw):
        super().__init__(**kw)
        self.people = people

    def compute_velocity(self, pose):
        self.calls += 1
        if self.people.blocked(self.people.now):
            return True, (0.0, 0.0, 0.8), ""
        return True, (0.3, 0.0, 0.0), ""


def test_a_turn_on_the_spot_before_a_person_close_in_front_is_waiting():
    """Nav bench seed 1 (1 Dec): Alice waited 0.52 m in front of the robot, the plan ran on past her,
    and the robot turned a full turn on the spot in 8 s (the local planner's only commands) before
    move_base waited."""
    ahead = Plan(True, np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]))
    people = FakePeople(lambda now: 1.0 <= now < 9.0)
    core = MoveBaseCore(core_params(person_wait_timeout=60.0), FakePlanner([ahead]), TurningController(people), [],
                        people=people)
    core.set_goal((2.0, 0.0, 0.0), 0.0, POSE)
    results = run_people(core, people, n=60)[3]
    waiting = [now for now, state, _ in results if state == "WAITING"]
    assert waiting and min(waiting) < 1.5 and 8.5 <= max(waiting) < 9.5
    assert all(r.cmd == (0.0, 0.0, 0.0) for now, state, r in results if 1.0 <= now < 9.0)  # no turning
    assert results[-1][1] == CONTROLLING and results[-1][2].cmd[0] > 0.0
    # a plan that starts behind the robot: turning toward it is going on, not waiting
    behind = Plan(True, np.array([[0.0, 0.0, math.pi], [-0.5, 0.0, math.pi], [-1.0, 0.0, math.pi]]))
    people = FakePeople(lambda now: 1.0 <= now < 9.0)
    core = MoveBaseCore(core_params(person_wait_timeout=60.0), FakePlanner([behind]), TurningController(people), [],
                        people=people)
    core.set_goal((-1.0, 0.0, math.pi), 0.0, POSE)
    results = run_people(core, people, n=60)[3]
    assert not [now for now, state, _ in results if state == "WAITING"]
    assert any(r.cmd == (0.0, 0.0, 0.8) for _, _, r in results)
    # and without person_wait_timeout ROS's behaviour: the turn
    people = FakePeople(lambda now: 1.0 <= now < 9.0)
    core = MoveBaseCore(core_params(person_wait_timeout=0.0), FakePlanner([ahead]), TurningController(people), [],
                        people=people)
    core.set_goal((2.0, 0.0, 0.0), 0.0, POSE)
    assert any(r.cmd == (0.0, 0.0, 0.8) for _, _, r in run_people(core, people, n=60)[3])


def test_flipping_between_blocked_and_free_without_progress_still_times_out():
    """A person just at min_person_distance: the way looks free for a moment, then blocked again, and the
    robot does not get on. The waits add up (ROS-style patience would restart every flip): after
    person_wait_timeout of waiting in all, the recoveries run and the goal aborts with the reason."""
    people = FakePeople(lambda now: now >= 1.0 and (now - 1.0) % 1.6 < 1.2)  # blocked 1.2 s, free 0.4 s
    recs = [FakeRecovery("conservative_reset")]
    core = MoveBaseCore(core_params(planner_patience=1.0, controller_patience=2.0, person_wait_timeout=10.0,
                                    max_recovery_restarts=2), WaitingPlanner(people),
                        GivingWayController(people, reached_after=None), recs, people=people)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, t_end, results = run_people(core, people, n=1000)
    assert outcome == "aborted", [(now, state) for now, state, _ in results[-20:]]
    assert "people stood in the way for 10 s" in text, text
    went_on = sum(1 for i in range(1, len(results)) if results[i - 1][1] == "WAITING" and results[i][1] != "WAITING")
    assert went_on >= 3  # it did flip
    assert recs[0].started >= 1
    assert t_end < 10.0 / (1.2 / 1.6) + 10.0


def test_a_wait_goes_on_while_the_people_are_out_of_view():
    """The people are seen at first, then only the marks they left block the plan (the robot turned
    away from them): the wait goes on to person_wait_timeout and the goal aborts saying people stood
    in the way (before, the wait ended as soon as nobody was in view, the recoveries ran, and the
    abort gave only the planner's reason)."""
    class OutOfView(FakePeople):
        def blocking(self, pose, goal, reason, waiting=False):
            seen = self.now < 3.0
            return "a person at (1.00, 0.00), 1.00 m away stands in the way" if seen or waiting else ""

    people = OutOfView(lambda now: now >= 1.0)
    recs = [FakeRecovery("conservative_reset")]
    core = MoveBaseCore(core_params(planner_patience=1.0, person_wait_timeout=10.0), WaitingPlanner(people),
                        GivingWayController(people, reached_after=None), recs, people=people)
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    outcome, text, _, results = run_people(core, people, n=1000)
    assert outcome == "aborted", [(now, state) for now, state, _ in results[-20:]]
    assert "people stood in the way for 10 s" in text, text
    waiting = [now for now, state, _ in results if state == "WAITING"]
    assert waiting and waiting[-1] - waiting[0] >= 9.5  # one wait, on past the time the people left the view


def test_progress_between_waits_starts_the_wait_afresh():
    """Blocked 5 s out of every 7, person_wait_timeout 8 s: while the robot gets 0.5 m (oscillation_distance)
    nearer the goal between the waits, no wait adds up to the timeout and the robot arrives."""
    people = FakePeople(lambda now: now % 7.0 < 5.0)
    ctrl = GivingWayController(people, reached_after=None)
    core = MoveBaseCore(core_params(person_wait_timeout=8.0, oscillation_distance=0.5), WaitingPlanner(people),
                        ctrl, [FakeRecovery("conservative_reset")], people=people)
    core.set_goal((20.0, 0.0, 0.0), 0.0, POSE)
    x, states = 0.0, []
    for i in range(300):  # 60 s at 5 Hz, 0.3 m/s while controlling
        now = i * 0.2
        people.now = now
        r = core.cycle(now, (x, 0.0, 0.0))
        assert r.outcome is None, r.text
        states.append(core.state)
        if core.state == CONTROLLING:
            x += 0.3 * 0.2
    assert states.count("WAITING") > 100 and x > 3.0


@pytest.mark.parametrize("blind", ["sensors", "pose"])
def test_a_moment_without_pose_after_a_long_wait_is_no_transform_timeout(blind):
    """20 s of waiting for a person (controller_patience 15 s), then one cycle where tf cannot place
    the robot (or the sensors lag): the robot stands that cycle and waits on. The goal used to abort
    at once, "no robot pose for longer than controller_patience (15.0 s)", after 0.6 s without one
    (florence_sim, giving way to Bob on a loaded machine). Blind for longer than the patience, it
    still aborts."""
    fresh = {"ok": True}
    people = FakePeople(lambda now: now >= 1.0)
    core = MoveBaseCore(core_params(planner_patience=1.0, person_wait_timeout=60.0, controller_patience=15.0),
                        WaitingPlanner(people), GivingWayController(people, reached_after=40), [], people=people,
                        sensors_current=lambda: (fresh["ok"], "scan (/filtered_scan) last seen 0.6 s ago"))
    core.set_goal((5.0, 0.0, 0.0), 0.0, POSE)
    _, _, _, results = run_people(core, people, n=100)  # 20 s
    assert results[-1][1] == "WAITING"

    def cycle(now):
        people.now = now
        if blind == "sensors":
            fresh["ok"] = False
            return core.cycle(now, POSE)
        return core.cycle(now, None)

    r = cycle(20.0)
    assert r.outcome is None and r.cmd == (0.0, 0.0, 0.0), r.text
    fresh["ok"] = True
    people.now = 20.2
    r = core.cycle(20.2, POSE)
    assert r.outcome is None and core.state == "WAITING"
    for i in range(80):  # 16 s blind
        r = cycle(20.4 + i * 0.2)
        if r.outcome:
            break
    assert r.outcome == "aborted", r.text
    assert r.text.startswith("Transform timeout" if blind == "pose" else "Sensor data is out of date")
    assert 20.2 + 15.0 - 0.01 <= 20.4 + i * 0.2 <= 20.2 + 15.0 + 0.4  # patience from the last sighting
