"""turtlebot_calibration.

Gyro and odometry scale calibration against walls seen by the laser (user manual 7.2).
"""
