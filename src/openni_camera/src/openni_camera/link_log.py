"""How the Kinect nodes tell what their libfreenect link reports (rospy logging).

A loss is logged once per reason (an absent Kinect is not news every second): as an error while
the device never streamed, as a warning after it did; the same reason again goes to debug.
Warnings (a damaged dump) are logged; what the worker prints goes to debug. The last few of both
are kept for /diagnostics.
"""

from collections import deque

import rospy


class LinkLog:
    def __init__(self, name, retry_interval):
        self.name, self.retry_interval = name, retry_interval
        self.said = None
        self.messages = deque(maxlen=5)

    def __call__(self, link, kind, text, what="streaming"):
        if kind == "connected":
            rospy.loginfo("%s: %s the %s", self.name, what, text)
        elif kind == "lost":
            if text != self.said:
                (rospy.logwarn if link.connects else rospy.logerr)(
                    "%s: %s; trying again every %.1f s or more", self.name, text, self.retry_interval)
                self.said = text
            else:
                rospy.logdebug("%s: %s", self.name, text)
        elif kind == "warning":
            rospy.logwarn("%s: %s", self.name, text)
            self.messages.append(text)
        else:
            rospy.logdebug("%s: worker: %s", self.name, text)
            self.messages.append(text)
