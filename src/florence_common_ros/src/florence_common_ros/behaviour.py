"""The action-server base of the Florence behaviours (follow_me, approach_me, ...).

A behaviour subclasses :class:`Behaviour` and writes three methods:

- ``begin(goal)``: check and take the goal; return None to go on, or a reason text to end
  it ABORTED at once (bad fields, nobody to follow);
- ``step(goal)``: one control cycle, called at ``rate`` [Hz] of ROS time; return None to go
  on, or :func:`succeeded` / :func:`aborted` with a reason text and the result message;
- ``halt()``: command a safe state (zero velocity). Called at once when a cancel or a new
  goal arrives (from actionlib's preempt callback, not a cycle later), and after every
  goal however it ended.

The base does the rest the same way for every behaviour (STYLE habit 9): the
SimpleActionServer is made with ``auto_start=False`` and started by :meth:`start`, which
the subclass calls last in its constructor; the loop checks preemption and shutdown every
cycle; an exception in ``begin`` or ``step`` ends the goal ABORTED with its text (and is
logged with its traceback); every goal ends in exactly one of SUCCEEDED, PREEMPTED or
ABORTED, with a text saying why.
"""

import threading
import traceback
from dataclasses import dataclass
from typing import Any

import actionlib
import rospy


@dataclass(frozen=True)
class Outcome:
    state: str  # "succeeded", "aborted" or "preempted"
    text: str
    result: Any = None


def succeeded(text, result=None):
    return Outcome("succeeded", text, result)


def aborted(text, result=None):
    return Outcome("aborted", text, result)


def preempted(text, result=None):
    return Outcome("preempted", text, result)


class Behaviour:
    """SimpleActionServer ``name`` of ``action_class`` running ``step`` at ``rate`` [Hz]."""

    def __init__(self, name, action_class, rate):
        if not rate > 0:
            raise ValueError(f"control rate must be > 0 [Hz], got {rate}")
        self.action_name = name
        self.rate = float(rate)
        self.log_prefix = f"{name}: "
        self._halt_lock = threading.Lock()
        self.server = actionlib.SimpleActionServer(name, action_class, execute_cb=self._execute, auto_start=False)
        self.server.register_preempt_callback(self._on_preempt)

    # --- for subclasses ----------------------------------------------------------------------------
    def begin(self, goal):
        return None

    def step(self, goal):
        raise NotImplementedError

    def halt(self):
        pass

    def result(self):
        """The result message for an ending without one of its own (preemption, shutdown, errors)."""
        return None

    def start(self):
        """Start serving goals: the last line of the subclass's constructor."""
        self.server.start()

    def shutdown(self):
        """run() registers this with rospy.on_shutdown: a safe state on the way out."""
        self._safe_halt()

    # --- the loop --------------------------------------------------------------------------------------
    def _safe_halt(self):
        with self._halt_lock:
            try:
                self.halt()
            except Exception:  # noqa: BLE001 - a failing halt must not hide the outcome
                rospy.logerr(self.log_prefix + "halt failed:\n%s", traceback.format_exc())

    def _on_preempt(self):
        self._safe_halt()

    def _execute(self, goal):
        outcome = self._run(goal)
        self._safe_halt()
        result = outcome.result if outcome.result is not None else self.result()
        text = outcome.text
        if outcome.state == "succeeded":
            rospy.loginfo(self.log_prefix + "SUCCEEDED: %s", text)
            self.server.set_succeeded(result, text)
        elif outcome.state == "preempted":
            rospy.loginfo(self.log_prefix + "PREEMPTED: %s", text)
            self.server.set_preempted(result, text)
        else:
            rospy.logwarn(self.log_prefix + "ABORTED: %s", text)
            self.server.set_aborted(result, text)

    def _run(self, goal):
        try:
            reason = self.begin(goal)
            if reason:
                return aborted(reason)
            rate = rospy.Rate(self.rate)
            while True:
                if rospy.is_shutdown():
                    return aborted("the node is shutting down")
                if self.server.is_preempt_requested():
                    return preempted("cancelled, or replaced by a new goal")
                outcome = self.step(goal)
                if outcome is not None:
                    return outcome
                try:
                    rate.sleep()
                except rospy.ROSTimeMovedBackwardsException:
                    rate = rospy.Rate(self.rate)  # simulated time was reset: start the cycle anew
        except rospy.ROSInterruptException:
            return aborted("the node is shutting down")
        except Exception as exc:  # noqa: BLE001 - every goal ends with a reason, never a stuck client
            rospy.logerr(self.log_prefix + "internal error:\n%s", traceback.format_exc())
            return aborted(f"internal error: {type(exc).__name__}: {exc}")
