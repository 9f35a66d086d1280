"""The Kinect for Xbox 360 (model 1414) as data: what its streams mean and how to convert them.

ROS-free (numpy only). The camera node, kinect_aux and florence_sim's fakenect recorder read
their numbers from here, so a dump written from the simulator decodes to what was rendered.

Depth. libfreenect's 11-bit mode (FREENECT_DEPTH_11BIT, the only depth mode Debian's fakenect
replays) delivers the device's raw disparity ``kd`` per pixel, 2047 meaning no return. It is
turned into metres with the model of Konolige and Mihelich, "Technical description of Kinect
calibration" (wiki.ros.org/kinect_calibration/technical):

    z = b * f / d,   d = (doff - kd) / 8          i.e.   z = 8 b f / (doff - kd)

with the IR camera's focal length ``f`` [px] (the depth camera_info's fx), the projector
baseline ``b`` ~ 0.075 m and the disparity offset ``doff`` ~ 1090. A step of one raw unit is
a depth step of z^2 / (8 b f): 11 mm at 2 m, 46 mm at 4 m with the defaults. Empirical fits of
one device differ by a few per cent (N. Burrus: z = 1 / (3.3309495161 - 0.0030711016 kd) m;
OpenKinect wiki: 100 / (3.33 - 0.00307 kd) cm): the per-device values are the parameters.

Accelerometer. The KXSD9 reports 819 counts per g (libfreenect's FREENECT_COUNTS_PER_G) on
three axes: x to the Kinect's left, y up, z forward (the Kinect for Windows SDK's frame, in
which a level sensor reads gravity on y); a level Kinect reads about +819 on y. We publish
it in camera_link (REP 103: x forward, y left, z up), i.e. (z, x, y). The signs are as the
SDK documents its frame; they are not checked on a device here (UNVERIFIED).
"""

import math

import numpy as np

VENDOR = 0x045E
PRODUCT_CAMERA = 0x02AE  # Xbox NUI Camera (model 1414 and 1473)
PRODUCT_MOTOR = 0x02B0  # Xbox NUI Motor (model 1414 only)
PRODUCT_AUDIO = 0x02AD  # Xbox NUI Audio
PRODUCT_K4W_CAMERA = 0x02BF  # Kinect for Windows camera
PRODUCT_NO_MOTOR = 0x02C2  # what models 1473 and Kinect for Windows show instead of a motor
PRODUCTS = {PRODUCT_CAMERA: "camera", PRODUCT_MOTOR: "motor", PRODUCT_AUDIO: "audio",
            PRODUCT_K4W_CAMERA: "camera (Kinect for Windows)", PRODUCT_NO_MOTOR: "hub without a motor (1473/K4W)"}

WIDTH, HEIGHT = 640, 480  # [px] the only size both of fakenect's modes have (FREENECT_RESOLUTION_MEDIUM)
RATE = 30.0  # [Hz] depth and colour at 640x480
RAW_NO_VALUE = 2047  # libfreenect's FREENECT_DEPTH_RAW_NO_VALUE
RAW_VALUES = 2048  # 11 bits
DEPTH_BYTES = WIDTH * HEIGHT * 2  # uint16 per pixel, little-endian
RGB_BYTES = WIDTH * HEIGHT * 3

BASELINE = 0.075  # [m] IR projector to IR camera (Konolige and Mihelich)
DISPARITY_OFFSET = 1090.0  # doff (Konolige and Mihelich)

# Default intrinsics at 640x480, as openni_camera / freenect_camera publish them without a
# calibration file: colour f = 1050 * w / 1280 = 525 px at the image centre; depth f =
# 575.8157 px (the device's zero-plane distance 120 mm over twice its 0.1042 mm pixel size) and
# the centre shifted by the IR-to-depth offset (-5, -4) px: cx 314.5, cy 235.5.
RGB_FOCAL = 525.0  # [px] at 640 wide
DEPTH_FOCAL = 575.8157348632812  # [px] at 640 wide
DEPTH_CENTRE_OFFSET = (-5.0, -4.0)  # [px] (x, y) added to the image centre
# Where the colour camera sits in the depth camera's optical frame [m]: 2.5 cm to the right
# (+x), as turtlebot_control's robot_dimensions.yaml places camera_rgb_frame (y -0.045) and
# camera_depth_frame (y -0.02) in camera_link. Rotation: none.
RGB_IN_DEPTH = (0.025, 0.0, 0.0)

