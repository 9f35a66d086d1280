"""actionlib helpers that never block (a rospy client under a stalled simulated clock would wait
for ever in ``wait_for_server``)."""

from actionlib_msgs.msg import GoalStatus

STATE_NAMES = {v: k for k, v in vars(GoalStatus).items() if isinstance(v, int) and k.isupper()}


def state_name(state):
    """actionlib's name of a GoalStatus value (SUCCEEDED, ABORTED, ...), or the number as text."""
    return STATE_NAMES.get(state, str(state))


def server_ready(client):
    """Whether the SimpleActionClient ``client`` is connected to its server now: the test of
    actionlib's ``wait_for_server`` (a status message came, and the goal and cancel topics and the
    result and feedback topics are connected to the server that sent it), done once."""
    ac = client.action_client
    status = ac.last_status_msg
    if status is None:
        return False
    server = status._connection_header.get("callerid") if status._connection_header else None
    if server is None:
        return False
    if not (ac.pub_goal.impl.has_connection(server) and ac.pub_cancel.impl.has_connection(server)):
        return False
    return (any(c.callerid_pub == server for c in ac.result_sub.impl.connections)
            and any(c.callerid_pub == server for c in ac.feedback_sub.impl.connections))


def server_ready_within(client, timeout, period=0.05):
    """:func:`server_ready`, waiting up to ``timeout`` s of wall time for the connection (a node
    called just after start-up, before its client met the server); never blocks on a stalled
    simulated clock."""
    import time

    deadline = time.monotonic() + timeout
    while not server_ready(client):
        if time.monotonic() >= deadline:
            return False
        time.sleep(period)
    return True
