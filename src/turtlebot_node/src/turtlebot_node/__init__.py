"""turtlebot_node.

iRobot Create Open Interface driver over pyserial (seed 2.3): cmd_vel, odom, imu/data,
~sensor_state, /diagnostics.
"""
