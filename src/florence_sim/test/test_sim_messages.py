"""The node's message builders (no ROS master needed): fields as the real drivers fill them."""

import math

import numpy as np
import pytest
from florence_sim.messages import Messages
from florence_sim.sim import SimConfig, Simulator

from florence_common.maps import map_file
from florence_common_ros.convert import yaw_of

pytestmark = pytest.mark.unit

APARTMENT = map_file("apartment", "apartment.world.yaml")


@pytest.fixture(scope="module")
def sim():
    return Simulator.from_files(APARTMENT, config=SimConfig(), start=(1.2, 3.0, 0.3))


@pytest.fixture(scope="module")
def stamp():
    import rospy

    return rospy.Time.from_sec(12.5)


def test_scan_message_is_honest(sim, stamp):
    msg = Messages(sim).scan(stamp, sim.scan())
    assert msg.header.frame_id == "base_laser_link" and msg.header.stamp == stamp
    assert msg.angle_min == pytest.approx(-math.pi / 2) and msg.angle_max == pytest.approx(math.pi / 2)
    assert len(msg.ranges) == round((msg.angle_max - msg.angle_min) / msg.angle_increment) + 1
    assert msg.angle_increment == pytest.approx(2 * math.pi / 1024)
    assert (msg.range_min, msg.range_max, msg.scan_time) == pytest.approx((0.02, 5.6, 0.1))
    assert msg.time_increment == pytest.approx(0.1 / 1024)
    ranges = np.array(msg.ranges)
    assert np.all(np.isposinf(ranges) | ((ranges >= 0.02) & (ranges <= 5.6)))


def test_depth_image_and_cloud_round_trip(sim, stamp):
    m = Messages(sim)
    depth, _ = sim.render_camera("camera_depth_optical_frame", noise=False, color=False)
    img = m.depth_image(stamp, depth)
    back = np.frombuffer(img.data, dtype="<f4").reshape(img.height, img.width)
    np.testing.assert_array_equal(back, depth)

    depth_rgb, rgb = sim.render_camera("camera_rgb_optical_frame", noise=False)
    cloud = m.points(stamp, depth_rgb, rgb)
    data = np.frombuffer(cloud.data, dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4")])
    data = data.reshape(cloud.height, cloud.width)
    np.testing.assert_array_equal(data["z"], depth_rgb)  # optical z is the depth
    xyz = sim.camera.points(depth_rgb)
    np.testing.assert_allclose(data["x"], xyz[..., 0], rtol=1e-6)
    packed = data["rgb"]
    decoded = np.stack([(packed >> 16) & 255, (packed >> 8) & 255, packed & 255], axis=-1)
    np.testing.assert_array_equal(decoded, rgb)
    assert cloud.row_step == cloud.point_step * cloud.width and not cloud.is_dense

    info = m.camera_info(stamp, "camera_rgb_optical_frame")
    assert info.P[0] == info.K[0] and info.P[2] == info.K[2] and info.P[5] == info.K[4]
    assert (info.width, info.height) == (160, 120)


def test_sensor_state_packets_add_up_to_the_odometry(sim, stamp):
    m = Messages(sim)
    m.sensor_state(stamp)  # reset the packet counters
    total_d = total_a = 0.0
    start = (sim.base.ox, sim.base.oy, sim.base.oyaw)
    for i in range(200):
        sim.base.command(0.2, 0.5, sim.time)
        sim.step()
        if i % 10 == 9:
            state = m.sensor_state(stamp)
            total_d += state.distance
            total_a += state.angle
            assert state.requested_velocity == 200 and state.oi_mode == 3
    assert total_a == pytest.approx(sim.base.oyaw - start[2], abs=1e-9)
    assert 0.3 < total_d < 0.42  # 2 s at up to 0.2 m/s along an arc
    odom, tf = m.odometry(stamp)
    assert (odom.header.frame_id, odom.child_frame_id) == ("odom", "base_footprint")
    assert tf.transform.translation.x == odom.pose.pose.position.x


def test_fake_localization_composes_to_ground_truth(sim, stamp):
    m = Messages(sim)
    map_odom = m.map_to_odom(stamp).transform
    _, odom_base = m.odometry(stamp)
    yaw = yaw_of(map_odom.rotation)
    c, s = math.cos(yaw), math.sin(yaw)
    ox, oy = odom_base.transform.translation.x, odom_base.transform.translation.y
    x = map_odom.translation.x + c * ox - s * oy
    y = map_odom.translation.y + s * ox + c * oy
    assert (x, y) == pytest.approx((sim.base.x, sim.base.y), abs=1e-9)
