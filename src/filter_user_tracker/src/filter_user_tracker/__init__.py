"""filter_user_tracker.

Filter user tracker (seed 4.2): drops stale tracker entries (users nearer than the
Kinect's minimum range).
"""
