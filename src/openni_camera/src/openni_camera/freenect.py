"""A small ctypes binding of libfreenect 0.5 (Debian's libfreenect0.5; /usr/include/libfreenect.h).

Only what the Kinect drivers use: context and device, the 11-bit depth and RGB video streams
at 640x480 with their callbacks, the motor (tilt, LED, accelerometer). Standard library only:
it runs in the worker process (openni_camera.worker), which keeps the library, its USB event
loop and anything it may do to its process (fakenect calls exit() on a broken dump) away from
the ROS node.

The same binding loads fakenect's libfreenect.so (libfreenect-bin), which replays a dump
instead of talking to USB: ``Freenect("/usr/lib/x86_64-linux-gnu/fakenect/libfreenect.so.0.5")``
or LD_LIBRARY_PATH pointing at that folder. Debian's fakenect (0.5.3) has no registration, no
millimetre depth, no device list and no flags: those symbols are optional here.
"""

import ctypes
import os

DEFAULT_LIBRARY = "libfreenect.so.0.5"
FAKENECT_DIR = "/usr/lib/x86_64-linux-gnu/fakenect"
FAKENECT_LIBRARY = f"{FAKENECT_DIR}/libfreenect.so.0.5"

# enums of libfreenect.h
DEVICE_MOTOR, DEVICE_CAMERA, DEVICE_AUDIO = 0x01, 0x02, 0x04
RESOLUTION_MEDIUM = 1  # 640x480
VIDEO_RGB = 0
DEPTH_11BIT = 0
LOG_WARNING = 2
LOG_MESSAGES = ("fatal", "error", "warning", "notice", "info", "debug", "spew", "flood")


class FrameMode(ctypes.Structure):
    """freenect_frame_mode (24 bytes)."""

    _fields_ = [("reserved", ctypes.c_uint32), ("resolution", ctypes.c_int32), ("format", ctypes.c_int32),
                ("bytes", ctypes.c_int32), ("width", ctypes.c_int16), ("height", ctypes.c_int16),
                ("data_bits_per_pixel", ctypes.c_int8), ("padding_bits_per_pixel", ctypes.c_int8),
                ("framerate", ctypes.c_int8), ("is_valid", ctypes.c_int8)]


class RawTiltState(ctypes.Structure):
    """freenect_raw_tilt_state (12 bytes): what fakenect-record stores as an 'a' record."""

    _fields_ = [("accelerometer_x", ctypes.c_int16), ("accelerometer_y", ctypes.c_int16),
                ("accelerometer_z", ctypes.c_int16), ("tilt_angle", ctypes.c_int8), ("tilt_status", ctypes.c_int32)]


class DeviceAttributes(ctypes.Structure):
    pass


DeviceAttributes._fields_ = [("next", ctypes.POINTER(DeviceAttributes)), ("camera_serial", ctypes.c_char_p)]


class Timeval(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_usec", ctypes.c_long)]


FRAME_CALLBACK = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint32)
LOG_CALLBACK = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_int, ctypes.c_char_p)

