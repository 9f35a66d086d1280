"""map_server and map_saver nodes (the ROS 1 command-line forms).

``rosrun map_server map_server map.yaml`` (or the deprecated ``map_server image.pgm 0.05``)

ROS Parameters: PARAMS below (rendered in the README).

Publishers (latched):
    map (nav_msgs/OccupancyGrid): the map.
    map_metadata (nav_msgs/MapMetaData): its size, resolution and origin.

Services:
    static_map (nav_msgs/GetMap): the same map.

``rosrun map_server map_saver [--occ 65] [--free 25] [-f mapname]``

Subscribers:
    map (nav_msgs/OccupancyGrid): the map to save (the first one received).

Services called:
    dynamic_map (nav_msgs/GetMap): used when it answers before a map arrives on ``map``.

Writes ``mapname.pgm`` (254 free, 0 occupied, 205 unknown) and ``mapname.yaml``, each
atomically, then exits.
"""

import argparse
import sys
import threading

import numpy as np

from florence_common.params import FRAME, Param, ParamTable
from florence_common.pose import quaternion_to_yaw, yaw_to_quaternion
from map_server.mapfile import GridMap, MapFileError, load_image_map, load_map, save_map

PARAMS = ParamTable(Param("frame_id", FRAME, "map", "frame of the published map's header"))


def grid_to_msg(grid, frame_id, stamp):
    """GridMap to (OccupancyGrid, MapMetaData)."""
    from nav_msgs.msg import MapMetaData, OccupancyGrid

    info = MapMetaData()
    info.map_load_time = stamp
    info.resolution = grid.resolution
    info.width, info.height = grid.width, grid.height
    info.origin.position.x, info.origin.position.y = grid.origin[0], grid.origin[1]
    o = info.origin.orientation
    o.x, o.y, o.z, o.w = yaw_to_quaternion(grid.origin[2])
    msg = OccupancyGrid()
    msg.header.frame_id = frame_id
    msg.header.stamp = stamp
    msg.info = info
    msg.data = grid.data.astype(np.int8).ravel().tolist()
    return msg, info


def msg_to_grid(msg):
    """OccupancyGrid to GridMap (origin yaw from the quaternion)."""
    o = msg.info.origin.orientation
    yaw = quaternion_to_yaw((o.x, o.y, o.z, o.w)) if (o.x, o.y, o.z, o.w) != (0, 0, 0, 0) else 0.0
    data = np.asarray(msg.data, dtype=np.int8).reshape(msg.info.height, msg.info.width)
    return GridMap(data=data, resolution=msg.info.resolution,
                   origin=(msg.info.origin.position.x, msg.info.origin.position.y, yaw))


def load_from_argv(argv):
    """``[map.yaml]`` or ``[image, resolution]`` to a GridMap (MapFileError on bad input)."""
    if len(argv) == 1:
        return load_map(argv[0])
    if len(argv) == 2:
        try:
            resolution = float(argv[1])
        except ValueError:
            raise MapFileError(f"field 'resolution' must be a number, got {argv[1]!r}") from None
        return load_image_map(argv[0], resolution)
    raise MapFileError("usage: map_server <map.yaml>  (or the deprecated: map_server <image> <resolution>)")


class MapServer:
    """Serves one map file on ``map``, ``map_metadata`` and ``static_map``."""

    def __init__(self, grid):
        import rospy
        from nav_msgs.msg import MapMetaData, OccupancyGrid
        from nav_msgs.srv import GetMap, GetMapResponse

        from florence_common_ros.node import read_params

        self.frame_id = read_params(PARAMS).frame_id
        self.map_msg, info = grid_to_msg(grid, self.frame_id, rospy.Time.now())
        self._response = GetMapResponse(map=self.map_msg)
        self.meta_pub = rospy.Publisher("map_metadata", MapMetaData, queue_size=1, latch=True)
        self.map_pub = rospy.Publisher("map", OccupancyGrid, queue_size=1, latch=True)
        self.meta_pub.publish(info)
        self.map_pub.publish(self.map_msg)
        self.service = rospy.Service("static_map", GetMap, lambda _req: self._response)
        rospy.loginfo("map_server: serving a %d x %d map at %.3f m/cell in frame '%s'",
                      grid.width, grid.height, grid.resolution, self.frame_id)


def main(argv=None):
    import rospy

    args = rospy.myargv(sys.argv if argv is None else argv)[1:]
    try:
        grid = load_from_argv(args)
    except MapFileError as exc:
        print(f"map_server: {exc}", file=sys.stderr)
        sys.exit(1)
    from florence_common_ros.node import run

    run(MapServer, "map_server", grid)


def saver_main(argv=None):
    import rospy
    from nav_msgs.msg import OccupancyGrid
    from nav_msgs.srv import GetMap

    parser = argparse.ArgumentParser(prog="map_saver", description="Save the map to mapname.pgm + mapname.yaml")
    parser.add_argument("-f", dest="mapname", default="map", help="map name (path without extension)")
    parser.add_argument("--occ", dest="occ", type=int, default=65, help="threshold_occupied [0..100]")
    parser.add_argument("--free", dest="free", type=int, default=25, help="threshold_free [0..100]")
    opts = parser.parse_args(rospy.myargv(sys.argv if argv is None else argv)[1:])
    if not 0 <= opts.free < opts.occ <= 100:
        parser.error(f"need 0 <= --free ({opts.free}) < --occ ({opts.occ}) <= 100")

    rospy.init_node("map_saver", anonymous=True)
    received = []
    done = threading.Event()

    def take(msg):
        if not done.is_set():
            received.append(msg)
            done.set()

    sub = rospy.Subscriber("map", OccupancyGrid, take, queue_size=1)
    rospy.loginfo("map_saver: waiting for the map")
    while not done.is_set() and not rospy.is_shutdown():
        try:
            rospy.wait_for_service("dynamic_map", timeout=0.5)
            take(rospy.ServiceProxy("dynamic_map", GetMap)().map)
        except rospy.ROSException:  # no dynamic_map service (yet): keep listening on map
            pass
        except rospy.ServiceException as exc:
            rospy.logwarn_throttle(5.0, f"map_saver: dynamic_map failed: {exc}")
            done.wait(0.5)
    sub.unregister()
    if not received:
        sys.exit(1)
    msg = received[0]
    grid = msg_to_grid(msg)
    pgm, yaml_path = save_map(grid, opts.mapname, opts.occ, opts.free)
    rospy.loginfo("map_saver: wrote %s and %s (%d x %d, %.3f m/cell)", pgm, yaml_path, grid.width, grid.height,
                  grid.resolution)
