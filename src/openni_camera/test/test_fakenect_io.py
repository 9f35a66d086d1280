"""fakenect dumps, the USB diagnosis and the worker's output (ROS-free, no device)."""

import os
import threading
import time

import numpy as np
import pytest

from openni_camera import fakenect_dump as fd
from openni_camera import kinect, usb, worker

pytestmark = pytest.mark.unit


def small_dump(path, frames=3):
    w = fd.DumpWriter(path)
    names = []
    for k in range(frames):
        t = 1000.0 + k / 30
        names.append(w.depth(t, 1000 * k, np.full((480, 640), 700 + k, dtype=np.uint16)))
        names.append(w.rgb(t + 0.001, 1000 * k, np.full((480, 640, 3), 10 * k, dtype=np.uint8)))
        names.append(w.tilt_state(t + 0.002, 1000 * k, (1, 819, -3), 16, 0))
    w.close()
    return names


def test_writer_writes_what_fakenect_record_writes(tmp_path):
    names = small_dump(tmp_path / "d")
    index = (tmp_path / "d" / fd.INDEX).read_text()
    assert index == "".join(f"{n}\n" for n in names)
    assert names[:3] == ["d-1000.000000-0.pgm", "r-1000.001000-0.ppm", "a-1000.002000-0.dump"]
    depth = (tmp_path / "d" / names[0]).read_bytes()
    assert depth.startswith(b"P5 640 480 65535\n") and len(depth) == 17 + 640 * 480 * 2
    assert np.frombuffer(depth[17:], "<u2")[0] == 700  # the raw buffer, little-endian as fakenect copies it
    state = (tmp_path / "d" / names[2]).read_bytes()
    assert len(state) == 12 and fd.parse_tilt_state(state) == ((1, 819, -3), 16, 0)
    with pytest.raises(FileExistsError):
        fd.DumpWriter(tmp_path / "d")  # as fakenect-record, never over a recording
    with pytest.raises(ValueError, match="640x480"):
        fd.depth_bytes(np.zeros((240, 320)))


def test_repeats_are_links(tmp_path):
    w = fd.DumpWriter(tmp_path / "d")
    first = w.depth(1.0, 0, np.zeros((480, 640), np.uint16))
    again = w.again(first, 1.5, 500)
    w.close()
    assert again == "d-1.500000-500.pgm" and os.readlink(tmp_path / "d" / again) == first
    assert fd.check(tmp_path / "d").counts["d"] == 2


def test_check_finds_what_would_stop_fakenect(tmp_path):
    path = tmp_path / "d"
    names = small_dump(path)
    os.unlink(path / names[3])  # a missing depth frame: fakenect would exit(1) there
    (path / names[4]).write_bytes(fd.RGB_HEADER + b"\0" * 100)  # a truncated colour frame
    (path / names[5]).write_bytes(b"\0" * 8)  # an accelerometer record of the wrong size
    with open(path / fd.INDEX, "a") as f:
        f.write("x-not-a-record\nd-999.000000-0.pgm\n")
    (path / "d-999.000000-0.pgm").write_bytes((path / names[0]).read_bytes())  # time going back
    result = fd.check(path)
    assert result.counts == {"d": 2, "r": 2, "a": 2}
    text = "\n".join(result.problems)
    for words in ("missing", "bytes of data", "8 bytes, not 12", "not a record name", "before the previous"):
        assert words in text, text
    assert len(result.problems) == 5
    assert result.duration == pytest.approx(2 / 30 + 0.002, abs=1e-6)


def test_replayable_leaves_out_the_bad_records(tmp_path):
    path = tmp_path / "d"
    names = small_dump(path)
    folder, result = fd.replayable(path, tmp_path / "scratch")
    assert folder == str(path) and not result.problems  # a good dump is played as it is
    os.unlink(path / names[3])
    folder, result = fd.replayable(path, tmp_path / "scratch")
    assert folder == str(tmp_path / "scratch")
    listed = (tmp_path / "scratch" / fd.INDEX).read_text().split()
    assert listed == [n for n in names if n != names[3]]
    assert all(os.path.realpath(tmp_path / "scratch" / n) == str(path / n) for n in listed)


def test_not_a_dump(tmp_path):
    with pytest.raises(fd.DumpError, match=r"no INDEX\.txt"):
        fd.replayable(tmp_path, tmp_path / "s")
    (tmp_path / fd.INDEX).write_text("d-1.000000-0.pgm\n")
    with pytest.raises(fd.DumpError, match="no usable record"):
        fd.replayable(tmp_path, tmp_path / "s")


