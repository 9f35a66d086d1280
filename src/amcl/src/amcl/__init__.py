"""amcl.

Adaptive Monte Carlo localization with the ROS amcl interface: scan + map to tf
map->odom, amcl_pose and particlecloud.
"""
