"""The calibration bench's offline run (florence_sim's core, the product's Calibrator, the Hokuyo
upside down): a +5 % gyro error comes back within 1 %, and the corrected gyro within 1 % of 1."""

import pytest
from florence_eval.calibration_offline import calibrate, corrected_error

pytestmark = pytest.mark.unit


def test_offline_calibration_recovers_the_injected_error():
    first = calibrate(0.05, seed=2)
    assert first.error is None and first.turns == 4
    assert abs(first.gyro_factor_error) < 0.01, first
    second = calibrate(corrected_error(0.05, first.gyro_factor), seed=3)
    assert second.gyro_factor == pytest.approx(1.0, abs=0.01), second
