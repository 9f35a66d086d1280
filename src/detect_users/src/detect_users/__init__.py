"""detect_users.

Detect users (seed 3.9): stop-and-go 45 degree search for a user with the Kinect
tracker; publishes /detected_user.
"""
