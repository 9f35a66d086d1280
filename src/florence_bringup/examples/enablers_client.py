#!/usr/bin/python3
"""Call the robot enablers as a Florence service does: follow the user, or come close to them.

    rosrun florence_bringup enablers_client.py follow 1.5 0.0 --seconds 60
    rosrun florence_bringup enablers_client.py approach 1.5 0.0 --distance 0.8 --p2r 0.5 --r2p 0

(x, y) [m] is where the person is, in the robot's frame (base_link: x ahead, y to the left), as
the tracker (/filtered_tracked_users) or a florenceLocator answer tells; the nearest tracked person
is taken. follow_me runs until cancelled (here after --seconds) or the person is lost; its feedback
is the person's place in the robot's frame. approach_me ends SUCCEEDED at the pose: --distance [m]
between robot and person, --p2r [rad] round the person from the side the robot came from (positive
counter-clockwise), --r2p [rad] the robot's final heading from facing the person. Zero fields take
the servers' defaults. Exit status 0 when the goal ended as asked.
"""

import argparse
import sys

import rospy
from actionlib_msgs.msg import GoalStatus
from approach_me.msg import ApproachMeAction, ApproachMeGoal
from follow_me.msg import FollowMeAction, FollowMeGoal

from florence_common_ros.actions import SimpleActionClient

NAMES = {v: k for k, v in vars(GoalStatus).items() if isinstance(v, int) and k.isupper()}


def client_of(name, action):
    client = SimpleActionClient(name, action)
    if not client.wait_for_server(rospy.Duration(30.0)):
        raise SystemExit(f"no {name} action server (is florence_bringup.launch running?)")
    return client


def follow(x, y, seconds):
    client = client_of("follow_me", FollowMeAction)
    client.send_goal(FollowMeGoal(x=x, y=y), feedback_cb=lambda fb: print(f"person at ({fb.x:.2f}, {fb.y:.2f})"))
    if client.wait_for_result(rospy.Duration(seconds)):  # it ended by itself: refused or the person lost
        print(f"follow_me: {NAMES[client.get_state()]} ({client.get_goal_status_text()})")
        return False
    client.cancel_goal()  # the robot stops at once
    client.wait_for_result(rospy.Duration(10.0))
    result = client.get_result()
    print(f"follow_me: {NAMES[client.get_state()]}; the person last at ({result.x:.2f}, {result.y:.2f})")
    return client.get_state() == GoalStatus.PREEMPTED


def approach(x, y, distance, p2r, r2p, timeout):
    client = client_of("approach_me", ApproachMeAction)
    goal = ApproachMeGoal(x=x, y=y, desired_distance=distance, desired_p2r_orientation=p2r,
                          desired_r2p_orientation=r2p)
    client.send_goal(goal)
    if not client.wait_for_result(rospy.Duration(timeout)):
        client.cancel_goal()
        print("approach_me: no result in time, cancelled")
        return False
    print(f"approach_me: {NAMES[client.get_state()]} ({client.get_goal_status_text()})")
    return client.get_state() == GoalStatus.SUCCEEDED


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("action", choices=("follow", "approach"))
    parser.add_argument("x", type=float, help="the person's x in base_link [m]")
    parser.add_argument("y", type=float, help="the person's y in base_link [m]")
    parser.add_argument("--seconds", type=float, default=60.0, help="follow: cancel after this long [s]")
    parser.add_argument("--distance", type=float, default=0.0, help="approach: final distance [m] (0: default)")
    parser.add_argument("--p2r", type=float, default=0.0, help="approach: angle round the person [rad]")
    parser.add_argument("--r2p", type=float, default=0.0, help="approach: final heading from facing them [rad]")
    parser.add_argument("--timeout", type=float, default=120.0, help="approach: give up after [s]")
    args = parser.parse_args(argv[1:])
    rospy.init_node("enablers_client", anonymous=True)
    rospy.sleep(0.5)  # a fresh action client's first goal can be lost while its connections settle
    if args.action == "follow":
        ok = follow(args.x, args.y, args.seconds)
    else:
        ok = approach(args.x, args.y, args.distance, args.p2r, args.r2p, args.timeout)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(rospy.myargv(sys.argv)))
