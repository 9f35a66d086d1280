"""turtlebot_teleop: turtlebot_teleop_key: keyboard teleoperation publishing cmd_vel."""
