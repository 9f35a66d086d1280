"""Topic helpers for ROS tests (wall time: the test's own loop)."""

import time


def publish_until_answered(pub, msg, answers, timeout=10.0, period=0.05, what="an answer"):
    """Publish ``msg`` on ``pub`` every ``period`` [s] until the list ``answers`` (filled by a
    subscriber's callback) grows; returns its newest element. AssertionError naming ``what`` after
    ``timeout`` [s]."""
    n = len(answers)
    deadline = time.monotonic() + timeout
    while len(answers) == n:
        assert time.monotonic() < deadline, f"no {what} in {timeout:.0f} s"
        pub.publish(msg)
        time.sleep(period)
    return answers[-1]
