"""The camera driver's ROS-free core: depth conversion, camera_info, registration, point packing."""

import math

import numpy as np
import pytest
from openni_camera.registration import POINT_FIELDS, POINT_STEP, Registration

from openni_camera import camera_info as ci
from openni_camera import kinect

pytestmark = pytest.mark.unit


# --- 11-bit depth ------------------------------------------------------------------------------------------------
def test_table_no_return_and_out_of_model_are_nan():
    table = kinect.raw_to_metres_table()
    assert table.dtype == np.float32 and table.shape == (2048,)
    assert math.isnan(table[kinect.RAW_NO_VALUE])
    assert np.isnan(table[1090:]).all()  # at and beyond doff the model has no depth
    assert table[0] == pytest.approx(8 * 0.075 * kinect.DEPTH_FOCAL / 1090, rel=1e-6)
    finite = table[:1090]
    assert np.isfinite(finite).all() and (np.diff(finite) > 0).all()  # more disparity code, farther


def test_model_against_published_values():
    """z = 8 b f / (doff - kd) with b 7.5 cm, f 580 px, doff 1090 (Konolige and Mihelich), and within a few per
    cent of Burrus's empirical fit of one Kinect over the range the robot uses."""
    raw = np.arange(2048)
    z = kinect.raw_to_metres_table(focal=580.0)
    assert z[700] == pytest.approx(348.0 / 390.0, rel=1e-6)
    burrus = 1.0 / (3.3309495161 - 0.0030711016 * raw)
    useful = (z > 0.6) & (z < 4.0)
    assert useful.sum() > 300
    assert np.max(np.abs(z[useful] / burrus[useful] - 1.0)) < 0.07


@pytest.mark.parametrize("focal", [kinect.DEPTH_FOCAL, 577.35])
def test_round_trip_within_half_a_step(focal):
    depth = np.linspace(0.5, 4.5, 2001)
    raw = kinect.metres_to_raw(depth, focal=focal)
    back = kinect.raw_to_metres_table(focal=focal)[raw]
    step = kinect.quantisation_step(depth, focal=focal)
    assert (np.abs(back - depth) <= 0.5 * step * 1.01 + 1e-6).all()
    # the step is the model's: 11.5 mm at 2 m, 46 mm at 4 m (f 575.8 px)
    assert kinect.quantisation_step(2.0) == pytest.approx(4.0 / (8 * 0.075 * kinect.DEPTH_FOCAL))
    assert 0.011 < kinect.quantisation_step(2.0) < 0.012 and 0.045 < kinect.quantisation_step(4.0) < 0.047


def test_no_return_encodes_as_2047():
    raw = kinect.metres_to_raw([math.nan, math.inf, -1.0, 0.0, 0.2, 2.0])
    assert raw.dtype == np.uint16
    assert list(raw[:5]) == [2047] * 5  # 0.2 m is nearer than the 11 bits reach (8 b f / doff = 0.32 m)
    assert raw[5] < 2047


# --- accelerometer and tilt ---------------------------------------------------------------------------------------
def test_accelerometer_axes():
    assert kinect.camera_link_to_accel((0.0, 0.0, kinect.GRAVITY)) == (0, 819, 0)  # level: +1 g on the device's y
    a = kinect.accel_to_camera_link((0, 819, 0))
    assert a == pytest.approx((0.0, 0.0, kinect.GRAVITY))
    up = math.radians(10.0)  # nose up: gravity's reaction leans toward +x of camera_link
    counts = kinect.camera_link_to_accel((9.81 * math.sin(up), 0.0, 9.81 * math.cos(up)))
    assert counts[2] > 0 and counts[0] == 0
    assert kinect.accel_to_camera_link(counts) == pytest.approx((9.81 * math.sin(up), 0.0, 9.81 * math.cos(up)),
                                                                abs=kinect.GRAVITY / 819)


def test_tilt_readings():
    assert kinect.tilt_degrees(16) == 8.0 and kinect.tilt_degrees(-62) == -31.0
    assert math.isnan(kinect.tilt_degrees(-128))  # the motor's "moving" reading
    assert kinect.tilt_raw(8.2) == 16 and kinect.tilt_raw(-31) == -62 and kinect.tilt_raw(200) == 127


