"""florence_harness.screen: XWD dumps read back pixel for pixel, and a screenshot of a real Xvfb."""

import struct

import numpy as np
import pytest

from florence_harness.screen import XWD_HEADER, VirtualScreen, read_xwd

pytestmark = pytest.mark.unit


def xwd(rgb, byte_order=0, ncolors=2, name=b"test\0"):
    """An XWD dump of ``rgb`` as a 24-bit TrueColor screen writes it (rows padded by 8 bytes)."""
    height, width, _ = rgb.shape
    bytes_per_line = 4 * width + 8
    header_size = XWD_HEADER.size + len(name)
    header = XWD_HEADER.pack(header_size, 7, 2, 24, width, height, 0, byte_order, 32, byte_order, 32, 32,
                             bytes_per_line, 4, 0xFF0000, 0xFF00, 0xFF, 8, 256, ncolors, width, height, 0, 0, 0)
    pixels = np.zeros((height, bytes_per_line), np.uint8)
    quad = np.zeros((height, width, 4), np.uint8)
    if byte_order == 0:
        quad[..., 0], quad[..., 1], quad[..., 2] = rgb[..., 2], rgb[..., 1], rgb[..., 0]
    else:
        quad[..., 1], quad[..., 2], quad[..., 3] = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    pixels[:, : 4 * width] = quad.reshape(height, -1)
    return header + name + b"\x00" * (12 * ncolors) + pixels.tobytes()


@pytest.mark.parametrize("byte_order", [0, 1])
def test_xwd_pixels_come_back_in_place_and_colour(byte_order):
    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 256, (5, 7, 3), dtype=np.uint8)
    assert np.array_equal(read_xwd(xwd(rgb, byte_order)), rgb)


def test_xwd_that_is_not_a_dump_or_truncated_is_refused():
    with pytest.raises(ValueError, match="not an XWD"):
        read_xwd(b"\x00" * 10)
    with pytest.raises(ValueError, match="truncated"):
        read_xwd(xwd(np.zeros((4, 4, 3), np.uint8))[:-20])
    eight_bit = bytearray(xwd(np.zeros((2, 2, 3), np.uint8)))
    struct.pack_into(">I", eight_bit, 44, 8)  # bits_per_pixel
    with pytest.raises(ValueError, match="unsupported"):
        read_xwd(bytes(eight_bit))


def test_virtual_screen_screenshot_has_the_screen_size():
    with VirtualScreen(320, 200) as screen:
        assert screen.display.startswith(":")
        shot = screen.screenshot()
    assert shot.shape == (200, 320, 3) and shot.dtype == np.uint8
