"""pointcloud_to_laserscan.

Kinect depth (image or PointCloud2) to a LaserScan (/kinect_scan) between min_height and
max_height.
"""
