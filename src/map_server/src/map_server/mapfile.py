"""ROS map files (YAML + PGM/PNG image) to occupancy grids and back, without ROS.

The rules are those of ROS 1 map_server (image_loader.cpp and map_saver.cpp):

Loading (``load_map``): every pixel's colour is the mean of its channels (the alpha
channel is left out of the mean except in trinary mode); with ``negate`` the mean is
replaced by ``255 - mean``; ``occ = (255 - mean) / 255``.

- ``raw``: the cell value is the (negated) mean itself, truncated to a byte and stored
  as int8 like ROS does (so 255 becomes -1);
- ``trinary`` (default): ``occ > occupied_thresh`` is 100, ``occ < free_thresh`` is 0,
  anything in between is -1 (unknown);
- ``scale``: as trinary, but in-between cells get ``1 + 98 * (occ - free) / (occ_thresh
  - free)`` (truncated), and fully transparent pixels (alpha 0) are unknown.

The image's top row is the map's last row: cell (0, 0) is the lower left corner at
``origin`` [x, y, yaw] (m, m, rad).

Saving (``occupancy_to_pgm``): cells in [0, threshold_free] are 254 (free), cells >=
threshold_occupied are 0 (occupied), everything else (unknown, in between) is 205. The
YAML says ``occupied_thresh: 0.65`` and ``free_thresh: 0.196`` like map_saver, so that
205 reads back as unknown.
"""

import logging
import math
import os
from dataclasses import dataclass, field

import numpy as np
import yaml

from florence_common.files import atomic_write

log = logging.getLogger(__name__)

MODES = ("trinary", "scale", "raw")
FREE_PIXEL, OCCUPIED_PIXEL, UNKNOWN_PIXEL = 254, 0, 205
SAVED_OCCUPIED_THRESH, SAVED_FREE_THRESH = 0.65, 0.196
REQUIRED_FIELDS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")


class MapFileError(ValueError):
    """A map YAML or image that cannot be loaded; the message names the file and field."""


@dataclass
class MapMeta:
    """How an image becomes a grid (the YAML fields)."""

    image: str  # path of the image, absolute or relative to the YAML's directory
    resolution: float  # [m/cell]
    origin: tuple  # (x [m], y [m], yaw [rad]) of the lower left cell's corner
    negate: bool = False
    occupied_thresh: float = 0.65  # occupancy probability above which a cell is occupied
    free_thresh: float = 0.196  # occupancy probability below which a cell is free
    mode: str = "trinary"


@dataclass
class GridMap:
    """An occupancy grid: ``data[row, col]`` int8 in {-1, 0..100}, row 0 at the origin."""

    data: np.ndarray
    resolution: float  # [m/cell]
    origin: tuple = (0.0, 0.0, 0.0)  # (x [m], y [m], yaw [rad])
    meta: MapMeta | None = field(default=None, repr=False)

    @property
    def height(self):
        return self.data.shape[0]

    @property
    def width(self):
        return self.data.shape[1]

    @property
    def extent(self):
        """(left, right, bottom, top) [m] of the grid (origin yaw 0), for matplotlib's imshow with
        origin="lower"."""
        x0, y0 = self.origin[:2]
        return (x0, x0 + self.width * self.resolution, y0, y0 + self.height * self.resolution)

    def shades(self):
        """The grid as grey levels for a picture: occupied 0.0, free 1.0, anything else 0.7."""
        return np.where(self.data == 100, 0.0, np.where(self.data == 0, 1.0, 0.7))


def _number(doc, name, where):
    value = doc.get(name)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise MapFileError(f"{where}: field '{name}' must be a finite number, got {value!r}")
    return float(value)


