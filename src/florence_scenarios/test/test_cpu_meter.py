"""CpuMeter against a real XML-RPC server standing in for the master and the nodes (no rospy)."""

import os
import threading
import time
from socketserver import ThreadingMixIn
from xmlrpc.server import SimpleXMLRPCServer

import pytest
from florence_scenarios.cpu import CpuMeter

pytestmark = pytest.mark.unit


class _ThreadingServer(ThreadingMixIn, SimpleXMLRPCServer):
    daemon_threads = True


@pytest.fixture
def master():
    """A master whose getSystemState takes 20 ms (a loaded master), listing two nodes that both
    answer getPid with this process's pid."""
    server = _ThreadingServer(("127.0.0.1", 0), logRequests=False, allow_none=True)
    uri = f"http://127.0.0.1:{server.server_address[1]}/"

    def get_system_state(caller):
        time.sleep(0.02)
        return 1, "", [[["/scan", ["/laser", "/tracker"]]], [], []]

    server.register_function(get_system_state, "getSystemState")
    server.register_function(lambda caller, name: (1, "", uri), "lookupNode")
    server.register_function(lambda caller: (1, "", os.getpid()), "getPid")
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield uri
    server.shutdown()
    server.server_close()


def test_a_sample_reads_the_cpu_time_of_every_node(master):
    sample = CpuMeter(master).sample()
    assert set(sample) == {"/laser", "/tracker"}
    assert sample["/laser"][os.getpid()] > 0.0


def test_samples_from_several_threads_while_the_meter_runs_never_collide(master):
    # the demo samples from its main thread (just before it kills a node) while the meter's thread
    # samples every period; both go through one HTTP connection to the master
    meter = CpuMeter(master, period=0.005).start()
    errors = []

    def sample_often():
        for _ in range(15):
            try:
                meter.sample()
            except Exception as e:  # noqa: BLE001 - any error is the failure under test
                errors.append(f"{type(e).__name__}: {e}")

    threads = [threading.Thread(target=sample_often) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30.0)
    last = meter.stop()
    assert errors == [] and meter.error is None, errors or meter.error
    assert os.getpid() in last["/tracker"]