# --- camera_info ------------------------------------------------------------------------------------------------
def test_default_intrinsics():
    rgb, depth = ci.default_rgb(), ci.default_depth()
    assert rgb.K == [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0]
    assert rgb.P == [525.0, 0.0, 319.5, 0.0, 0.0, 525.0, 239.5, 0.0, 0.0, 0.0, 1.0, 0.0]
    assert depth.K[0] == pytest.approx(575.8157) and (depth.cx, depth.cy) == (314.5, 235.5)
    assert rgb.D == [0.0] * 5 and rgb.distortion_model == "plumb_bob"
    assert ci.default_rgb(320, 240).fx == 262.5


def test_yaml_round_trip_and_load(tmp_path):
    info = ci.pinhole(640, 480, 577.35, 319.5, 239.5, "florence_sim_depth")
    path = tmp_path / "depth.yaml"
    path.write_text(ci.to_yaml(info))
    loaded, problem = ci.load(f"file://{path}", 640, 480, ci.default_depth())
    assert problem is None
    assert loaded.K == info.K and loaded.P == info.P and loaded.camera_name == "florence_sim_depth"
    # ${NAME} and package URLs
    named = tmp_path / "depth_cam.yaml"
    named.write_text(ci.to_yaml(info))
    assert ci.load(f"file://{tmp_path}/${{NAME}}.yaml", 640, 480, None, camera_name="depth_cam")[1] is None
    resolved = ci.resolve_url("package://openni_camera/x.yaml", package_path=lambda p: f"/opt/{p}")
    assert resolved == "/opt/openni_camera/x.yaml"
    assert ci.resolve_url("") is None


@pytest.mark.parametrize("text, words", [
    ("[1, 2", "not YAML"),
    ("- a list", "expected a mapping"),
    ("image_width: 640\n", "image_height"),
    ("image_width: 640\nimage_height: 480\ncamera_matrix: {rows: 3, cols: 3, data: [1, 2]}\n", "9 numbers"),
    ("image_width: 640\nimage_height: 480\ncamera_matrix: {rows: 3, cols: 3, data: [.nan, 0, 1, 0, 1, 1, 0, 0, 1]}\n",
     "finite"),
    ("image_width: 640\nimage_height: 480\ncamera_matrix: {rows: 3, cols: 3, data: [0, 0, 1, 0, 1, 1, 0, 0, 1]}\n",
     "positive"),
])
def test_bad_calibration_files_fall_back_with_the_reason(tmp_path, text, words):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    default = ci.default_rgb()
    info, problem = ci.load(f"file://{path}", 640, 480, default)
    assert info is default and words in problem and str(path) in problem


def test_calibration_url_problems():
    default = ci.default_rgb()
    for url, words in (("file:///nonexistent/x.yaml", "cannot read"), ("http://x/y.yaml", "unsupported"),
                       ("file://relative.yaml", "absolute"), ("package://onlyname", "package://<package>/<path>")):
        info, problem = ci.load(url, 640, 480, default)
        assert info is default and words in problem, (url, problem)


def test_calibration_of_another_size_is_refused(tmp_path):
    path = tmp_path / "small.yaml"
    path.write_text(ci.to_yaml(ci.default_rgb(320, 240)))
    info, problem = ci.load(f"file://{path}", 640, 480, ci.default_rgb())
    assert "320x240" in problem and info.width == 640


# --- registration ---------------------------------------------------------------------------------------------
def _raw(depth, info):
    return kinect.metres_to_raw(depth, focal=info.fx)


def test_plane_registers_at_its_depth():
    depth, rgb = ci.default_depth(), ci.default_rgb()
    reg = Registration(depth, rgb)
    raw = _raw(np.full((480, 640), 2.0), depth)
    z = reg.register(raw)
    step = kinect.quantisation_step(2.0)
    assert np.nanmax(np.abs(z - 2.0)) <= 0.5 * step + 1e-6
    # the colour camera sees wider (f 525 < 575.8): its border has no depth, its middle all of it
    assert np.isfinite(z[40:440, 60:580]).all()
    assert np.isnan(z[:, :10]).all() and np.isnan(z[:, -10:]).all()


def test_a_point_lands_on_the_colour_pixel_it_projects_to():
    depth, rgb = ci.default_depth(), ci.default_rgb()
    reg = Registration(depth, rgb)
    raw = np.full((480, 640), kinect.RAW_NO_VALUE, dtype=np.uint16)
    u, v = 400, 300
    raw[v, u] = 800
    z = reg.table[800]
    x, y = (u - depth.cx) / depth.fx * z, (v - depth.cy) / depth.fy * z
    expected = (round(rgb.fy * y / z + rgb.cy), round(rgb.fx * (x - 0.025) / z + rgb.cx))
    out = reg.register(raw)
    assert list(zip(*np.nonzero(np.isfinite(out)), strict=True)) == [expected]
    assert out[expected] == pytest.approx(z)


