"""florence_bringup.

Top-level launch files of the Florence system (florence_bringup.launch), the rviz
configuration and the demo runner.
"""
