"""map_server's file rules: YAML validation, the three modes, thresholds, negate, image formats, saving."""

import os

import numpy as np
import pytest
from map_server.mapfile import (
    GridMap,
    MapFileError,
    image_to_occupancy,
    load_map,
    occupancy_to_pgm,
    parse_map_yaml,
    save_map,
)
from PIL import Image

pytestmark = pytest.mark.unit

GOOD = ("image: m.pgm\nresolution: 0.05\norigin: [-1.0, 2.0, 0.5]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")


def grey(values):
    return np.array(values, dtype=np.uint8)[:, :, None]


def test_parse_good_yaml():
    meta = parse_map_yaml(GOOD)
    assert meta.image == "m.pgm" and meta.resolution == 0.05 and meta.origin == (-1.0, 2.0, 0.5)
    assert meta.mode == "trinary" and meta.negate is False


@pytest.mark.parametrize("field", ["image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh"])
def test_missing_field_is_named(field):
    text = "\n".join(line for line in GOOD.splitlines() if not line.startswith(field + ":"))
    with pytest.raises(MapFileError, match=f"missing field '{field}'"):
        parse_map_yaml(text)


@pytest.mark.parametrize(("line", "field"), [
    ("resolution: -0.05", "resolution"),
    ("resolution: abc", "resolution"),
    ("origin: [1, 2]", "origin"),
    ("origin: [1, 2, .nan]", "origin"),
    ("negate: 2", "negate"),
    ("occupied_thresh: 1.5", "occupied_thresh"),
    ("free_thresh: -0.1", "free_thresh"),
    ("free_thresh: 0.9", "free_thresh"),
    ("mode: fancy", "mode"),
    ("image: ''", "image"),
])
def test_bad_field_is_named(line, field):
    key = line.split(":")[0]
    text = "\n".join(line if existing.startswith(key + ":") else existing for existing in GOOD.splitlines())
    if key not in GOOD:
        text += "\n" + line
    with pytest.raises(MapFileError, match=f"'{field}'"):
        parse_map_yaml(text)


def test_not_a_mapping():
    with pytest.raises(MapFileError, match="expected a mapping"):
        parse_map_yaml("- 1\n- 2\n")


# Pixel value -> cell value with the thresholds 0.65 / 0.196, occ = (255 - p) / 255, worked by hand;
# scale: 1 + 98 * (occ - 0.196) / (0.65 - 0.196), truncated.
@pytest.mark.parametrize(("pixel", "trinary", "scale"), [
    (255, 0, 0),      # occ 0: free
    (254, 0, 0),      # map_saver's free
    (206, 0, 0),      # occ 0.1922 < 0.196: free
    (205, -1, 1),     # occ 0.19608 > 0.196: map_saver's unknown; scale 1.0003
    (150, -1, 47),    # occ 0.4118: scale 47.57
    (90, -1, 98),     # occ 0.6471 < 0.65: scale 98.4
    (89, 100, 100),   # occ 0.6510 > 0.65: occupied
    (0, 100, 100),    # occ 1: occupied
])
def test_trinary_and_scale_values(pixel, trinary, scale):
    img = grey([[pixel]])
    assert image_to_occupancy(img, False, "trinary")[0, 0] == trinary
    assert image_to_occupancy(img, False, "scale")[0, 0] == scale


def test_negate_swaps_black_and_white():
    img = grey([[0, 255]])
    assert image_to_occupancy(img, False, "trinary", negate=False).tolist() == [[100, 0]]
    assert image_to_occupancy(img, False, "trinary", negate=True).tolist() == [[0, 100]]


def test_raw_mode_keeps_values_as_bytes():
    img = grey([[0, 50, 100, 255]])
    assert image_to_occupancy(img, False, "raw").tolist() == [[0, 50, 100, -1]]
    assert image_to_occupancy(img, False, "raw", negate=True).tolist() == [[-1, -51, -101, 0]]


def test_rows_are_flipped_so_cell_00_is_lower_left():
    img = grey([[0, 255], [255, 255]])  # black pixel top left
    data = image_to_occupancy(img, False)
    assert data[1, 0] == 100 and data[0, 0] == 0


