"""move_base.

move_base with the ROS 1 interface: costmaps, navfn-style global planner, trajectory
rollout / DWA local planner and recovery behaviours.
"""
