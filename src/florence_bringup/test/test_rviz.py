"""The shipped rviz configuration (rviz/florence.rviz) rendered under Xvfb with software GL.

The whole navigation stack runs in florence_sim with the robot in the kitchen; rviz opens the
shipped configuration on a virtual screen, and its screenshot must show the apartment's map at
the configured scale (its free space where the map file has it) and the robot model where the
robot stands. The screenshot checks are ROS-free functions, tested first on synthetic pictures
(a blank screen, a map without the robot) so that they can fail.
"""

import math
from pathlib import Path

import numpy as np
import pytest
import rospkg
from scipy import ndimage

from florence_common.processes import ManagedProcess, wait_for
from florence_harness import workspace

ROBOT = (6.3, 2.5, 0.0)  # the kitchen's open floor
ROBOT_RADIUS = 0.17  # the Create's body [m]


# --- screenshot checks (ROS-free) ---------------------------------------------------------------
def free_bbox_world(grid):
    """(x0, x1, y0, y1) [m] of a map's free cells (map_server's GridMap; row 0 at the origin's y)."""
    rows, cols = np.nonzero(grid.data == 0)
    ox, oy = grid.origin[0], grid.origin[1]
    r = grid.resolution
    return ox + cols.min() * r, ox + (cols.max() + 1) * r, oy + rows.min() * r, oy + (rows.max() + 1) * r


def map_on_screen(rgb, world_bbox):
    """Where rviz drew the map's free space: a light neutral grey (free cells at the Map display's
    alpha over the dark background). Returns (pixels per metre, function world (x, y) -> pixel
    (column, row)) or raises AssertionError naming what is missing."""
    img = rgb.astype(int)
    neutral = (img.max(axis=2) - img.min(axis=2)) < 14
    light = (img.min(axis=2) > 150) & (img.max(axis=2) < 235)
    # the apartment's free space is one region (its rooms joined by doorways); rviz's panels are others
    labels, n = ndimage.label(neutral & light)
    assert n > 0, "no map on the screen: no free space"
    sizes = ndimage.sum_labels(np.ones_like(labels), labels, index=np.arange(1, n + 1))
    rows, cols = np.nonzero(labels == 1 + int(np.argmax(sizes)))
    assert rows.size > 20000, f"no map on the screen: {rows.size} pixels of free space"
    # the bounding box of the free space, robust to a few stray pixels (grid lines, text)
    c0, c1 = np.percentile(cols, [0.2, 99.8])
    r0, r1 = np.percentile(rows, [0.2, 99.8])
    x0, x1, y0, y1 = world_bbox
    sx, sy = (c1 - c0) / (x1 - x0), (r1 - r0) / (y1 - y0)
    assert abs(sx - sy) < 0.08 * max(sx, sy), f"the map is distorted: {sx:.1f} px/m across, {sy:.1f} px/m up"
    scale = 0.5 * (sx + sy)

    def to_pixel(x, y):
        return c0 + (x - x0) * scale, r0 + (y1 - y) * scale  # y up in the map, rows down on the screen

    return scale, to_pixel


def dark_fraction(rgb, centre, radius_px):
    """The fraction of pixels within ``radius_px`` of ``centre`` (column, row) that are dark (the
    robot model's black plates and grey body from above; free map cells are light)."""
    h, w, _ = rgb.shape
    rr, cc = np.mgrid[0:h, 0:w]
    disc = (cc - centre[0]) ** 2 + (rr - centre[1]) ** 2 <= radius_px**2
    assert disc.any(), f"the robot's place {centre} is off the screen"
    return float((rgb[disc].max(axis=1) < 110).mean())


def synthetic_screen(scale=60.0, robot=True):
    """A screen as rviz draws florence.rviz: dark background, a light map 8 x 10 m, maybe a robot."""
    rgb = np.full((800, 1280, 3), 48, np.uint8)
    c0, r0 = 500, 100
    rgb[r0:r0 + int(10 * scale), c0:c0 + int(8 * scale)] = 193
    if robot:
        col, row = c0 + 6.3 * scale, r0 + (10 - 2.5) * scale
        rr, cc = np.mgrid[0:800, 0:1280]
        rgb[(cc - col) ** 2 + (rr - row) ** 2 <= (0.17 * scale) ** 2] = 38
    return rgb


