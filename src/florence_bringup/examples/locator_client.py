#!/usr/bin/python3
"""Call florenceLocator as a Florence service does: send the robot to a room, or find the user.

    rosrun florence_bringup locator_client.py room kitchen       # gotoRoom, wait, where is the robot
    rosrun florence_bringup locator_client.py user living_room   # a sensor saw the user there; gotoUser
    rosrun florence_bringup locator_client.py user               # gotoUser from the last known place

The go-to services answer at once (success: accepted, message: why not) and the robot moves in the
background; getStatus tells how it goes (ACTIVE, then SUCCEEDED, ABORTED or PREEMPTED) and why.
Exit status: 0 when the robot arrived, 1 when the call was refused or the activity did not succeed.
"""

import sys

import rospy

from florence_locator import srv

DONE = ("SUCCEEDED", "ABORTED", "PREEMPTED", "REJECTED", "RECALLED")


def call(name, *args):
    """florenceLocator/<name>(*args): the service's response (every one has success and message)."""
    service = f"florenceLocator/{name}"
    rospy.wait_for_service(service, 30.0)
    cls = getattr(srv, name[0].upper() + name[1:])
    return rospy.ServiceProxy(service, cls)(*args)


def wait_done(timeout=300.0):
    """Poll getStatus until the activity ends (or ``timeout`` s of ROS time): its response."""
    deadline = rospy.get_time() + timeout
    status = call("getStatus")
    while status.status not in DONE and rospy.get_time() < deadline and not rospy.is_shutdown():
        rospy.sleep(0.5)
        status = call("getStatus")
    return status


def goto_room(room):
    reply = call("gotoRoom", room)
    print(f"gotoRoom({room!r}): success {reply.success}, {reply.message}")
    if not reply.success:  # e.g. an unknown room: nothing moves
        return False
    status = wait_done()
    where = call("getRobotPosRoom")
    print(f"getStatus: {status.status} ({status.message}); the robot is in {where.room}")
    return status.status == "SUCCEEDED"


def find_user(room=None):
    if room is not None:
        reply = call("setUserPosRoom", room)  # what a home sensor would report
        print(f"setUserPosRoom({room!r}): success {reply.success}, {reply.message}")
        if not reply.success:
            return False
    reply = call("gotoUser")
    print(f"gotoUser: success {reply.success}, {reply.message}")
    if not reply.success:
        return False
    status = wait_done()
    user = call("getUserPosXYPhi")
    print(f"getStatus: {status.status} ({status.message}); the user at ({user.x:.2f}, {user.y:.2f}) ({user.message})")
    return status.status == "SUCCEEDED"


def main(argv):
    if len(argv) < 2 or argv[1] not in ("room", "user") or (argv[1] == "room" and len(argv) != 3):
        print(__doc__, file=sys.stderr)
        return 2
    rospy.init_node("locator_client", anonymous=True)
    ok = goto_room(argv[2]) if argv[1] == "room" else find_user(argv[2] if len(argv) > 2 else None)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main(rospy.myargv(sys.argv)))
