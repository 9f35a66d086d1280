"""The Kinect's motor device as kinect_aux sees it (ROS-free): commands checked, states decoded.

Numbers from openni_camera.kinect (one table for the driver and florence_sim's recorder).
"""

import math
from dataclasses import dataclass

from openni_camera.fakenect_dump import parse_tilt_state

from openni_camera import kinect


def tilt_command(degrees):
    """(degrees to send, note): a tilt command [deg] clamped to the motor's +-31; (None, why) for
    NaN or infinity. ``note`` says when it was clamped (None otherwise)."""
    value = float(degrees)
    if not math.isfinite(value):
        return None, f"tilt {value} deg is not a number: ignored"
    limit = kinect.TILT_LIMIT_DEG
    clamped = max(-limit, min(limit, value))
    return clamped, (f"tilt {value:g} deg clamped to {clamped:g} (the motor's range is +-{limit:g})"
                     if clamped != value else None)


def led_command(option):
    """(option, None) for an LED option 0..7, or (None, why)."""
    value = int(option)
    if value not in kinect.LED_OPTIONS:
        return None, (f"LED option {value} ignored: 0..7 ("
                      + ", ".join(f"{k} {v}" for k, v in kinect.LED_OPTIONS.items() if k < 7) + ")")
    return value, None


@dataclass
class MotorState:
    acceleration: tuple  # [m/s^2] specific force in camera_link (x forward, y left, z up)
    counts: tuple  # raw accelerometer counts (x, y, z) as the device reports them
    tilt: float  # [deg], NaN when the reading is no angle (the motor is moving)
    status: int  # libfreenect's freenect_tilt_status_code: 0 stopped, 1 at limit, 4 moving

    @property
    def status_text(self):
        return kinect.TILT_STATUS.get(self.status, f"unknown ({self.status})")


def decode(raw):
    """MotorState of the 12 bytes of freenect_raw_tilt_state."""
    counts, tilt_raw, status = parse_tilt_state(raw)
    return MotorState(kinect.accel_to_camera_link(counts), counts, kinect.tilt_degrees(tilt_raw), status)
