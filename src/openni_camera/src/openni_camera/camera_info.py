"""Camera intrinsics: the Kinect's defaults, calibration files and their URLs (ROS-free).

Calibration files are in the YAML format of ROS's camera_calibration_parsers (what
camera_calibration writes and camera_info_manager reads)::

    image_width: 640
    image_height: 480
    camera_name: depth_A00361800412047A
    camera_matrix: {rows: 3, cols: 3, data: [fx, 0, cx, 0, fy, cy, 0, 0, 1]}
    distortion_model: plumb_bob
    distortion_coefficients: {rows: 1, cols: 5, data: [k1, k2, t1, t2, k3]}
    rectification_matrix: {rows: 3, cols: 3, data: [...]}
    projection_matrix: {rows: 3, cols: 4, data: [...]}

URLs as camera_info_manager takes them: "" (the defaults), ``file:///abs/path.yaml``,
``package://pkg/relative/path.yaml``; ``${NAME}`` in a URL is the camera's name.
"""

import math
from dataclasses import dataclass, field

import yaml

from openni_camera import kinect


class CalibrationError(ValueError):
    """A calibration file or URL that cannot be used; the message says why."""


@dataclass
class CameraInfo:
    """sensor_msgs/CameraInfo without the header: sizes [px], K (3x3), D, R (3x3), P (3x4) row-major."""

    width: int
    height: int
    K: list
    D: list = field(default_factory=lambda: [0.0] * 5)
    R: list = field(default_factory=lambda: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])
    P: list = None
    distortion_model: str = "plumb_bob"
    camera_name: str = ""

    def __post_init__(self):
        if self.P is None:
            k = self.K
            self.P = [k[0], k[1], k[2], 0.0, k[3], k[4], k[5], 0.0, 0.0, 0.0, 1.0, 0.0]

    @property
    def fx(self):
        return self.K[0]

    @property
    def fy(self):
        return self.K[4]

    @property
    def cx(self):
        return self.K[2]

    @property
    def cy(self):
        return self.K[5]


def pinhole(width, height, focal, cx, cy, name=""):
    return CameraInfo(width, height, [focal, 0.0, cx, 0.0, focal, cy, 0.0, 0.0, 1.0], camera_name=name)


def default_rgb(width=kinect.WIDTH, height=kinect.HEIGHT, name="rgb"):
    """The Kinect colour camera's default intrinsics: f = 525 px at 640 wide, centred."""
    f = kinect.RGB_FOCAL * width / kinect.WIDTH
    return pinhole(width, height, f, (width - 1) / 2.0, (height - 1) / 2.0, name)


def default_depth(width=kinect.WIDTH, height=kinect.HEIGHT, name="depth"):
    """The Kinect depth camera's default intrinsics: f = 575.8 px at 640 wide, the centre moved
    by the IR-to-depth offset (-5, -4) px (cx 314.5, cy 235.5 at 640x480)."""
    s = width / kinect.WIDTH
    dx, dy = kinect.DEPTH_CENTRE_OFFSET
    return pinhole(width, height, kinect.DEPTH_FOCAL * s, (width - 1) / 2.0 + dx * s, (height - 1) / 2.0 + dy * s,
                   name)


# --- files -----------------------------------------------------------------------------------------------------------
def _matrix(doc, key, rows, cols, where):
    m = doc.get(key)
    if not isinstance(m, dict) or "data" not in m:
        raise CalibrationError(f"{where}: {key}: expected a mapping with rows, cols and data")
    data = m["data"]
    if not isinstance(data, list):
        raise CalibrationError(f"{where}: {key}.data: expected a list")
    if rows is not None and (m.get("rows", rows) != rows or (cols is not None and m.get("cols", cols) != cols)):
        raise CalibrationError(f"{where}: {key}: expected {rows}x{cols}, got {m.get('rows')}x{m.get('cols')}")
    if rows is not None and cols is not None and len(data) != rows * cols:
        raise CalibrationError(f"{where}: {key}.data: expected {rows * cols} numbers, got {len(data)}")
    try:
        values = [float(v) for v in data]
    except (TypeError, ValueError):
        raise CalibrationError(f"{where}: {key}.data: expected numbers, got {data!r}") from None
    if not all(math.isfinite(v) for v in values):
        raise CalibrationError(f"{where}: {key}.data: not every number is finite")
    return values


