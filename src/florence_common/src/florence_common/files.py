"""Files the workspace writes (maps, hotspots, reports) are written atomically: a reader, or a
process killed in the middle, sees the old file or the new one, never a half-written one."""

import os
import tempfile


def atomic_write(path, payload, mode=0o644):
    """Write bytes ``payload`` to ``path``: a temporary file in the same directory, flushed and
    fsynced, renamed over ``path`` (os.replace), then the directory fsynced so the rename
    survives a power cut."""
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(path)}.", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(payload)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    dir_fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)
