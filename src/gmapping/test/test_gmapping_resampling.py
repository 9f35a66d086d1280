"""Weights, effective sample size and systematic resampling."""

import math

import numpy as np
import pytest
from gmapping.resampling import entropy, normalise, systematic

pytestmark = pytest.mark.unit


def test_equal_weights_give_n_eff_n_and_full_entropy():
    w, neff = normalise(np.full(30, -123.0), 3.0)
    np.testing.assert_allclose(w, 1 / 30)
    assert neff == pytest.approx(30.0)
    assert entropy(w) == pytest.approx(math.log(30))


def test_ogain_smooths_the_likelihood():
    """weights exp(l / (ogain N)): a particle 90 log units better with N = 30, ogain 3 weighs e times more."""
    lw = np.zeros(30)
    lw[0] = 90.0
    w, neff = normalise(lw, 3.0)
    assert w[0] / w[1] == pytest.approx(math.e)
    assert neff < 30
    w_sharp, neff_sharp = normalise(lw, 0.1)
    assert w_sharp[0] > 0.999 and neff_sharp == pytest.approx(1.0, abs=1e-3)
    assert entropy(w_sharp) == pytest.approx(0.0, abs=0.01)


def test_systematic_draws_each_particle_floor_or_ceil_of_its_share():
    rng = np.random.default_rng(4)
    w = np.array([0.5, 0.25, 0.125, 0.0625, 0.0625, 0.0])
    for _ in range(200):
        idx = systematic(w, rng, 16)
        counts = np.bincount(idx, minlength=len(w))
        assert (counts >= np.floor(w * 16)).all() and (counts <= np.ceil(w * 16)).all()
        assert counts[-1] == 0 and (np.diff(idx) >= 0).all()
    idx = systematic(w, np.random.default_rng(5))
    assert len(idx) == len(w)


def test_systematic_is_unbiased():
    rng = np.random.default_rng(6)
    w = np.array([0.1, 0.2, 0.3, 0.4])
    counts = sum(np.bincount(systematic(w, rng, 3), minlength=4) for _ in range(20000))
    np.testing.assert_allclose(counts / counts.sum(), w, atol=0.005)
