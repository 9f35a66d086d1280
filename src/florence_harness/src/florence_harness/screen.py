"""A virtual X screen for tests of graphical tools (rviz), and screenshots of it.

Xvfb writes its framebuffer to a file in X Window Dump (XWD) format when started with ``-fbdir``;
:func:`read_xwd` reads such a dump into an RGB array, so no screenshot tool is needed.
"""

import contextlib
import os
import struct
import tempfile

import numpy as np

from florence_common.processes import ManagedProcess, wait_for

XWD_HEADER = struct.Struct(">25I")  # XWDFileHeader: 25 big-endian CARD32
XWD_COLOR_SIZE = 12  # XWDColor: pixel CARD32, red, green, blue CARD16, flags, pad CARD8


def read_xwd(data):
    """An XWD dump of a 24-bit TrueColor screen with 32 bits per pixel (what Xvfb writes) as an
    (height, width, 3) uint8 RGB array. ValueError for any other layout."""
    if len(data) < XWD_HEADER.size:
        raise ValueError(f"not an XWD dump: {len(data)} bytes")
    (header_size, version, pixmap_format, depth, width, height, _xoffset, byte_order, _unit, _bit_order,
     _pad, bits_per_pixel, bytes_per_line, visual_class, red_mask, green_mask, blue_mask, _bits_per_rgb,
     _colormap_entries, ncolors, *_window) = XWD_HEADER.unpack_from(data)
    if version != 7 or pixmap_format != 2 or bits_per_pixel != 32 or depth != 24:
        raise ValueError(f"unsupported XWD layout: version {version}, format {pixmap_format}, "
                         f"depth {depth}, {bits_per_pixel} bits per pixel")
    if (red_mask, green_mask, blue_mask) != (0xFF0000, 0xFF00, 0xFF) or visual_class not in (4, 5):
        raise ValueError("unsupported XWD visual: only 8-bit TrueColor/DirectColor RGB masks")
    offset = header_size + ncolors * XWD_COLOR_SIZE
    if len(data) < offset + bytes_per_line * height:
        raise ValueError("XWD dump is truncated")
    rows = np.frombuffer(data, np.uint8, count=bytes_per_line * height, offset=offset).reshape(height, bytes_per_line)
    pixels = rows[:, : 4 * width].reshape(height, width, 4)
    # a 32-bit pixel 0x00RRGGBB: least significant byte first is B, G, R, X; most significant first X, R, G, B
    order = [2, 1, 0] if byte_order == 0 else [1, 2, 3]
    return np.ascontiguousarray(pixels[..., order])


class VirtualScreen:
    """Xvfb on a free display number with its framebuffer in a file; ``display`` for DISPLAY."""

    def __init__(self, width=1280, height=800):
        self.size = (width, height)
        self._dir = tempfile.TemporaryDirectory(prefix="florence-xvfb-")
        self.proc = None
        self.display = None

    def start(self, timeout=20.0):
        for number in range(90, 140):
            if os.path.exists(f"/tmp/.X11-unix/X{number}") or os.path.exists(f"/tmp/.X{number}-lock"):
                continue
            self.proc = ManagedProcess(["Xvfb", f":{number}", "-screen", "0", f"{self.size[0]}x{self.size[1]}x24",
                                        "-fbdir", self._dir.name, "-nolisten", "tcp"], name=f"Xvfb:{number}")
            try:
                wait_for(lambda n=number: not self.proc.running() or os.path.exists(f"/tmp/.X11-unix/X{n}"),
                         timeout, what=f"Xvfb on display :{number}")
            except Exception:
                self.proc.stop()
                raise
            if self.proc.running():
                self.display = f":{number}"
                return self
            self.proc.stop()  # lost the race for that display number: try the next
        raise RuntimeError("no free X display number for Xvfb in :90..:139")

    def screenshot(self):
        """The screen now, as an (height, width, 3) uint8 RGB array."""
        with open(os.path.join(self._dir.name, "Xvfb_screen0"), "rb") as f:
            return read_xwd(f.read())

    def stop(self):
        if self.proc is not None:
            self.proc.stop()
        with contextlib.suppress(OSError):
            self._dir.cleanup()

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
        return False
