"""Laser models on a synthetic map, ray casting, beam selection, beam geometry from the laser's pose."""

import math

import numpy as np
import pytest
from amcl.sensor import (
    LaserParams,
    OccupancyMap,
    beam_weights,
    beams_in_base,
    likelihood_field_prob_weights,
    likelihood_field_weights,
    sensor_weights,
    subsample_beams,
)

pytestmark = pytest.mark.unit

RES = 0.05


def room_map():
    """A 4 m x 3 m room, origin (-1, -1), walls one cell thick, a box at x 2.0..2.5, y 0.5..1.0,
    and an unknown patch at x -0.5..-0.25, y 1.25..1.5."""
    data = np.zeros((60, 80), dtype=np.int8)
    data[0, :] = data[-1, :] = 100
    data[:, 0] = data[:, -1] = 100
    data[30:40, 60:70] = 100
    data[45:50, 10:15] = -1
    return OccupancyMap(data, RES, (-1.0, -1.0), max_occ_dist=2.0)


def scan_from(omap, pose, laser_xy, bearings, range_max=5.6):
    c, s = math.cos(pose[2]), math.sin(pose[2])
    lx = pose[0] + c * laser_xy[0] - s * laser_xy[1]
    ly = pose[1] + s * laser_xy[0] + c * laser_xy[1]
    return omap.calc_range(np.full(bearings.shape, lx), np.full(bearings.shape, ly), pose[2] + bearings, range_max)


def test_distance_field_and_cells():
    omap = room_map()
    assert omap.distance_at(np.array([-0.975]), np.array([0.0]))[0] == pytest.approx(0.0)  # on the left wall
    assert omap.distance_at(np.array([0.0]), np.array([0.0]))[0] == pytest.approx(0.95, abs=0.051)
    assert omap.distance_at(np.array([50.0]), np.array([0.0]))[0] == 2.0  # outside: the cap
    assert omap.is_free(np.array([0.0]), np.array([0.0]))[0]
    assert not omap.is_free(np.array([-0.99]), np.array([0.0]))[0]


@pytest.mark.parametrize(("angle", "expected"), [
    (0.0, 2.0),             # +x from (0, 0.75): the box's face at x = 2.0
    (math.pi, 0.95),        # -x: left wall cell starts at x = -0.95 (cell 0 covers -1.0..-0.95)
    (math.pi / 2, 1.2),     # +y: top wall row 59 starts at y = 1.95
    (-math.pi / 2, 1.7),    # -y: bottom wall row 0 ends at y = -0.95
])
def test_calc_range_hits_walls(angle, expected):
    omap = room_map()
    r = omap.calc_range(np.array([0.0]), np.array([0.75]), np.array([angle]), 5.6)[0]
    assert r == pytest.approx(expected, abs=RES)


def test_calc_range_stops_at_unknown():
    omap = room_map()  # unknown patch from x = -0.5 at y 1.25..1.5
    r = omap.calc_range(np.array([0.5]), np.array([1.3]), np.array([math.pi]), 5.6)[0]
    assert r == pytest.approx(0.75, abs=RES)


def test_calc_range_max_when_leaving_map():
    data = np.zeros((10, 10), dtype=np.int8)
    omap = OccupancyMap(data, 0.1, (0.0, 0.0))
    assert omap.calc_range(np.array([0.5]), np.array([0.5]), np.array([0.0]), 3.0)[0] == 3.0


@pytest.mark.parametrize("model", ["likelihood_field", "beam"])
def test_true_pose_weighs_most(model):
    omap = room_map()
    laser_xy = np.array([0.1, 0.0])
    bearings = np.linspace(-2.0, 2.0, 60)
    truth = np.array([0.5, 0.2, 0.3])
    ranges = scan_from(omap, truth, laser_xy, bearings)
    offsets = np.array([[0, 0, 0], [0.2, 0, 0], [0, -0.2, 0], [0, 0, 0.15]])
    candidates = np.vstack([truth + offsets, [[1.5, -0.5, -2.0]]])
    fn = likelihood_field_weights if model == "likelihood_field" else beam_weights
    w = fn(candidates, omap, laser_xy, bearings, ranges, 5.6, LaserParams())
    assert np.argmax(w) == 0
    assert (w >= 1.0).all()


def test_likelihood_field_value_by_hand():
    """One beam ending exactly on a wall: pz = z_hit + z_rand / range_max; p = 1 + pz^3."""
    data = np.zeros((20, 20), dtype=np.int8)
    data[:, 15] = 100  # wall at x 1.5..1.6
    omap = OccupancyMap(data, 0.1, (0.0, 0.0))
    params = LaserParams(z_hit=0.9, z_rand=0.1, sigma_hit=0.2)
    w = likelihood_field_weights(np.array([[0.55, 1.05, 0.0]]), omap, np.zeros(2), np.array([0.0]),
                                 np.array([1.0]), 4.0, params)
    pz = 0.9 + 0.1 / 4.0
    assert w[0] == pytest.approx(1.0 + pz**3)
    # 0.3 m short of the wall: distance 0.3 (cell centre distance 3 cells)
    w = likelihood_field_weights(np.array([[0.55, 1.05, 0.0]]), omap, np.zeros(2), np.array([0.0]),
                                 np.array([0.7]), 4.0, params)
    pz = 0.9 * math.exp(-(0.3**2) / (2 * 0.2**2)) + 0.1 / 4.0
    assert w[0] == pytest.approx(1.0 + pz**3)


