"""laser_combinator.

Florence laser combinator (seed 3.7): merges the inverted Hokuyo scan and the Kinect's
fake scan into /scan_combined on the Hokuyo grid.
"""
