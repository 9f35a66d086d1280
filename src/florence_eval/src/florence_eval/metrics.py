"""What a bench measures of the processes it starts: a node's process id (through the master)
and its CPU time (from /proc); and the wall and CPU time of blocks of code it runs itself.
Linux only; no rospy."""

import os
import time
import xmlrpc.client

import numpy as np


def node_pid(master_uri, name, caller="/bench"):
    """Process id of the ROS node ``name`` (e.g. "/move_base") registered with the master at
    ``master_uri``."""
    master = xmlrpc.client.ServerProxy(master_uri)
    _, _, uri = master.lookupNode(caller, name)
    return xmlrpc.client.ServerProxy(uri).getPid(caller)[2]


def cpu_seconds(pid):
    """User + system CPU time [s] of process ``pid`` so far."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def memory_kib(pid):
    """{"VmRSS": resident set, "VmHWM": its peak} [KiB] of process ``pid``."""
    fields = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                fields[key] = int(value.split()[0])
    return fields


class Stopwatch:
    """Wall-clock and CPU time [ms] of each timed block, kept apart.

    On a loaded machine the wall time of a call includes the time other processes held the core;
    the calling thread's CPU time does not, so a bench reports both (``summary()``)::

        watch = Stopwatch()
        with watch:
            work()
        watch.summary()  # {"p50_ms", "p99_ms", "cpu_p50_ms", "cpu_p99_ms", "n"}
    """

    def __init__(self):
        self.wall_ms, self.cpu_ms = [], []

    def __enter__(self):
        self._wall, self._cpu = time.perf_counter(), time.thread_time()
        return self

    def __exit__(self, *exc):
        self.wall_ms.append(1000.0 * (time.perf_counter() - self._wall))
        self.cpu_ms.append(1000.0 * (time.thread_time() - self._cpu))
        return False

    def summary(self):
        """Median and 99th percentile of the wall and CPU times [ms], and the number of blocks."""
        if not self.wall_ms:
            return {"n": 0}
        wall, cpu = np.asarray(self.wall_ms), np.asarray(self.cpu_ms)
        return {"p50_ms": float(np.percentile(wall, 50)), "p99_ms": float(np.percentile(wall, 99)),
                "cpu_p50_ms": float(np.percentile(cpu, 50)), "cpu_p99_ms": float(np.percentile(cpu, 99)),
                "n": len(wall)}