def parse_map_yaml(text, where="map YAML"):
    """Parse and validate the YAML text of a map; return a :class:`MapMeta`.

    Raises :class:`MapFileError` naming the missing or invalid field.
    """
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise MapFileError(f"{where}: not valid YAML: {exc}") from None
    if not isinstance(doc, dict):
        raise MapFileError(f"{where}: expected a mapping with fields {', '.join(REQUIRED_FIELDS)}")
    for name in REQUIRED_FIELDS:
        if name not in doc:
            raise MapFileError(f"{where}: missing field '{name}'")
    image = doc["image"]
    if not isinstance(image, str) or not image.strip():
        raise MapFileError(f"{where}: field 'image' must be a file name, got {image!r}")
    resolution = _number(doc, "resolution", where)
    if resolution <= 0.0:
        raise MapFileError(f"{where}: field 'resolution' must be > 0, got {resolution}")
    origin = doc["origin"]
    if (not isinstance(origin, list | tuple) or len(origin) != 3
            or not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in origin)):
        raise MapFileError(f"{where}: field 'origin' must be [x, y, yaw] (three numbers), got {origin!r}")
    negate = doc["negate"]
    if negate not in (0, 1):  # also accepts true/false
        raise MapFileError(f"{where}: field 'negate' must be 0 or 1, got {negate!r}")
    occ = _number(doc, "occupied_thresh", where)
    free = _number(doc, "free_thresh", where)
    if not 0.0 <= occ <= 1.0:
        raise MapFileError(f"{where}: field 'occupied_thresh' must be in [0, 1], got {occ}")
    if not 0.0 <= free <= 1.0:
        raise MapFileError(f"{where}: field 'free_thresh' must be in [0, 1], got {free}")
    if free > occ:
        raise MapFileError(f"{where}: field 'free_thresh' ({free}) must not exceed 'occupied_thresh' ({occ})")
    mode = doc.get("mode", "trinary")
    if mode not in MODES:
        raise MapFileError(f"{where}: field 'mode' must be one of {', '.join(MODES)}, got {mode!r}")
    return MapMeta(image=image.strip(), resolution=resolution, origin=tuple(float(v) for v in origin),
                   negate=bool(negate), occupied_thresh=occ, free_thresh=free, mode=mode)


def read_image(path):
    """Read an image file into (pixels uint8 [H, W, C], has_alpha).

    Grey, grey+alpha, RGB and RGBA images of any format PIL reads (PGM, PNG, BMP...).
    """
    from PIL import Image, UnidentifiedImageError

    try:
        with Image.open(path) as opened:
            opened.load()
            mode, img = opened.mode, opened
            if mode == "P":
                img = opened.convert("RGBA" if "transparency" in opened.info else "RGB")
            elif mode == "1":
                img = opened.convert("L")
            elif mode in ("I", "I;16", "I;16B", "F"):
                # 16-bit PGM: scale to 8 bits like an 8-bit loader would see it.
                arr = np.asarray(opened, dtype=np.float64)
                top = 65535.0 if arr.max(initial=0) > 255 else 255.0
                return np.clip(np.round(arr * 255.0 / top), 0, 255).astype(np.uint8)[:, :, None], False
            elif mode not in ("L", "LA", "RGB", "RGBA"):
                img = opened.convert("RGB")
            pixels = np.asarray(img, dtype=np.uint8)
    except (OSError, UnidentifiedImageError) as exc:
        raise MapFileError(f"cannot read map image '{path}': {exc}") from None
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    has_alpha = pixels.shape[2] in (2, 4)
    return pixels, has_alpha


def image_to_occupancy(pixels, has_alpha, mode="trinary", negate=False, occupied_thresh=0.65, free_thresh=0.196):
    """Convert image pixels [H, W, C] (top row first) to int8 grid data [H, W] (row 0 = bottom)."""
    if mode not in MODES:
        raise MapFileError(f"field 'mode' must be one of {', '.join(MODES)}, got {mode!r}")
    pixels = np.asarray(pixels)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    channels = pixels.shape[2]
    avg_channels = channels - 1 if has_alpha and mode != "trinary" else channels
    mean = pixels[:, :, :avg_channels].astype(np.int64).sum(axis=2) / float(avg_channels)
    alpha = pixels[:, :, -1] if channels > 1 else np.full(mean.shape, 255)
    if negate:
        mean = 255.0 - mean
    if mode == "raw":
        values = mean.astype(np.int64).astype(np.uint8).view(np.int8)
        return np.ascontiguousarray(values[::-1])
    occ = (255.0 - mean) / 255.0
    values = np.full(mean.shape, -1, dtype=np.int8)
    if mode == "scale":
        span = occupied_thresh - free_thresh
        ratio = (occ - free_thresh) / span if span > 0 else np.zeros_like(occ)
        scaled = (1.0 + 98.0 * ratio).astype(np.int64)
        between = alpha >= 1
        values[between] = np.clip(scaled[between], 1, 99)
    values[occ < free_thresh] = 0
    values[occ > occupied_thresh] = 100
    return np.ascontiguousarray(values[::-1])