# --- USB -------------------------------------------------------------------------------------------------------
def fake_usb(root, devices, driver=None):
    sysfs, dev = root / "sys", root / "dev"
    sysfs.mkdir()
    for i, product in enumerate(devices):
        d = sysfs / f"1-{i + 1}"
        d.mkdir()
        (d / "idVendor").write_text("045e\n")
        (d / "idProduct").write_text(f"{product:04x}\n")
        (d / "busnum").write_text("1\n")
        (d / "devnum").write_text(f"{i + 4}\n")
        (dev / "001").mkdir(parents=True, exist_ok=True)
        (dev / "001" / f"{i + 4:03d}").write_text("")
        if driver:
            iface = sysfs / f"1-{i + 1}:1.0"
            iface.mkdir()
            os.symlink(f"/sys/bus/usb/drivers/{driver}", iface / "driver")
    return str(sysfs), str(dev)


def test_usb_diagnosis(tmp_path):
    assert "no USB device list" in usb.diagnose("camera", sysfs=str(tmp_path / "none"))
    sysfs, dev = fake_usb(tmp_path, [])
    assert "no Kinect on USB" in usb.diagnose("camera", sysfs, dev)


@pytest.mark.parametrize("products, subdevice, words", [
    ([kinect.PRODUCT_MOTOR, kinect.PRODUCT_AUDIO], "camera", "12 V"),
    ([kinect.PRODUCT_CAMERA, kinect.PRODUCT_NO_MOTOR], "motor", "1473"),
    ([kinect.PRODUCT_CAMERA, kinect.PRODUCT_MOTOR], "motor", ""),
    ([kinect.PRODUCT_CAMERA], "camera", ""),
])
def test_usb_diagnosis_by_device(tmp_path, products, subdevice, words):
    sysfs, dev = fake_usb(tmp_path, products)
    text = usb.diagnose(subdevice, sysfs, dev, access=lambda *_: True)
    assert (words in text) if words else text == ""


def test_usb_permission_and_kernel_driver(tmp_path):
    (tmp_path / "a").mkdir()
    sysfs, dev = fake_usb(tmp_path / "a", [kinect.PRODUCT_CAMERA])
    text = usb.diagnose("camera", sysfs, dev, access=lambda *_: False)
    assert "no permission" in text and "plugdev" in text and usb.UDEV_RULE in text and "/001/004" in text
    (tmp_path / "b").mkdir()
    sysfs, dev = fake_usb(tmp_path / "b", [kinect.PRODUCT_CAMERA], driver="gspca_kinect")
    assert "gspca_kinect" in usb.diagnose("camera", sysfs, dev, access=lambda *_: True)


# --- the worker's output ------------------------------------------------------------------------------------------
def test_worker_output_never_waits_and_sends_the_newest():
    """The event loop hands frames over without waiting for the node: while nobody reads, newer frames replace
    older ones (counted as dropped); events are never dropped."""
    read_fd, write_fd = os.pipe()
    out = worker.Output(write_fd)
    big = b"\1" * (2 << 20)  # larger than the pipe: the writer thread blocks on it
    out.frame(worker.DEPTH, 1, big)
    time.sleep(0.2)
    start = time.monotonic()
    for k in range(2, 6):
        out.frame(worker.DEPTH, k, bytes([k]) * 10)
    out.event(worker.EVENT, {"event": "x"})
    assert time.monotonic() - start < 0.1
    got = []

    def read_all():
        with os.fdopen(read_fd, "rb") as f:
            while True:
                header = f.read(worker.HEADER.size)
                if len(header) < worker.HEADER.size:
                    return
                kind, ts, _host, dropped, size = worker.HEADER.unpack(header)
                got.append((kind, ts, dropped, len(f.read(size))))

    reader = threading.Thread(target=read_all, daemon=True)
    reader.start()
    deadline = time.monotonic() + 10
    while len(got) < 3 and time.monotonic() < deadline:
        time.sleep(0.02)
    os.close(write_fd)
    assert got[0] == (worker.DEPTH, 1, 0, len(big))
    assert got[1][:2] == (worker.EVENT, 0)
    assert got[2][:3] == (worker.DEPTH, 5, 3)  # frames 2, 3 and 4 dropped
