"""Colour signatures and the gallery of persistent ids."""

import numpy as np
import pytest

from user_tracker_ni import reid

pytestmark = pytest.mark.unit


def shirt(rgb, n=300, noise=12, seed=0):
    rng = np.random.default_rng(seed)
    return np.clip(np.asarray(rgb) + rng.normal(0, noise, (n, 3)), 0, 255).astype(np.uint8)


def test_same_shirt_is_close_and_different_shirts_are_far():
    red_a, red_b = reid.signature(shirt((200, 30, 30), seed=1)), reid.signature(shirt((190, 35, 25), seed=2))
    blue = reid.signature(shirt((30, 60, 200), seed=3))
    assert reid.distance(red_a, red_b) < 0.3
    assert reid.distance(red_a, blue) > 0.8


def test_brightness_changes_matter_little_and_greys_are_told_apart():
    red = reid.signature(shirt((200, 30, 30)))
    darker_red = reid.signature(shirt((120, 18, 18)))
    assert reid.distance(red, darker_red) < 0.35
    white, black = reid.signature(shirt((235, 235, 235), noise=5)), reid.signature(shirt((25, 25, 25), noise=5))
    assert reid.distance(white, black) > 0.8


def test_signature_of_nothing_is_none_and_sums_to_one():
    assert reid.signature(np.zeros((0, 3), np.uint8)) is None
    sig = reid.signature(shirt((10, 200, 10)))
    assert sig.shape == (reid.SIZE,) and sig.sum() == pytest.approx(1.0)


def test_gallery_identifies_excludes_held_ids_and_enrolls():
    g = reid.Gallery(threshold=0.4)
    red, blue = reid.signature(shirt((200, 30, 30))), reid.signature(shirt((30, 60, 200)))
    r, b = g.enroll(red), g.enroll(blue)
    assert g.identify(reid.signature(shirt((195, 28, 35), seed=4)))[0] == r
    assert g.identify(red, exclude={r})[0] is None, "an id held by a live track is not handed out twice"
    assert g.identify(reid.signature(shirt((30, 200, 30))))[0] is None
    unknown = g.enroll(None)
    assert g.identify(red, exclude={r, b})[0] is None
    g.update(unknown, reid.signature(shirt((240, 240, 20))))
    assert g.identify(reid.signature(shirt((235, 235, 25), seed=5)))[0] == unknown