_P = ctypes.c_void_p
_PP = ctypes.POINTER(ctypes.c_void_p)
_INT = ctypes.c_int
# name: (result type, argument types); every one of these is in libfreenect 0.5 and fakenect
REQUIRED = {
    "freenect_init": (_INT, [_PP, _P]),
    "freenect_shutdown": (_INT, [_P]),
    "freenect_set_log_level": (None, [_P, _INT]),
    "freenect_process_events": (_INT, [_P]),
    "freenect_process_events_timeout": (_INT, [_P, ctypes.POINTER(Timeval)]),
    "freenect_num_devices": (_INT, [_P]),
    "freenect_select_subdevices": (None, [_P, _INT]),
    "freenect_open_device": (_INT, [_P, _PP, _INT]),
    "freenect_open_device_by_camera_serial": (_INT, [_P, _PP, ctypes.c_char_p]),
    "freenect_close_device": (_INT, [_P]),
    "freenect_set_depth_callback": (None, [_P, FRAME_CALLBACK]),
    "freenect_set_video_callback": (None, [_P, FRAME_CALLBACK]),
    "freenect_find_depth_mode": (FrameMode, [_INT, _INT]),
    "freenect_find_video_mode": (FrameMode, [_INT, _INT]),
    "freenect_set_depth_mode": (_INT, [_P, FrameMode]),
    "freenect_set_video_mode": (_INT, [_P, FrameMode]),
    "freenect_start_depth": (_INT, [_P]),
    "freenect_start_video": (_INT, [_P]),
    "freenect_stop_depth": (_INT, [_P]),
    "freenect_stop_video": (_INT, [_P]),
    "freenect_update_tilt_state": (_INT, [_P]),
    "freenect_get_tilt_state": (ctypes.POINTER(RawTiltState), [_P]),
    "freenect_set_tilt_degs": (_INT, [_P, ctypes.c_double]),
    "freenect_set_led": (_INT, [_P, _INT]),
}
# real libfreenect only (Debian's fakenect lacks them)
OPTIONAL = {
    "freenect_list_device_attributes": (_INT, [_P, ctypes.POINTER(ctypes.POINTER(DeviceAttributes))]),
    "freenect_free_device_attributes": (None, [ctypes.POINTER(DeviceAttributes)]),
    "freenect_set_log_callback": (None, [_P, LOG_CALLBACK]),
}


class FreenectError(RuntimeError):
    """A libfreenect call failed; the message names the call and its result."""


def load(library=DEFAULT_LIBRARY):
    """The ctypes library ``library`` (a name the dynamic loader finds, e.g. through
    LD_LIBRARY_PATH, or a path) with every prototype set. OSError when it cannot be loaded,
    FreenectError when it is no libfreenect."""
    lib = ctypes.CDLL(library)
    missing = [name for name in REQUIRED if not hasattr(lib, name)]
    if missing:
        raise FreenectError(f"{library} is not libfreenect 0.5: it lacks {', '.join(missing)}")
    for name, (restype, argtypes) in {**REQUIRED, **OPTIONAL}.items():
        if hasattr(lib, name):
            fn = getattr(lib, name)
            fn.restype, fn.argtypes = restype, argtypes
    return lib


def is_fakenect(lib):
    """Whether ``lib`` is fakenect's replay library (it has no device list)."""
    return not hasattr(lib, "freenect_list_device_attributes")


def library_path(lib):
    """The file the dynamic loader took for ``lib`` (from /proc/self/maps), or the name asked for."""
    try:
        with open("/proc/self/maps") as f:
            for line in f:
                path = line.rstrip("\n").split(" ")[-1]
                if os.path.basename(path).startswith("libfreenect.so"):
                    return path
    except OSError:
        pass
    return lib._name


