"""atomic_write: the old file or the new one, never a broken one, and no temporary left."""

import os
import signal
import subprocess
import sys

import pytest

from florence_common.files import atomic_write

pytestmark = pytest.mark.unit


def test_writes_and_replaces(tmp_path):
    path = tmp_path / "hotspots.yaml"
    atomic_write(str(path), b"a: 1\n")
    atomic_write(str(path), b"a: 2\n")
    assert path.read_bytes() == b"a: 2\n"
    assert oct(path.stat().st_mode & 0o777) == "0o644"
    assert [p.name for p in tmp_path.iterdir()] == ["hotspots.yaml"]


def test_a_failed_write_leaves_the_old_file(tmp_path):
    path = tmp_path / "map.yaml"
    atomic_write(str(path), b"old")

    with pytest.raises(TypeError):
        atomic_write(str(path), object())  # not bytes: fails inside the write
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["map.yaml"]


def test_killed_writers_leave_old_or_new(tmp_path):
    """SIGKILL a process that rewrites the file in a loop: every time, the file is whole."""
    path = tmp_path / "data.bin"
    old, new = b"o" * 200_000, b"n" * 300_000
    atomic_write(str(path), old)
    script = ("from florence_common.files import atomic_write\n"
              f"while True:\n    atomic_write({str(path)!r}, b'n' * 300_000)\n")
    for _ in range(5):
        proc = subprocess.Popen([sys.executable, "-c", script], env=os.environ)
        try:
            proc.wait(0.3)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
        assert path.read_bytes() in (old, new)