def load_map(yaml_path):
    """Load a map from its YAML file; the image path is relative to the YAML's directory."""
    try:
        with open(yaml_path) as f:
            text = f.read()
    except OSError as exc:
        raise MapFileError(f"cannot read map YAML '{yaml_path}': {exc.strerror}") from None
    meta = parse_map_yaml(text, where=str(yaml_path))
    image = meta.image if os.path.isabs(meta.image) else os.path.join(os.path.dirname(os.path.abspath(yaml_path)),
                                                                      meta.image)
    if not os.path.isfile(image):
        raise MapFileError(f"{yaml_path}: field 'image': no such file '{image}'")
    meta.image = image
    pixels, has_alpha = read_image(image)
    data = image_to_occupancy(pixels, has_alpha, meta.mode, meta.negate, meta.occupied_thresh, meta.free_thresh)
    log.info("loaded %s: %d x %d cells at %.3f m/cell", image, data.shape[1], data.shape[0], meta.resolution)
    return GridMap(data=data, resolution=meta.resolution, origin=meta.origin, meta=meta)


def load_image_map(image_path, resolution):
    """The deprecated ``map_server <image> <resolution>`` form: trinary, origin 0, ROS thresholds."""
    if not (isinstance(resolution, float) and math.isfinite(resolution) and resolution > 0):
        raise MapFileError(f"field 'resolution' must be > 0, got {resolution!r}")
    pixels, has_alpha = read_image(image_path)
    meta = MapMeta(image=str(image_path), resolution=resolution, origin=(0.0, 0.0, 0.0))
    data = image_to_occupancy(pixels, has_alpha)
    return GridMap(data=data, resolution=resolution, origin=meta.origin, meta=meta)


def occupancy_to_pgm(data, threshold_occupied=65, threshold_free=25):
    """Grid data [H, W] (row 0 = bottom) to PGM pixel rows [H, W] uint8 (top row first)."""
    data = np.asarray(data).astype(np.int16)
    pixels = np.full(data.shape, UNKNOWN_PIXEL, dtype=np.uint8)
    pixels[(data >= 0) & (data <= threshold_free)] = FREE_PIXEL
    pixels[data >= threshold_occupied] = OCCUPIED_PIXEL
    return np.ascontiguousarray(pixels[::-1])


def save_map(grid, mapname, threshold_occupied=65, threshold_free=25):
    """Write ``mapname``.pgm and ``mapname``.yaml, each atomically; return both paths.

    The YAML names the image by its base name (it sits beside the YAML), so the pair
    can be moved together.
    """
    if not 0 <= threshold_free < threshold_occupied <= 100:
        raise ValueError(f"need 0 <= threshold_free ({threshold_free}) < threshold_occupied "
                         f"({threshold_occupied}) <= 100")
    pgm_path, yaml_path = f"{mapname}.pgm", f"{mapname}.yaml"
    pixels = occupancy_to_pgm(grid.data, threshold_occupied, threshold_free)
    height, width = pixels.shape
    header = f"P5\n# CREATOR: map_saver {grid.resolution:.3f} m/pix\n{width} {height}\n255\n".encode("ascii")
    x, y, yaw = grid.origin
    text = (f"image: {os.path.basename(pgm_path)}\nresolution: {grid.resolution:f}\n"
            f"origin: [{x:f}, {y:f}, {yaw:f}]\nnegate: 0\noccupied_thresh: {SAVED_OCCUPIED_THRESH}\n"
            f"free_thresh: {SAVED_FREE_THRESH}\n\n")
    atomic_write(pgm_path, header + pixels.tobytes())
    atomic_write(yaml_path, text.encode("ascii"))
    return pgm_path, yaml_path
