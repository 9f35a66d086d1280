"""actionlib helpers that never block (a rospy client under a stalled simulated clock would wait
for ever in ``wait_for_server``)."""

import threading

import actionlib
from actionlib_msgs.msg import GoalStatus

STATE_NAMES = {v: k for k, v in vars(GoalStatus).items() if isinstance(v, int) and k.isupper()}


def state_name(state):
    """actionlib's name of a GoalStatus value (SUCCEEDED, ABORTED, ...), or the number as text."""
    return STATE_NAMES.get(state, str(state))


ACTIVE_STATES = (GoalStatus.ACTIVE, GoalStatus.PREEMPTING)
DONE_STATES = (GoalStatus.PREEMPTED, GoalStatus.SUCCEEDED, GoalStatus.ABORTED, GoalStatus.REJECTED,
               GoalStatus.RECALLED, GoalStatus.LOST)


class SimpleActionClient(actionlib.SimpleActionClient):
    """actionlib's SimpleActionClient without its ``send_goal`` race (ros/actionlib#206, never fixed
    in ROS 1): the client assigns its goal handle only after the goal is published, and a server
    that answers within that window (a goal refused at once, on a loaded machine) has its status
    and result dropped ("Got a transition callback on a goal handle that we're not tracking"):
    ``wait_for_result`` then waits for ever. Here ``send_goal`` and the transition and feedback
    callbacks take one lock, so a transition waits until the handle it belongs to is known."""

    def __init__(self, ns, action_spec):
        self._send_lock = threading.RLock()
        super().__init__(ns, action_spec)

    def send_goal(self, goal, done_cb=None, active_cb=None, feedback_cb=None):
        with self._send_lock:
            super().send_goal(goal, done_cb=done_cb, active_cb=active_cb, feedback_cb=feedback_cb)

    def _handle_transition(self, gh):
        with self._send_lock:
            super()._handle_transition(gh)

    def _handle_feedback(self, gh, feedback):
        with self._send_lock:
            super()._handle_feedback(gh, feedback)


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


class SentGoal:
    """A goal sent through the SimpleActionClient ``client``, whose ``active_cb()`` and
    ``done_cb(state)`` are each called exactly once, even when actionlib drops the transition.

    rospy's SimpleActionClient assigns its goal handle only after ``send_goal`` has published the
    goal; a server that answers at once (on the same machine, or a goal aborted immediately) can
    have its status processed in that window, and the client then drops the transition ("Got a
    transition callback on a goal handle that we're not tracking"): the active or the done
    callback never comes although ``get_state()`` tells it. :meth:`poll`, called periodically,
    delivers what was dropped from ``get_state()``. Call it from one thread with the goal still
    the client's newest (a newer goal replaces this one and its poll does nothing).
    """

    def __init__(self, client, goal, active_cb=None, done_cb=None, feedback_cb=None):
        self.client = client
        self._active_cb, self._done_cb = active_cb, done_cb
        self._lock = threading.Lock()
        self.active = self.done = False
        self.state = None  # the GoalStatus value it ended in, once done
        client.send_goal(goal, done_cb=lambda state, _result: self._on_done(state), active_cb=self._on_active,
                         feedback_cb=feedback_cb)
        self._handle = client.gh

    def poll(self):
        """Deliver a transition actionlib dropped; True once the goal is done."""
        if not self.done and self.client.gh is self._handle and self._handle is not None:
            state = self.client.get_state()
            if state in ACTIVE_STATES:
                self._on_active()
            elif state in DONE_STATES:
                self._on_done(state)
        return self.done

    def _on_active(self):
        with self._lock:
            if self.active or self.done:
                return
            self.active = True
        if self._active_cb is not None:
            self._active_cb()

    def _on_done(self, state):
        with self._lock:
            if self.done:
                return
            self.done, self.state = True, state
        if self._done_cb is not None:
            self._done_cb(state)
