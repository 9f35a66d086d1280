"""florence_harness: the pytest fixtures of the workspace's ROS tests and facts about the workspace.

Tests only; runtime code uses florence_common.processes.
"""
