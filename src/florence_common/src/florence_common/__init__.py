"""florence_common: ROS-free code every Florence package shares (no rospy, no messages).

Modules: angles (wrap, diff), pose (2-D pose maths, quaternions, matrices), params
(parameter tables), pty_device (emulated serial devices), processes (private rosmaster,
roslaunch in process groups, condition waits), maps (the maps folder).
"""