def test_the_nearer_point_wins_a_colour_pixel():
    """z-buffer: a near and a far depth pixel that land on one colour pixel leave the near depth."""
    depth, rgb = ci.default_depth(), ci.default_rgb()
    reg = Registration(depth, rgb)
    near_raw, far_raw, v = 600, 1000, 240
    table = reg.table

    def target(u, raw):
        z = table[raw]
        return round(rgb.fx * (((u - depth.cx) / depth.fx * z) - 0.025) / z + rgb.cx)

    u_near = 300
    u_far = next(u for u in range(640) if target(u, far_raw) == target(u_near, near_raw))
    assert u_far != u_near  # the two are different depth pixels
    for first, second in ((u_near, u_far), (u_far, u_near)):  # whatever the scan order
        raw = np.full((480, 640), kinect.RAW_NO_VALUE, dtype=np.uint16)
        raw[v, first] = near_raw if first == u_near else far_raw
        raw[v, second] = near_raw if second == u_near else far_raw
        out = reg.register(raw)
        row = round(rgb.fy * (v - depth.cy) / depth.fy + rgb.cy)  # the same for every depth on this row
        assert np.isfinite(out).sum() == 1
        assert out[row, target(u_near, near_raw)] == pytest.approx(table[near_raw])


def test_one_pixel_gaps_of_a_surface_are_filled():
    """Equal focal lengths (florence_sim's cameras): the depth-dependent shift rounds some colour pixels empty on a
    slanted wall; those between two neighbours of the surface are filled, real edges are not."""
    sim = ci.pinhole(640, 480, 577.35, 319.5, 239.5)
    reg = Registration(sim, sim)
    depth = np.tile(np.linspace(1.0, 3.0, 640), (480, 1))
    depth[:, 300:340] = 1.0  # a post in front: its edges stay edges
    out = reg.register(_raw(depth, sim))
    inner = out[:, 20:620]
    holes = np.isnan(inner)
    # every empty pixel left is beside the post's jump (the shadow the colour camera sees behind it)
    assert holes.sum() < 480 * 12
    assert not holes[:, :200].any() and not holes[:, 420:].any()


