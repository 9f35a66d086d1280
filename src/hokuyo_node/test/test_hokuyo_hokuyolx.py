"""A third-party SCIP 2.0 implementation (hokuyolx, PyPI) reads our URG-04LX emulator.

hokuyolx talks SCIP 2.0 over TCP (Ethernet Hokuyos), so the emulator core, which
is transport-free, is served on a loopback socket here. hokuyolx's time
synchronisation and activate() first ask "%ST", a command of the UST series
the URG-04LX does not have, so they are not used; PP, VV and MD are.
"""

import select
import socket
import threading
import time
from itertools import islice

import pytest
from hokuyo_node.urg_emulator import STEPS, UrgEmulator
from hokuyolx import HokuyoLX

pytestmark = pytest.mark.protocol

PATTERN = [3 if i % 41 == 0 else 250 + 5 * i for i in range(STEPS)]  # [mm]


class TcpDevice:
    """Serve a device core to one TCP client (what PtyDevice does on a pty)."""

    def __init__(self, core):
        self.core = core
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        conn, _ = self.server.accept()
        with conn:
            while not self.stop.is_set():
                readable, _, _ = select.select([conn], [], [], 0.002)
                now = time.monotonic()
                out = b""
                if readable:
                    data = conn.recv(4096)
                    if not data:
                        return
                    out += self.core.feed(data, now)
                out += self.core.poll(now)
                if out:
                    conn.sendall(out)

    def close(self):
        self.stop.set()
        self.thread.join(5.0)
        self.server.close()


def test_hokuyolx_reads_parameters_and_continuous_scans_of_our_emulator():
    emulator = UrgEmulator(ranges=lambda _now: PATTERN, serial_number="H1234567")
    device = TcpDevice(emulator)
    laser = HokuyoLX(addr=("127.0.0.1", device.port), activate=False, info=True, tsync=False, convert_time=False,
                     timeout=5)
    try:
        assert (laser.dmin, laser.dmax, laser.ares, laser.amin, laser.amax, laser.aforw) == (20, 5600, 1024, 44,
                                                                                           725, 384)
        assert laser.version()["SERI"] == "H1234567"
        scans = list(islice(laser.iter_dist(scans=2, start=44, end=725), 2))
        assert [pending for _, _, pending in scans] == [1, 0]
        for scan, _, _ in scans:
            assert scan.tolist() == PATTERN[44:726]
    finally:
        laser.close()
        device.close()
