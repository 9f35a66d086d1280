"""follow_me.

FollowMe enabler (seed 4.1): actionlib server follow_me that keeps the robot at a
distance behind a tracked person.
"""
