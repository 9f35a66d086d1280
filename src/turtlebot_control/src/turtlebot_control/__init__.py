"""turtlebot_control.

Florence TurtleBot description (URDF/xacro: Create base, 10/25/50 cm standoffs,
inverted Hokuyo, Kinect), the seed's launch files and navigation configuration.
"""
