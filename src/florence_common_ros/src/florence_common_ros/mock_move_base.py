"""A scriptable stand-in for move_base, for testing behaviours without navigation.

It serves what a client of move_base uses: the ``move_base`` action (move_base_msgs/
MoveBaseAction), ``move_base_simple/goal`` and ``move_base/make_plan`` (nav_msgs/GetPlan).
What each goal does is a :class:`Reply`: succeed, abort, or never finish (until cancelled),
after ``after`` [s] of ROS time. ``policy(x, y, yaw, frame_id)`` chooses it per goal (the
default succeeds after 0.5 s); ``blocked(x, y)`` makes ``make_plan`` answer an empty plan
(no path) and goals there abort. With ``publish_tf`` the mock "drives" instantly: on
success it broadcasts ``map -> base_link`` at the goal, so a behaviour that reads the robot's
pose from tf sees it arrive.

In a test (the process is a rospy node already):

    mock = MockMoveBase(policy=lambda x, y, yaw, frame: Reply("aborted", text="no path"))
    ...
    assert mock.goals[-1][:2] == pytest.approx((1.0, 2.0))

As a node (``rosrun florence_common_ros mock_move_base``), parameters ``~outcome``
("succeeded", "aborted" or "hang"), ``~after`` [s], ``~publish_tf`` (bool).
"""

import threading
from dataclasses import dataclass

import actionlib
import rospy
import tf2_ros
from geometry_msgs.msg import PoseStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseResult
from nav_msgs.msg import Path
from nav_msgs.srv import GetPlan, GetPlanResponse

from florence_common.params import Param, ParamTable
from florence_common_ros.actions import SimpleActionClient
from florence_common_ros.convert import to_xyyaw, transform_stamped
from florence_common_ros.node import read_params, run

OUTCOMES = ("succeeded", "aborted", "hang")


@dataclass(frozen=True)
class Reply:
    state: str = "succeeded"  # one of OUTCOMES
    after: float = 0.5  # [s] of ROS time before the goal ends
    text: str = ""


class MockMoveBase:
    def __init__(self, policy=None, blocked=None, publish_tf=False, name="move_base", global_frame="map",
                 base_frame="base_link"):
        self.policy = policy or (lambda x, y, yaw, frame: Reply())
        self.blocked = blocked or (lambda x, y: False)
        self.global_frame, self.base_frame = global_frame, base_frame
        self.goals = []  # (x, y, yaw, frame_id) of every goal, in arrival order
        self.outcomes = []  # "succeeded" / "aborted" / "preempted" of every ended goal
        self._lock = threading.Lock()
        self.tf = tf2_ros.TransformBroadcaster() if publish_tf else None
        self.pose = (0.0, 0.0, 0.0)
        self.server = actionlib.SimpleActionServer(name, MoveBaseAction, execute_cb=self._execute, auto_start=False)
        self.simple_client = SimpleActionClient(name, MoveBaseAction)
        self.simple_sub = rospy.Subscriber(f"{name}_simple/goal", PoseStamped, self._on_simple_goal, queue_size=1)
        self.plan_srv = rospy.Service(f"{name}/make_plan", GetPlan, self._make_plan)
        if self.tf is not None:
            self.tf_timer = rospy.Timer(rospy.Duration(0.05), lambda _e: self._broadcast())
        self.server.start()

    def _broadcast(self):
        x, y, yaw = self.pose
        self.tf.sendTransform(transform_stamped(rospy.Time.now(), self.global_frame, self.base_frame, x, y, yaw))

    def _on_simple_goal(self, msg):
        from move_base_msgs.msg import MoveBaseGoal

        self.simple_client.send_goal(MoveBaseGoal(target_pose=msg))

    def _make_plan(self, req):
        gx, gy, _ = to_xyyaw(req.goal)
        path = Path()
        path.header.frame_id = req.goal.header.frame_id or self.global_frame
        if not self.blocked(gx, gy):
            path.poses = [req.start, req.goal]
        return GetPlanResponse(plan=path)

    def _execute(self, goal):
        x, y, yaw = to_xyyaw(goal.target_pose)
        frame = goal.target_pose.header.frame_id
        with self._lock:
            self.goals.append((x, y, yaw, frame))
        reply = Reply("aborted", 0.0, "no valid plan (mock: blocked)") if self.blocked(x, y) \
            else self.policy(x, y, yaw, frame)
        end = rospy.Time.now() + rospy.Duration(max(0.0, reply.after))
        rate = rospy.Rate(50)
        while not rospy.is_shutdown():
            if self.server.is_preempt_requested():
                self._end("preempted", "cancelled")
                return
            if reply.state != "hang" and rospy.Time.now() >= end:
                break
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                return
        if reply.state == "succeeded":
            self.pose = (x, y, yaw)
            self._end("succeeded", reply.text or "Goal reached (mock).")
        else:
            self._end("aborted", reply.text or "Failed (mock).")

    def _end(self, state, text):
        with self._lock:
            self.outcomes.append(state)
        getattr(self.server, f"set_{state}")(MoveBaseResult(), text)


PARAMS = ParamTable(
    Param("outcome", str, "succeeded", "how every goal ends", choices=OUTCOMES),
    Param("after", float, 0.5, "ROS time before a goal ends", unit="s", ge=0),
    Param("publish_tf", bool, False, "broadcast map -> base_link at each reached goal"),
)


class MockMoveBaseNode:
    def __init__(self):
        p = read_params(PARAMS)
        self.mock = MockMoveBase(policy=lambda *_goal: Reply(p.outcome, p.after), publish_tf=p.publish_tf)


def main():
    run(MockMoveBaseNode, "move_base")