def test_nan_and_max_range_beams_are_left_out():
    omap = room_map()
    particles = np.array([[0.0, 0.0, 0.0], [0.5, 0.5, 1.0]])
    w = likelihood_field_weights(particles, omap, np.zeros(2), np.array([0.0, 1.0, 2.0]),
                                 np.array([np.nan, 5.6, np.inf]), 5.6, LaserParams())
    assert w.tolist() == [1.0, 1.0]
    w = beam_weights(particles, omap, np.zeros(2), np.array([0.0]), np.array([np.nan]), 5.6, LaserParams())
    assert w.tolist() == [1.0, 1.0]


@pytest.mark.parametrize(("count", "max_beams", "expected_len", "step"), [
    (683, 60, 63, 11),   # the URG's 683 beams: (682 // 59) = 11, 0..682 -> 63 beams like ROS
    (683, 30, 30, 23),   # 682 // 29 = 23: 0..667
    (10, 60, 10, 1),
    (100, 2, 2, 99),
])
def test_subsample_beams(count, max_beams, expected_len, step):
    idx = subsample_beams(count, max_beams)
    assert len(idx) == expected_len and idx[0] == 0 and (np.diff(idx) == step).all() and idx[-1] < count


def test_subsample_rejects_one_beam():
    with pytest.raises(ValueError, match="laser_max_beams"):
        subsample_beams(100, 1)


def test_upside_down_laser_mirrors_bearings():
    """base_laser_link: xyz 0.06 0 -0.02, rpy pi 0 0: a beam at +a in the laser frame points to -a on the base."""
    q_roll_pi = (1.0, 0.0, 0.0, 0.0)
    angles = np.array([-1.0, 0.0, 0.5, 2.0])
    xy, bearings = beams_in_base((0.06, 0.0, -0.02), q_roll_pi, angles)
    assert xy.tolist() == [0.06, 0.0]
    np.testing.assert_allclose(bearings, -angles, atol=1e-12)
    _, upright = beams_in_base((0, 0, 0), (0, 0, 0, 1), angles)
    np.testing.assert_allclose(upright, angles, atol=1e-12)
    yawed = beams_in_base((0, 0, 0), (0, 0, math.sin(0.25), math.cos(0.25)), angles)[1]
    np.testing.assert_allclose(yawed, angles + 0.5, atol=1e-12)


def test_interpolated_distance_measures_to_the_surface():
    """A wall occupying cells x >= 1.5 (cells 15.. of 0.1 m): the surface runs through the outermost
    occupied cells' centres, x = 1.55; inside the wall the distance is the depth below it."""
    data = np.zeros((20, 20), dtype=np.int8)
    data[:, 15:] = 100
    omap = OccupancyMap(data, 0.1, (0.0, 0.0))
    xs = np.array([1.55, 1.5, 1.45, 1.3, 1.12, 0.8])
    d = omap.distance_interpolated(xs, np.full(xs.shape, 1.0))
    np.testing.assert_allclose(d, 1.55 - xs, atol=1e-6)
    # Regression: endpoints behind the surface scored like hits (0.05 everywhere inside the wall).
    inside = np.array([1.6, 1.75, 1.85])
    np.testing.assert_allclose(omap.distance_interpolated(inside, np.full(3, 1.0)), inside - 1.55, atol=1e-6)
    # ROS's lookup: centre-to-centre distance of the cells, quantised; 0 anywhere inside the wall.
    assert omap.distance_at(np.array([1.45]), np.array([1.0]))[0] == pytest.approx(0.1)
    assert omap.distance_at(np.array([1.85]), np.array([1.0]))[0] == 0.0
    assert omap.distance_interpolated(np.array([100.0]), np.array([1.0]))[0] == 2.0  # off the map: the cap


def rasterise_boxes(boxes, res, size):
    """Occupancy grid (origin (0, 0)) as florence_sim's generate_map makes it: a cell is occupied when its
    centre lies inside a box (x0, y0, x1, y1) or within half a cell of it."""
    ny, nx = round(size[1] / res), round(size[0] / res)
    cx, cy = np.meshgrid((np.arange(nx) + 0.5) * res, (np.arange(ny) + 0.5) * res)
    data = np.zeros((ny, nx), dtype=np.int8)
    for x0, y0, x1, y1 in boxes:
        gap = np.hypot(np.maximum(np.maximum(x0 - cx, cx - x1), 0), np.maximum(np.maximum(y0 - cy, cy - y1), 0))
        data[gap < res / 2] = 100
    return data


