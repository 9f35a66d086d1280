"""gmapping.

slam_gmapping: grid SLAM for building a map; the inverted laser is handled through tf.
"""
