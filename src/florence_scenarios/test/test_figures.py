"""florence_scenarios.figures draw real pictures: a PNG of the right kind, with the paths on it."""

import numpy as np
import pytest
from map_server.mapfile import GridMap
from PIL import Image

from florence_scenarios import figures

pytestmark = pytest.mark.unit


def grid():
    data = np.zeros((100, 80), np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    return GridMap(data, 0.05, (0.0, 0.0, 0.0))


def test_paths_over_map_draws_the_paths(tmp_path):
    png = tmp_path / "paths.png"
    figures.paths_over_map(png, grid(), [(0.5, 0.5), (3.5, 4.5)], [(0.5, 0.6), (3.4, 4.4)],
                           {"alice": [(1.0, 4.0), (3.0, 1.0)]}, [(3.5, 4.5, "gotoUser")], "day")
    empty = tmp_path / "empty.png"
    figures.paths_over_map(empty, grid(), [], title="day")
    drawn, blank = (np.asarray(Image.open(p).convert("RGB")).astype(int) for p in (png, empty))
    assert drawn.shape == blank.shape and drawn.shape[0] > drawn.shape[1]  # the map is taller than wide
    blue = (drawn[..., 2] > 150) & (drawn[..., 0] < 100)
    assert blue.sum() > 100 and ((blank[..., 2] > 150) & (blank[..., 0] < 100)).sum() < blue.sum() / 10


def test_timeline_and_bars_write_pngs(tmp_path):
    figures.timeline(tmp_path / "t.png", {"distance": ([0, 1, 2], [1.2, 1.0, 0.9])}, "m",
                     [(0.45, "personal space")])
    figures.bars(tmp_path / "b.png", {"move_base": 0.3, "amcl": 0.1}, "cores", limit=1.2)
    for name in ("t.png", "b.png"):
        assert Image.open(tmp_path / name).format == "PNG"
