"""The action-server base: every goal ends in exactly one of SUCCEEDED, PREEMPTED or ABORTED,
with a reason; halt() runs at once on cancel and after every goal."""

import threading

import pytest

pytestmark = pytest.mark.ros


@pytest.fixture(scope="module")
def toy(rospy_node):
    from actionlib.msg import TestAction, TestResult

    from florence_common_ros.actions import SimpleActionClient
    from florence_common_ros.behaviour import Behaviour, succeeded

    class Toy(Behaviour):
        """goal 1: refused by begin; 2: succeeds on the third cycle; 3: runs until cancelled;
        4: raises in step."""

        def __init__(self):
            super().__init__("toy_behaviour", TestAction, rate=50.0)
            self.halts = 0
            self.cycles = 0
            self.goals_begun = 0
            self.halt_event = threading.Event()
            self.start()

        def begin(self, goal):
            self.cycles = 0
            self.goals_begun += 1
            return "goal 1 is refused" if goal.goal == 1 else None

        def step(self, goal):
            self.cycles += 1
            if goal.goal == 2 and self.cycles == 3:
                return succeeded("three cycles done", TestResult(result=3))
            if goal.goal == 4:
                raise RuntimeError("sensor exploded")
            return None

        def halt(self):
            self.halts += 1
            self.halt_event.set()

        def result(self):
            return TestResult(result=-1)

    server = Toy()
    client = SimpleActionClient("toy_behaviour", TestAction)
    assert client.wait_for_server(rospy_node.Duration(10))
    yield server, client


def _send(client, value, timeout=10.0):
    import rospy
    from actionlib.msg import TestGoal

    client.send_goal(TestGoal(goal=value))
    assert client.wait_for_result(rospy.Duration(timeout))
    return client.get_state(), client.get_goal_status_text(), client.get_result()


def test_begin_refusal_aborts_with_its_reason(toy):
    from actionlib_msgs.msg import GoalStatus

    server, client = toy
    halts = server.halts
    state, text, result = _send(client, 1)
    assert (state, text, result.result) == (GoalStatus.ABORTED, "goal 1 is refused", -1)
    assert server.halts == halts + 1


def test_success_carries_the_step_result(toy):
    from actionlib_msgs.msg import GoalStatus

    server, client = toy
    state, text, result = _send(client, 2)
    assert (state, text, result.result) == (GoalStatus.SUCCEEDED, "three cycles done", 3)
    assert server.cycles == 3


def test_cancel_halts_at_once_and_preempts(toy, rospy_node):
    from actionlib.msg import TestGoal
    from actionlib_msgs.msg import GoalStatus

    from florence_common.processes import wait_for

    server, client = toy
    begun = server.goals_begun
    client.send_goal(TestGoal(goal=3))
    # cycles still holds the previous goal's count until begin() runs: wait for this goal's
    # begin, then for its cycles (a cancel that overtakes the goal would make it RECALLED)
    wait_for(lambda: server.goals_begun > begun and server.cycles > 2, 10.0, what="the goal running")
    server.halt_event.clear()
    client.cancel_goal()
    assert server.halt_event.wait(5.0)
    assert client.wait_for_result(rospy_node.Duration(10))
    assert client.get_state() == GoalStatus.PREEMPTED
    assert "cancelled" in client.get_goal_status_text()


def test_an_exception_aborts_with_its_text(toy):
    from actionlib_msgs.msg import GoalStatus

    _server, client = toy
    state, text, result = _send(client, 4)
    assert state == GoalStatus.ABORTED
    assert text == "internal error: RuntimeError: sensor exploded"
    assert result.result == -1
