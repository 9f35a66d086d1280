"""laser_filter.

Florence laser filter (seed 3.5): drops returns of the robot's own structure and turns
out-of-range readings into range_max - 1e-4 so the costmap clears.
"""