def parse_yaml(text, where="calibration"):
    """CameraInfo of a camera_calibration_parsers YAML text; CalibrationError naming the field."""
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise CalibrationError(f"{where}: not YAML: {exc}") from None
    if not isinstance(doc, dict):
        raise CalibrationError(f"{where}: expected a mapping")
    try:
        width, height = int(doc["image_width"]), int(doc["image_height"])
    except (KeyError, TypeError, ValueError):
        raise CalibrationError(f"{where}: image_width and image_height must be integers") from None
    if width <= 0 or height <= 0:
        raise CalibrationError(f"{where}: image size {width}x{height} must be positive")
    K = _matrix(doc, "camera_matrix", 3, 3, where)
    if K[0] <= 0 or K[4] <= 0:
        raise CalibrationError(f"{where}: camera_matrix: fx and fy must be positive, got {K[0]}, {K[4]}")
    D = _matrix(doc, "distortion_coefficients", None, None, where) if "distortion_coefficients" in doc else [0.0] * 5
    R = _matrix(doc, "rectification_matrix", 3, 3, where) if "rectification_matrix" in doc else None
    P = _matrix(doc, "projection_matrix", 3, 4, where) if "projection_matrix" in doc else None
    info = CameraInfo(width, height, K, D, camera_name=str(doc.get("camera_name", "")),
                      distortion_model=str(doc.get("distortion_model", "plumb_bob")))
    if R is not None:
        info.R = R
    if P is not None:
        info.P = P
    return info


def to_yaml(info):
    """The camera_calibration_parsers YAML text of a CameraInfo."""
    def matrix(rows, cols, data):
        return {"rows": rows, "cols": cols, "data": [float(v) for v in data]}

    doc = {"image_width": int(info.width), "image_height": int(info.height), "camera_name": info.camera_name,
           "camera_matrix": matrix(3, 3, info.K), "distortion_model": info.distortion_model,
           "distortion_coefficients": matrix(1, len(info.D), info.D), "rectification_matrix": matrix(3, 3, info.R),
           "projection_matrix": matrix(3, 4, info.P)}
    return yaml.safe_dump(doc, sort_keys=False, default_flow_style=None)


def resolve_url(url, camera_name="", package_path=None):
    """The file a calibration URL names, or None for "" (use the defaults). ``package_path(name)``
    returns a package's directory (rospkg in the node). CalibrationError for other schemes."""
    url = url.strip().replace("${NAME}", camera_name)
    if not url:
        return None
    if url.startswith("file://"):
        path = url[len("file://"):]
        if not path.startswith("/"):
            raise CalibrationError(f"{url}: a file URL needs an absolute path (file:///...)")
        return path
    if url.startswith("package://"):
        rest = url[len("package://"):]
        package, _, relative = rest.partition("/")
        if not package or not relative:
            raise CalibrationError(f"{url}: expected package://<package>/<path>")
        if package_path is None:
            raise CalibrationError(f"{url}: package URLs need ROS's package path")
        try:
            return f"{package_path(package)}/{relative}"
        except Exception as exc:  # noqa: BLE001 - rospkg's ResourceNotFound or any lookup failure
            raise CalibrationError(f"{url}: package {package!r} not found ({exc})") from None
    raise CalibrationError(f"{url}: unsupported URL (use file:///path.yaml or package://pkg/path.yaml)")


def load(url, width, height, default, camera_name="", package_path=None):
    """(CameraInfo, problem): the calibration at ``url`` for a ``width`` x ``height`` image, or
    ``default`` and the reason it was not used (None when the URL is empty or the file is good)."""
    try:
        path = resolve_url(url, camera_name, package_path)
        if path is None:
            return default, None
        try:
            with open(path, encoding="utf-8") as f:
                text = f.read()
        except OSError as exc:
            raise CalibrationError(f"{url}: cannot read {path}: {exc.strerror}") from None
        info = parse_yaml(text, where=path)
        if (info.width, info.height) != (width, height):
            raise CalibrationError(f"{path}: calibrated for {info.width}x{info.height}, the stream is {width}x{height}")
        return info, None
    except CalibrationError as exc:
        return default, str(exc)