@pytest.mark.unit
def test_screenshot_checks_fail_without_a_map_or_a_robot():
    bbox = (0.0, 8.0, 0.0, 10.0)
    with pytest.raises(AssertionError, match="no map"):
        map_on_screen(np.full((800, 1280, 3), 48, np.uint8), bbox)
    scale, to_pixel = map_on_screen(synthetic_screen(), bbox)
    assert scale == pytest.approx(60.0, rel=0.02)
    where = to_pixel(6.3, 2.5)
    assert dark_fraction(synthetic_screen(), where, 0.8 * ROBOT_RADIUS * scale) > 0.9
    assert dark_fraction(synthetic_screen(robot=False), where, 0.8 * ROBOT_RADIUS * scale) == 0.0
    stretched = synthetic_screen()
    stretched[700:, 500:980] = 193  # the map drawn taller than wide
    with pytest.raises(AssertionError, match="distorted"):
        map_on_screen(stretched, bbox)


# --- rviz on the running system -----------------------------------------------------------------
@pytest.mark.scenario
@pytest.mark.slow
def test_florence_rviz_shows_the_map_and_the_robot(ros_master, launch, tf_buffer, tmp_path):
    from map_server.mapfile import load_map

    from florence_common.grid import Grid

    grid = load_map(workspace.root() / "maps" / "apartment" / "apartment.yaml")
    assert Grid(grid.data, grid.origin, grid.resolution).clearance_at([ROBOT[:2]])[0] > 0.4, \
        "the robot's place must be open floor for the check below"
    import rosgraph

    master = rosgraph.Master("/pytest")
    had_sim_time = master.hasParam("/use_sim_time")
    stack = launch("turtlebot_control", "turtlebot_2dnav_control.launch", "sim:=true", "real_time_factor:=1.0",
                   f"x:={ROBOT[0]}", f"y:={ROBOT[1]}", f"yaw:={ROBOT[2]}")
    try:
        _screenshot_checks(ros_master, stack, tf_buffer, tmp_path, grid)
    finally:
        # florence_sim's launch set /use_sim_time on this session's master: later tests' nodes would wait
        # for a /clock nobody publishes
        stack.stop()
        if not had_sim_time and master.hasParam("/use_sim_time"):
            master.deleteParam("/use_sim_time")
        tf_buffer.clear()  # its simulated stamps must not be "the latest" for a later test's lookups


def _screenshot_checks(ros_master, stack, tf_buffer, tmp_path, grid):
    from florence_harness.screen import VirtualScreen


    def localised():
        assert stack.running(), f"the stack exited:\n{stack.output()[-3000:]}"
        import rospy

        try:
            t = tf_buffer.lookup_transform("map", "base_footprint", rospy.Time(0)).transform.translation
        except Exception:  # noqa: BLE001 - tf's exceptions: not there yet
            return False
        return math.hypot(t.x - ROBOT[0], t.y - ROBOT[1]) < 0.3

    wait_for(localised, 240.0, what="amcl's map -> base_footprint at the robot's place")
    config = Path(rospkg.RosPack().get_path("florence_bringup")) / "rviz" / "florence.rviz"
    with VirtualScreen(1280, 800) as screen:
        # software GL; rviz keeps its settings under HOME: a temporary one, not the user's
        env = ros_master.env(DISPLAY=screen.display, LIBGL_ALWAYS_SOFTWARE="1", QT_X11_NO_MITSHM="1",
                             HOME=str(tmp_path))
        rviz = ManagedProcess(["rviz", "-d", str(config)], env=env, name="rviz")
        try:
            bbox = free_bbox_world(grid)
            seen = {}

            def drawn():
                assert rviz.running(), f"rviz exited:\n{rviz.output()[-3000:]}"
                rgb = screen.screenshot()
                seen["rgb"] = rgb
                try:
                    scale, to_pixel = map_on_screen(rgb, bbox)
                except AssertionError as exc:
                    seen["why"] = str(exc)
                    return False
                seen["fraction"] = dark_fraction(rgb, to_pixel(*ROBOT[:2]), 0.8 * ROBOT_RADIUS * scale)
                seen["scale"] = scale
                return seen["fraction"] > 0.5

            try:
                wait_for(drawn, 180.0, interval=2.0, what="rviz drawing the map and the robot")
            finally:
                if "rgb" in seen:
                    from PIL import Image

                    Image.fromarray(seen["rgb"]).save(tmp_path / "florence_rviz.png")
                    print(f"screenshot: {tmp_path / 'florence_rviz.png'}; {seen}")
            assert seen["scale"] == pytest.approx(60.0, rel=0.1), "florence.rviz's top-down view is 60 px/m"
        finally:
            rviz.stop()
