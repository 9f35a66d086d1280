"""CPU time of every node of the running system, from /proc through the master (no rospy).

    meter = CpuMeter(master_uri, exclude={"/florence_demo"}).start()   # samples every ``period`` s
    first = meter.sample()      # {node: {pid: CPU s}}
    ...                         # a node restarted meanwhile shows up with its new pid too
    meter.sample()              # e.g. just before a node is killed
    last = meter.stop()         # the latest CPU time of every pid seen (a dead one keeps its last)

florence_scenarios.judge.cpu_per_node turns two samples into cores at real time.
"""

import copy
import http.client
import threading
import xmlrpc.client

import rosgraph
from florence_eval.metrics import cpu_seconds, node_pid


class CpuMeter:
    def __init__(self, master_uri, exclude=(), period=3.0):
        self.master = rosgraph.Master("/cpu_meter", master_uri=master_uri)
        self.uri = master_uri
        self.exclude = set(exclude)
        self.period = period  # [s, wall]
        self.latest = {}  # node -> {pid: CPU s}
        self.pids = {}  # node -> pid it had when last looked up
        # one sample at a time (it guards pids and latest too): the rosgraph.Master handle is one
        # xmlrpc.client.ServerProxy, one HTTP connection; two threads on it at once raise
        # http.client.CannotSendRequest ("Request-sent")
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = None
        self.error = None  # the last error of the meter's own thread, if any

    def nodes(self):
        """Names of every node registered with the master (publishers, subscribers, services)."""
        names = set()
        for kind in self.master.getSystemState():
            for _, nodes in kind:
                names.update(nodes)
        return sorted(names - self.exclude)

    def sample(self):
        """Read the CPU time of every node now; returns a copy of {node: {pid: CPU s}}. Safe to call
        from any thread while the meter's own thread samples."""
        with self.lock:
            for node in self.nodes():
                try:
                    self.pids[node] = node_pid(self.uri, node, caller="/cpu_meter")
                except Exception:  # noqa: BLE001 - a node that just went away
                    continue
            for node, pid in self.pids.items():
                try:
                    self.latest.setdefault(node, {})[pid] = cpu_seconds(pid)
                except (OSError, IndexError, ValueError):
                    continue  # gone: its last sample stands
            return copy.deepcopy(self.latest)

    def _run(self):
        while not self._stop.wait(self.period):
            try:
                self.sample()
            except (OSError, xmlrpc.client.Error, http.client.HTTPException) as e:  # master busy or going down
                self.error = f"{type(e).__name__}: {e}"

    def start(self):
        self._thread = threading.Thread(target=self._run, name="cpu meter", daemon=True)
        self._thread.start()
        return self

    def stop(self):
        self._stop.set()
        if self._thread is not None:
            self._thread.join(10.0)
        return self.sample()
