"""Benchmark of the two serial drivers.

1. Decoding one full MD frame of the URG-04LX (every measurable step, AMIN..AMAX =
   44..725 from its PP answer: 682 ranges, 3-character encoding, 33 blocks with
   sums): reply split, every sum checked, values decoded, error codes mapped.
   Target: <= 1 ms.
2. CPU seconds per second of each driver node, at its working rate, against its
   emulator on a pseudo-terminal and a private ROS master: turtlebot_node with
   the Create streaming group 6 every 15 ms and publishing at 10 Hz;
   hokuyo_node with the URG-04LX scanning at 10 Hz (the launch files' +-1.570 rad,
   511 ranges). The CPU time is read from /proc of the node's process; a
   `rostopic hz` subscribes to every data topic so messages are really serialised.

Run after `source devel/setup.bash`:  /usr/bin/python3 bench/drivers.py
Writes bench/results/drivers.json.
"""

import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from florence_eval.metrics import cpu_seconds
from hokuyo_node.urg_emulator import STEPS, UrgEmulator
from turtlebot_node.create_emulator import CreateEmulator

from florence_common.processes import ManagedProcess, RosMaster, wait_for
from florence_common.pty_device import PtyDevice
from hokuyo_node import scip

RESULTS = Path(__file__).resolve().parent / "results" / "drivers.json"


def executable(package, relative):
    """Path of a package's executable (rospkg: wherever the package is)."""
    import rospkg

    return str(Path(rospkg.RosPack().get_path(package)) / relative)


def md_frame():
    """One MD scan reply of all measurable steps, as the emulator sends it."""
    emulator = UrgEmulator(ranges=lambda _now: [(37 * i) % 5600 for i in range(STEPS)])
    emulator.feed(scip.measure_command(44, 725), 0.0)
    raw = emulator.poll(1.0)
    assert raw.endswith(b"\n\n")
    return raw


def bench_decode(repeats=3000):
    raw = md_frame()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        reply = scip.parse_reply(raw)
        scip.check_status(reply, b"99")
        _, values = scip.parse_scan(reply, 3)
        scip.ranges_to_metres(values, 20)
        times.append(time.perf_counter() - start)
    return {"frame_bytes": len(raw), "ranges": int(values.size), "repeats": repeats,
            "median_ms": 1000 * statistics.median(times), "mean_ms": 1000 * statistics.fmean(times),
            "p99_ms": 1000 * sorted(times)[int(0.99 * repeats)], "target_ms": 1.0}


def bench_node(master, name, argv, core, ready, count, topics, seconds=10.0):
    """CPU use of a driver node over ``seconds`` once ``ready()``; ``count()`` counts device messages.
    A `rostopic hz` subscribes to each of ``topics`` so the node really serialises what it publishes."""
    with tempfile.TemporaryDirectory() as tmp:
        link = os.path.join(tmp, "tty")
        device = PtyDevice(core, link=link).start()
        proc = ManagedProcess(["/usr/bin/python3", *argv, f"_port:={link}"], env=master.env(), name=name)
        listeners = [ManagedProcess(["rostopic", "hz", topic], env=master.env(), name=f"hz {topic}")
                     for topic in topics]
        try:
            wait_for(ready, 60.0, what=f"{name} talking to its emulator")
            time.sleep(1.0)  # let start-up work settle before measuring
            cpu0, t0 = cpu_seconds(proc.pid), time.monotonic()
            count0 = count()
            time.sleep(seconds)
            cpu1, t1 = cpu_seconds(proc.pid), time.monotonic()
            count1 = count()
        finally:
            for listener in listeners:
                listener.stop()
            proc.stop()
            device.close()
    return {"cpu_s_per_s": (cpu1 - cpu0) / (t1 - t0), "wall_s": t1 - t0,
            "device_messages_per_s": (count1 - count0) / (t1 - t0)}


def main():
    results = {"md_decode": bench_decode()}
    d = results["md_decode"]
    print(f"MD frame decode ({d['ranges']} ranges, {d['frame_bytes']} bytes): median {d['median_ms']:.3f} ms, "
          f"p99 {d['p99_ms']:.3f} ms (target <= 1 ms)")
    master = RosMaster().start()
    try:
        create = CreateEmulator()
        frames = []
        stream_frame = create._stream_frame

        def counted_frame():
            frames.append(1)
            return stream_frame()

        create._stream_frame = counted_frame
        results["turtlebot_node"] = bench_node(
            master, "turtlebot_node", [executable("turtlebot_node", "scripts/turtlebot_node.py"),
                                       "__name:=turtlebot_node", "__ns:=/bench"],
            create, lambda: create.streaming and len(frames) > 10, lambda: len(frames),
            ["/bench/odom", "/bench/turtlebot_node/sensor_state", "/bench/imu/data"])
        urg = UrgEmulator()
        results["hokuyo_node"] = bench_node(
            master, "hokuyo_node", [executable("hokuyo_node", "nodes/hokuyo_node"), "__name:=hokuyo_node",
                                    "__ns:=/bench", "_min_ang:=-1.570", "_max_ang:=1.570"],
            urg, lambda: urg.scans_sent > 5, lambda: urg.scans_sent, ["/bench/scan"])
    finally:
        master.stop()
    for name in ("turtlebot_node", "hokuyo_node"):
        r = results[name]
        print(f"{name}: {100 * r['cpu_s_per_s']:.1f}% of one core, {r['device_messages_per_s']:.1f} device "
              f"messages/s (stream frames / scans)")
    results["machine"] = {"cpus": os.cpu_count(), "python": sys.version.split()[0]}
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    tmp = RESULTS.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(results, indent=2) + "\n")
    os.replace(tmp, RESULTS)
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
