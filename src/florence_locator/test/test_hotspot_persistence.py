"""setHotspot's file survives a crash: a real process rewriting the hotspots file through
Hotspots.set is killed with SIGKILL in the middle of its writes, again and again; every time the
file loads whole, with the old hotspots or the new ones, never a broken file (the locator would
not start on one). The file is made large (1000 hotspots, ~40 kB) so that many kills land inside
a write; a plain open()/write() instead of the atomic rename fails this test (checked when it
was written: a truncated file on the first or second kill)."""

import os
import random
import signal
import subprocess
import sys
import time

import pytest
from florence_locator.places import Hotspots, Pose

pytestmark = pytest.mark.unit

N = 1000
WRITER = """
import sys
from florence_locator.places import Hotspots, Pose
path, n = sys.argv[1], int(sys.argv[2])
spots = Hotspots.load(path)
k = 0
print("ready", flush=True)
while True:
    k += 1
    # every write changes every hotspot, so that a mix of two writes could not pass as one
    for i in range(n):
        spots.set(f"spot_{i}", Pose(float(k), float(i), 0.5), save=False)
    spots.set("generation", Pose(float(k), 0.0, 0.0))
"""


def _consistent(spots):
    """(whole, generation): every hotspot of one write; generation 0 is the file before any write."""
    gen = spots.get("generation")
    values = {p.x for label, p in spots.items() if label.startswith("spot_")}
    count = sum(1 for label in spots.labels() if label.startswith("spot_"))
    return count == N and gen is not None and values == {gen.x}, (gen.x if gen else None)


def test_a_killed_writer_leaves_the_old_or_the_new_file(tmp_path):
    path = tmp_path / "hotspots.yaml"
    first = Hotspots({f"spot_{i}": Pose(0.0, float(i), 0.5) for i in range(N)} | {"generation": Pose(0, 0, 0)},
                     path)
    first.set("generation", Pose(0.0, 0.0, 0.0))  # the file before any writer ran
    rng = random.Random(7)
    generations = set()
    for kill in range(6):
        before = path.stat().st_mtime_ns
        proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path), str(N)], env=os.environ,
                                stdout=subprocess.PIPE, text=True)
        try:
            assert proc.stdout.readline().strip() == "ready"
            # once a write has finished (whatever the machine's load), kill somewhere in the following ones
            t0 = time.monotonic()
            deadline = t0 + 60.0
            while path.stat().st_mtime_ns == before and time.monotonic() < deadline:
                time.sleep(0.005)
            period = time.monotonic() - t0
            time.sleep(rng.uniform(0.0, 2.0 * period))
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait(10)
            proc.stdout.close()
        loaded = Hotspots.load(path)  # a broken file raises YamlError here
        whole, generation = _consistent(loaded)
        assert whole, f"kill {kill}: the file holds a mix of writes (generation {generation})"
        generations.add(generation)
    assert len(generations) >= 2, f"the writers never finished a write before being killed: {generations}"