def test_cloud_packing():
    rgb_info = ci.default_rgb()
    reg = Registration(ci.default_depth(), rgb_info)
    depth = np.full((480, 640), np.nan, dtype=np.float32)
    depth[100, 200] = 2.0
    colour = np.zeros((480, 640, 3), dtype=np.uint8)
    colour[100, 200] = (200, 100, 50)
    cloud = reg.cloud(depth, colour)
    assert [name for name, _ in POINT_FIELDS] == ["x", "y", "z", "rgb"] and POINT_STEP == 16
    points = np.frombuffer(cloud.tobytes(), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4")])
    points = points.reshape(480, 640)
    p = points[100, 200]
    assert p["x"] == pytest.approx((200 - 319.5) / 525 * 2.0) and p["y"] == pytest.approx((100 - 239.5) / 525 * 2.0)
    assert p["z"] == 2.0
    assert p["rgb"] == (200 << 16) | (100 << 8) | 50  # PCL's packing, as florence_sim's cloud
    others = np.ones((480, 640), dtype=bool)
    others[100, 200] = False
    assert np.isnan(points["z"][others]).all() and np.isnan(points["x"][others]).all()
    with pytest.raises(ValueError, match="does not match"):
        reg.cloud(depth, colour[:240])


def test_messages_serialise_as_the_generated_code():
    """PointCloud2Out and ImageOut write the same bytes as sensor_msgs' own serialize (one copy fewer)."""
    import io

    import rospy
    from openni_camera.messages import cloud_msg, image_msg
    from sensor_msgs.msg import Image, PointCloud2

    reg = Registration(ci.default_depth(), ci.default_rgb())
    depth = np.random.default_rng(1).uniform(0.5, 4.0, (480, 640)).astype(np.float32)
    colour = np.random.default_rng(2).integers(0, 255, (480, 640, 3), dtype=np.uint8)
    stamp = rospy.Time(12, 345)
    for fast, plain_class in ((cloud_msg(reg.cloud(depth, colour), stamp, "camera_rgb_optical_frame"), PointCloud2),
                              (image_msg(depth, "32FC1", stamp, "f"), Image), (image_msg(colour, "rgb8", stamp, "f"),
                                                                             Image)):
        plain = plain_class()
        for slot in plain_class.__slots__:
            setattr(plain, slot, getattr(fast, slot))
        plain.data = bytes(fast.data)
        a, b = io.BytesIO(), io.BytesIO()
        fast.serialize(a)
        plain.serialize(b)
        assert a.getvalue() == b.getvalue()
        assert plain_class().deserialize(a.getvalue()).data == plain.data
        assert fast._type == plain._type and fast._md5sum == plain._md5sum


def test_the_shift_path_equals_the_general_transform():
    """The fast path (colour camera only translated sideways) gives what the general transform gives; a rotated
    colour camera takes the general one and still puts a point where it projects."""
    from openni_camera.registration import _register

    depth, rgb = ci.default_depth(), ci.default_rgb()
    reg = Registration(depth, rgb)
    assert reg.shift_only
    rng = np.random.default_rng(3)
    scene = np.where(rng.random((480, 640)) < 0.1, np.nan, rng.uniform(0.6, 4.0, (480, 640)))
    raw = _raw(scene, depth)
    general = np.empty((480, 640), np.float32)
    _register(raw, reg.table, reg.depth_ray_x, reg.depth_ray_y, reg.rot, reg.t, rgb.fx, rgb.fy, rgb.cx, rgb.cy,
              general)
    fast = reg.register(raw)
    same = (fast == general) | (np.isnan(fast) & np.isnan(general))
    assert same.mean() > 0.9999  # rounding ties at most

    yaw = math.radians(2.0)
    rotation = [[math.cos(yaw), 0, math.sin(yaw)], [0, 1, 0], [-math.sin(yaw), 0, math.cos(yaw)]]
    turned = Registration(depth, rgb, rotation=rotation)
    assert not turned.shift_only
    one = np.full((480, 640), kinect.RAW_NO_VALUE, dtype=np.uint16)
    one[200, 320] = 700
    z = turned.table[700]
    p = np.array([(320 - depth.cx) / depth.fx * z, (200 - depth.cy) / depth.fy * z, z])
    q = np.array(rotation).T @ (p - np.array(kinect.RGB_IN_DEPTH))
    out = turned.register(one)
    (v, u), = np.argwhere(np.isfinite(out))
    assert (v, u) == (round(rgb.fy * q[1] / q[2] + rgb.cy), round(rgb.fx * q[0] / q[2] + rgb.cx))
    assert out[v, u] == pytest.approx(q[2])


def admitted(gate, times):
    return [t for t in times if gate.admit(t)]


@pytest.mark.unit
@pytest.mark.parametrize(("source", "rate", "expected"), [(30.0, 30.0, 30), (29.47, 30.0, 29.47), (36.0, 30.0, 30),
                                                         (30.0, 20.0, 20), (60.0, 30.0, 30), (30.0, 7.5, 7.5)])
def test_rate_gate_passes_a_source_up_to_its_rate_and_thins_a_faster_one_to_it(source, rate, expected):
    rng = np.random.default_rng(1)
    period = 1.0 / source
    times = np.arange(int(20 * source)) * period + rng.uniform(-0.2, 0.2, int(20 * source)) * min(period, 1 / rate)
    passed = admitted(kinect.RateGate(rate), times)
    assert abs(len(passed) / 20.0 - expected) <= 0.2, (len(passed) / 20.0, expected)
    passed = np.asarray(passed)  # and evenly: no second holds more than the rate and one frame
    assert max(np.searchsorted(passed, t + 1.0) - i for i, t in enumerate(passed)) <= rate + 1


@pytest.mark.unit
def test_rate_gate_gives_no_burst_after_a_pause():
    gate = kinect.RateGate(10.0)
    assert len(admitted(gate, np.arange(0.0, 1.0, 0.1))) == 10
    # 2 s without frames, then 100 Hz for 1 s: its first frame, one half a period later, then 10 Hz
    resumed = admitted(gate, 3.0 + np.arange(100) * 0.01)
    assert len(resumed) <= 11 and resumed[1] - resumed[0] >= 0.05 - 1e-9


@pytest.mark.unit
def test_rate_gate_refuses_a_rate_that_is_not_positive():
    for rate in (0.0, -1.0, math.nan):
        with pytest.raises(ValueError):
            kinect.RateGate(rate)
