"""user_tracker_ni.

Person detection and tracking from the Kinect (seed 4.1.2, 3.9): /tracked_users, a tf
frame per user, Start/Stop services, persistent ids from colour histograms.
"""