def test_rgb_mean_and_alpha_rules():
    # RGB mean (0+0+255)/3 = 85 -> occ 0.667 > 0.65: occupied.
    rgba = np.array([[[0, 0, 255, 255], [200, 200, 200, 0]]], dtype=np.uint8)
    scale = image_to_occupancy(rgba, True, "scale")
    assert scale[0, 0] == 100
    assert scale[0, 1] == -1  # in between and fully transparent: unknown in scale mode
    # Trinary mode averages alpha in (ROS keeps that): (0+0+255+255)/4 = 127.5 -> occ 0.5: unknown.
    assert image_to_occupancy(rgba, True, "trinary")[0, 0] == -1


@pytest.mark.parametrize("ext", ["pgm", "png"])
def test_load_map_relative_image(tmp_path, ext):
    sub = tmp_path / "maps"
    sub.mkdir()
    Image.fromarray(np.array([[0, 255, 205]], dtype=np.uint8)).save(sub / f"m.{ext}")
    (sub / "m.yaml").write_text(GOOD.replace("m.pgm", f"m.{ext}"))
    grid = load_map(str(sub / "m.yaml"))
    assert grid.data.tolist() == [[100, 0, -1]]
    assert grid.resolution == 0.05 and grid.origin == (-1.0, 2.0, 0.5)


def test_load_rgba_png(tmp_path):
    Image.fromarray(np.array([[[0, 0, 0, 255], [255, 255, 255, 255]]], dtype=np.uint8), "RGBA").save(tmp_path / "m.png")
    (tmp_path / "m.yaml").write_text(GOOD.replace("m.pgm", "m.png") + "mode: scale\n")
    assert load_map(str(tmp_path / "m.yaml")).data.tolist() == [[100, 0]]


def test_missing_image_names_the_field(tmp_path):
    (tmp_path / "m.yaml").write_text(GOOD)
    with pytest.raises(MapFileError, match="field 'image'"):
        load_map(str(tmp_path / "m.yaml"))


def test_unreadable_image(tmp_path):
    (tmp_path / "m.pgm").write_bytes(b"this is not an image")
    (tmp_path / "m.yaml").write_text(GOOD)
    with pytest.raises(MapFileError, match="cannot read map image"):
        load_map(str(tmp_path / "m.yaml"))


def test_missing_yaml():
    with pytest.raises(MapFileError, match="cannot read map YAML"):
        load_map("/nonexistent/map.yaml")


def test_pgm_values_for_saving():
    data = np.array([[-1, 0, 25, 26, 64, 65, 100]], dtype=np.int8)
    assert occupancy_to_pgm(data).tolist() == [[205, 254, 254, 205, 205, 0, 0]]


def test_save_and_load_round_trip(tmp_path):
    rng = np.random.default_rng(1)
    data = rng.choice(np.array([-1, 0, 100], dtype=np.int8), size=(37, 53))
    grid = GridMap(data=data, resolution=0.025, origin=(-3.5, 1.25, 0.0))
    pgm, yaml_path = save_map(grid, str(tmp_path / "saved"))
    with open(pgm, "rb") as f:
        assert f.read(2) == b"P5"
    loaded = load_map(yaml_path)
    np.testing.assert_array_equal(loaded.data, data)
    assert loaded.resolution == pytest.approx(0.025) and loaded.origin == pytest.approx((-3.5, 1.25, 0.0))
    assert sorted(os.listdir(tmp_path)) == ["saved.pgm", "saved.yaml"]  # no temporary files left


def test_failed_save_leaves_no_partial_file(tmp_path, monkeypatch):
    grid = GridMap(data=np.zeros((4, 4), dtype=np.int8), resolution=0.05)
    (tmp_path / "old.pgm").write_bytes(b"old")

    def broken_fsync(_fd):
        raise OSError("disk full")

    monkeypatch.setattr(os, "fsync", broken_fsync)
    with pytest.raises(OSError, match="disk full"):
        save_map(grid, str(tmp_path / "old"))
    assert (tmp_path / "old.pgm").read_bytes() == b"old"
    assert sorted(os.listdir(tmp_path)) == ["old.pgm"]


def test_grid_extent_and_shades_for_pictures():
    data = np.array([[0, 100], [-1, 55]], dtype=np.int8)
    grid = GridMap(data=data, resolution=0.5, origin=(-1.0, 2.0, 0.0))
    assert grid.extent == (-1.0, 0.0, 2.0, 3.0)
    np.testing.assert_array_equal(grid.shades(), [[1.0, 0.0], [0.7, 0.7]])