def cast_boxes(boxes, origin, angles, range_max=5.6):
    """Exact ranges from origin (x, y) along angles [rad] to axis-aligned boxes (slab method)."""
    dx, dy = np.cos(angles), np.sin(angles)
    best = np.full(angles.shape, np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        for x0, y0, x1, y1 in boxes:
            tx = np.sort(np.stack([(x0 - origin[0]) / dx, (x1 - origin[0]) / dx]), axis=0)
            ty = np.sort(np.stack([(y0 - origin[1]) / dy, (y1 - origin[1]) / dy]), axis=0)
            t_in = np.maximum(np.nan_to_num(tx[0], nan=-np.inf), np.nan_to_num(ty[0], nan=-np.inf))
            t_out = np.minimum(np.nan_to_num(tx[1], nan=np.inf), np.nan_to_num(ty[1], nan=np.inf))
            hit = (t_in <= t_out) & (t_in > 0)
            best = np.where(hit, np.minimum(best, t_in), best)
    return np.where(best < range_max, best, np.inf)


def test_interpolated_field_has_no_bias_towards_a_wall_ahead():
    """Regression (issue 5 follow-up): the robot faces a thick wall 1.5 m ahead in a corridor; the map is
    rasterised from the true geometry with the wall at 20 sub-cell positions. The likelihood's peak along
    the heading must sit on the true pose: the edge-of-cell field put it 1-2 cm off, because it made walls
    half a cell thick and scored endpoints behind the surface like hits."""
    res, laser_xy = 0.05, np.zeros(2)
    bearings = np.linspace(-1.5, 1.5, 61)
    params = LaserParams(z_hit=0.5, z_rand=0.5, sigma_hit=0.1, interpolate=True)
    shifts = np.arange(-0.05, 0.0501, 0.002)
    peaks = []
    for offset in np.linspace(0.0, res, 20, endpoint=False):
        wall_x = 3.0 + offset
        boxes = [(wall_x, 0.0, wall_x + 0.3, 3.0), (0.0, 0.0, 4.0, 0.9), (0.0, 2.1, 4.0, 3.0)]
        omap = OccupancyMap(rasterise_boxes(boxes, res, (4.0, 3.0)), res, (0.0, 0.0))
        truth = np.array([wall_x - 1.5, 1.5, 0.0])
        ranges = cast_boxes(boxes, truth[:2], bearings)
        particles = truth + np.column_stack([shifts, np.zeros_like(shifts), np.zeros_like(shifts)])
        w = likelihood_field_weights(particles, omap, laser_xy, bearings, ranges, 5.6, params)
        peaks.append(shifts[np.argmax(w)])
    assert abs(np.mean(peaks)) < 0.004, peaks
    assert np.max(np.abs(peaks)) <= 0.026, peaks


def test_interpolated_field_prefers_the_true_pose_to_sub_cell_precision():
    omap = room_map()
    laser_xy = np.array([0.06, 0.0])
    bearings = np.linspace(-1.57, 1.57, 60)
    truth = np.array([0.52, 0.21, 0.1])
    ranges = scan_from(omap, truth, laser_xy, bearings)
    params = LaserParams(sigma_hit=0.05, interpolate=True)
    shifts = np.array([[dx, 0.0, 0.0] for dx in np.linspace(-0.1, 0.1, 21)])
    w = likelihood_field_weights(truth + shifts, omap, laser_xy, bearings, ranges, 5.6, params)
    assert abs(shifts[np.argmax(w), 0]) <= 0.03


def test_likelihood_field_prob_multiplies_the_beams():
    """ROS's likelihood_field_prob: p = prod(pz) over beams with a return, by hand for two beams."""
    omap = room_map()
    params = LaserParams(z_hit=0.8, z_rand=0.2, sigma_hit=0.1)
    # From (0, 0.5) facing +x: a beam of 1.0 m ends at x = 1.0 (cell centre 0.975 .. distance to the box
    # at x >= 2.0 is 1.0 m, capped field 2.0); a beam of 0.95 m to -y ends on the bottom wall's cells.
    particle = np.array([[0.0, 0.5, 0.0]])
    bearings, ranges = np.array([0.0, -math.pi / 2]), np.array([1.0, 1.45])
    d = omap.distance_at(np.array([1.0, 0.0]), np.array([0.5, -0.95]))
    pz = 0.8 * np.exp(-d**2 / (2 * 0.1**2)) + 0.2 / 5.6
    w = likelihood_field_prob_weights(particle, omap, np.zeros(2), bearings, ranges, 5.6, params)
    assert w[0] == pytest.approx(pz[0] * pz[1])
    assert sensor_weights("likelihood_field_prob", particle, omap, np.zeros(2), bearings, ranges, 5.6, params)[0] \
        == pytest.approx(w[0])
    # no usable beam: weight 1 (the particle keeps its weight), as the other models
    assert likelihood_field_prob_weights(particle, omap, np.zeros(2), bearings, np.array([np.nan, 5.6]), 5.6,
                                         params).tolist() == [1.0]