COUNTS_PER_G = 819.0
GRAVITY = 9.80665  # [m/s^2] libfreenect's freenect_get_mks_accel
TILT_LIMIT_DEG = 31.0  # [deg] the motor's range
TILT_READING_LIMIT_DEG = 35.0  # [deg] a reading beyond is no reading (-128 = -64 deg while moving)
TILT_STATUS = {0: "stopped", 1: "at limit", 4: "moving"}  # freenect_tilt_status_code
LED_OPTIONS = {0: "off", 1: "green", 2: "red", 3: "yellow", 4: "blink green", 5: "blink green",
               6: "blink red/yellow", 7: "undocumented (sent as is)"}


# --- depth -----------------------------------------------------------------------------------------------------------
def raw_to_metres_table(focal=DEPTH_FOCAL, baseline=BASELINE, offset=DISPARITY_OFFSET):
    """float32[2048]: depth [m] of every 11-bit raw value; NaN for no return (2047) and for
    raw values at or beyond the disparity offset (no finite depth)."""
    raw = np.arange(RAW_VALUES, dtype=np.float64)
    with np.errstate(divide="ignore"):
        z = 8.0 * baseline * focal / (offset - raw)
    z[(raw >= offset) | (raw == RAW_NO_VALUE)] = np.nan
    return z.astype(np.float32)


def metres_to_raw(depth, focal=DEPTH_FOCAL, baseline=BASELINE, offset=DISPARITY_OFFSET):
    """uint16 raw values of depths [m] (any shape): the nearest raw value; 2047 (no return) for
    NaN, inf, z <= 0 and depths the 11 bits cannot hold (nearer than 8 b f / doff)."""
    z = np.asarray(depth, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        raw = np.rint(offset - 8.0 * baseline * focal / z)
        bad = ~np.isfinite(z) | (z <= 0) | (raw < 0) | (raw >= min(offset, RAW_NO_VALUE))
    return np.where(bad, RAW_NO_VALUE, raw).astype(np.uint16)


def quantisation_step(depth, focal=DEPTH_FOCAL, baseline=BASELINE):
    """Depth step [m] of one raw unit at ``depth`` [m]: z^2 / (8 b f)."""
    return np.asarray(depth, dtype=np.float64) ** 2 / (8.0 * baseline * focal)


# --- accelerometer and tilt ------------------------------------------------------------------------------------------
def accel_to_camera_link(counts):
    """Raw (x, y, z) counts -> specific force [m/s^2] in camera_link (x forward, y left, z up)."""
    x, y, z = (float(c) for c in counts)
    k = GRAVITY / COUNTS_PER_G
    return (z * k, x * k, y * k)


def camera_link_to_accel(acceleration):
    """Specific force [m/s^2] in camera_link -> the raw (x, y, z) counts a Kinect would report."""
    fx, fy, fz = (float(a) for a in acceleration)
    k = COUNTS_PER_G / GRAVITY
    return tuple(int(max(-32768, min(32767, round(v * k)))) for v in (fy, fz, fx))


def tilt_degrees(raw):
    """Tilt [deg] of the raw int8 reading (half degrees); NaN when it is no reading (the motor
    reports -128 while it moves)."""
    deg = int(raw) / 2.0
    return deg if abs(deg) <= TILT_READING_LIMIT_DEG else math.nan


def tilt_raw(degrees):
    """The raw int8 reading of a tilt [deg] (half degrees, rounded)."""
    return int(max(-128, min(127, round(2.0 * float(degrees)))))


# --- frame rate -------------------------------------------------------------------------------------------------------
class RateGate:
    """Lets frames through at most at ``rate`` [Hz], judged by the frames' own times [s].

    Frames pass on a schedule of slots one period apart. A frame passes when it is at most a
    quarter period early for the next slot, and then books the slot after it. A frame up to
    three quarters of a period late for its slot keeps the schedule (the slot after is booked
    one period after the one it took), so a faster source is thinned to the rate whatever the
    phase of its frames (36 Hz to 30, 30 to 20 as two of three) and a source at the rate with
    that much jitter passes whole. A frame later than that (a slower source, or a pause)
    starts the schedule afresh, its next slot three quarters of a period after it: a source
    that resumes after a pause gets no more than one frame half a period early. A gate
    that booked from each frame's own time would lose what an early frame left over: 36 Hz
    came out at 24, 30 at 15 for a rate of 20.
    """

    def __init__(self, rate):
        if not rate > 0:
            raise ValueError(f"rate must be > 0, got {rate!r}")
        self.period = 1.0 / float(rate)
        self.next = -math.inf

    def admit(self, t):
        if t + 0.25 * self.period < self.next:
            return False
        late = t - self.next
        self.next = t + 0.75 * self.period if late > 0.75 * self.period else self.next + self.period
        return True