class Freenect:
    """One libfreenect context with at most one open device."""

    def __init__(self, library=DEFAULT_LIBRARY):
        self.lib = load(library)
        self.fake = is_fakenect(self.lib)
        self.ctx = ctypes.c_void_p()
        self.dev = ctypes.c_void_p()
        self._callbacks = []  # keep the ctypes callbacks alive as long as the library may call them
        self._check("freenect_init", self.lib.freenect_init(ctypes.byref(self.ctx), None))

    @staticmethod
    def _check(call, result):
        if result < 0:
            raise FreenectError(f"{call} failed ({result})")
        return result

    def set_log(self, level, callback=None):
        """Library messages up to ``level`` (LOG_*); with ``callback(level, text)`` they go there
        instead of stderr (real libfreenect only)."""
        self.lib.freenect_set_log_level(self.ctx, level)
        if callback is not None and hasattr(self.lib, "freenect_set_log_callback"):
            cb = LOG_CALLBACK(lambda _ctx, lvl, msg: callback(lvl, msg.decode("utf-8", "replace").strip()))
            self._callbacks.append(cb)
            self.lib.freenect_set_log_callback(self.ctx, cb)

    def select(self, subdevices):
        self.lib.freenect_select_subdevices(self.ctx, subdevices)

    def num_devices(self):
        return self._check("freenect_num_devices", self.lib.freenect_num_devices(self.ctx))

    def serials(self):
        """Camera serial numbers of the connected devices (empty when the library cannot list them)."""
        if not hasattr(self.lib, "freenect_list_device_attributes"):
            return []
        head = ctypes.POINTER(DeviceAttributes)()
        count = self.lib.freenect_list_device_attributes(self.ctx, ctypes.byref(head))
        serials, node = [], head
        for _ in range(max(0, count)):
            if not node:
                break
            serials.append((node.contents.camera_serial or b"").decode("ascii", "replace"))
            node = node.contents.next
        if head:
            self.lib.freenect_free_device_attributes(head)
        return serials

    def open(self, index=0, serial=None):
        if serial:
            result = self.lib.freenect_open_device_by_camera_serial(self.ctx, ctypes.byref(self.dev),
                                                                    serial.encode("ascii"))
            self._check(f"freenect_open_device_by_camera_serial({serial!r})", result)
        else:
            result = self.lib.freenect_open_device(self.ctx, ctypes.byref(self.dev), int(index))
            self._check(f"freenect_open_device({index})", result)

    # --- camera ------------------------------------------------------------------------------------------------------
    def start_streams(self, on_depth=None, on_video=None):
        """Start 11-bit depth and/or RGB video at 640x480; ``on_*(pointer, size, timestamp)`` get
        each frame (the buffer is the library's: copy it before returning). Returns the modes."""
        modes = {}
        for kind, handler, find, setter, fmt, start, set_cb in (
                ("depth", on_depth, "freenect_find_depth_mode", "freenect_set_depth_mode", DEPTH_11BIT,
                 "freenect_start_depth", "freenect_set_depth_callback"),
                ("video", on_video, "freenect_find_video_mode", "freenect_set_video_mode", VIDEO_RGB,
                 "freenect_start_video", "freenect_set_video_callback")):
            if handler is None:
                continue
            mode = getattr(self.lib, find)(RESOLUTION_MEDIUM, fmt)
            if not mode.is_valid:
                raise FreenectError(f"{find}: no 640x480 {kind} mode")
            self._check(setter, getattr(self.lib, setter)(self.dev, mode))
            size = int(mode.bytes)

            def trampoline(_dev, data, timestamp, handler=handler, size=size):
                handler(data, size, timestamp)

            cb = FRAME_CALLBACK(trampoline)
            self._callbacks.append(cb)
            getattr(self.lib, set_cb)(self.dev, cb)
            self._check(start, getattr(self.lib, start)(self.dev))
            modes[kind] = mode
        return modes

    def stop_streams(self):
        self.lib.freenect_stop_depth(self.dev)
        self.lib.freenect_stop_video(self.dev)

    def process_events(self, timeout):
        """Handle the library's pending events for up to ``timeout`` [s] (fakenect: one record of
        its dump, waiting as long as the recording did). Returns libfreenect's result (< 0: error
        or, for fakenect, the end of the dump)."""
        tv = Timeval(int(timeout), int((timeout - int(timeout)) * 1e6))
        return self.lib.freenect_process_events_timeout(self.ctx, ctypes.byref(tv))

    # --- motor -------------------------------------------------------------------------------------------------------
    def tilt_state(self):
        """Raw state bytes (12, as fakenect-record stores them) after asking the device for it."""
        self._check("freenect_update_tilt_state", self.lib.freenect_update_tilt_state(self.dev))
        state = self.lib.freenect_get_tilt_state(self.dev)
        return ctypes.string_at(state, ctypes.sizeof(RawTiltState))

    def set_tilt(self, degrees):
        self._check("freenect_set_tilt_degs", self.lib.freenect_set_tilt_degs(self.dev, float(degrees)))

    def set_led(self, option):
        self._check("freenect_set_led", self.lib.freenect_set_led(self.dev, int(option)))

    def close(self):
        if self.dev:
            self.lib.freenect_close_device(self.dev)
            self.dev = ctypes.c_void_p()
        if self.ctx:
            self.lib.freenect_shutdown(self.ctx)
            self.ctx = ctypes.c_void_p()
