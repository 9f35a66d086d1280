"""openni_camera.

Kinect depth/RGB camera node (seed 2.2.1): /camera/depth/image, /camera/rgb/image_color,
camera_info and /camera/rgb/points.
"""
