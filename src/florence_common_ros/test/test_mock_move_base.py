"""The mock move_base answers goals as scripted, records them, and its make_plan refuses
blocked goals."""

import pytest

pytestmark = pytest.mark.ros


def test_scripted_outcomes_and_make_plan(rospy_node):
    from actionlib_msgs.msg import GoalStatus
    from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
    from nav_msgs.srv import GetPlan

    from florence_common_ros.actions import SimpleActionClient
    from florence_common_ros.convert import pose_stamped
    from florence_common_ros.mock_move_base import MockMoveBase, Reply

    mock = MockMoveBase(name="mock_nav", blocked=lambda x, y: y > 5.0,
                        policy=lambda x, y, yaw, frame: Reply("aborted" if x < 0 else "succeeded", 0.1))
    client = SimpleActionClient("mock_nav", MoveBaseAction)
    assert client.wait_for_server(rospy_node.Duration(10))
    outcomes = []
    for x, y in ((1.0, 2.0), (-1.0, 0.0), (0.0, 6.0)):
        client.send_goal(MoveBaseGoal(target_pose=pose_stamped(x, y, 0.3, "map")))
        assert client.wait_for_result(rospy_node.Duration(10))
        outcomes.append(client.get_state())
    assert outcomes == [GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.ABORTED]
    assert [g[:2] for g in mock.goals] == [(1.0, 2.0), (-1.0, 0.0), (0.0, 6.0)]
    assert mock.goals[0][3] == "map" and mock.goals[0][2] == pytest.approx(0.3)

    rospy_node.wait_for_service("mock_nav/make_plan", 10)
    plan = rospy_node.ServiceProxy("mock_nav/make_plan", GetPlan)
    start = pose_stamped(0.0, 0.0, 0.0, "map")
    assert len(plan(start, pose_stamped(1.0, 1.0, 0.0, "map"), 0.1).plan.poses) == 2
    assert len(plan(start, pose_stamped(1.0, 6.0, 0.0, "map"), 0.1).plan.poses) == 0
