"""sim_now.catch_up: a recorder that lags behind the simulation is waited for, not judged early."""

import time

import pytest

from florence_common.processes import ProcessError
from florence_eval import sim_now

pytestmark = pytest.mark.unit


def test_catch_up_waits_for_the_recorder_to_reach_the_present(monkeypatch):
    monkeypatch.setattr(sim_now, "present", lambda timeout=30.0: 98.6)
    start = time.monotonic()

    def recorded():  # a recorder 8 simulated s behind, reading 40 s of backlog per wall second
        return 90.6 + 40.0 * (time.monotonic() - start)

    assert sim_now.catch_up(recorded, timeout=10.0) == 98.6
    assert recorded() >= 98.6 - sim_now.TOLERANCE


def test_catch_up_tolerates_one_odometry_period(monkeypatch):
    monkeypatch.setattr(sim_now, "present", lambda timeout=30.0: 50.0)
    assert sim_now.catch_up(lambda: 50.0 - sim_now.TOLERANCE / 2, timeout=0.5) == 50.0


def test_catch_up_names_what_it_waited_for(monkeypatch):
    monkeypatch.setattr(sim_now, "present", lambda timeout=30.0: 12.0)
    with pytest.raises(ProcessError, match=r"ground truth to reach simulated 12\.00 s"):
        sim_now.catch_up(lambda: 11.0, timeout=0.3)
