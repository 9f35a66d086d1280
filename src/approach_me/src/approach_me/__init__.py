"""approach_me.

ApproachMe enabler (seed 4.3): actionlib server approach_me that brings the robot to a
pose relative to a person, tracking them with Kinect and laser.
"""
