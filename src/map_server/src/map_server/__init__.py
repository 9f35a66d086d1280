"""map_server.

map_server and map_saver: ROS map YAML + PGM/PNG images to /map, /map_metadata and
static_map, and back to files.
"""
