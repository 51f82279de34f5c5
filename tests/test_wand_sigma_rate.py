"""``pose_graph(..., sigma_rate=r)``: the default sigma measured on frames 1 / r s apart, so it does not depend on
the capture rate (issue 25); the default (None) is the paper's per-frame form, unchanged."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data, wand


@pytest.fixture(scope="module")
def walk():
    return data.load("walk")


def test_the_default_sigma_at_a_rate_does_not_depend_on_the_capture_rate(walk):
    fast = walk.resample(walk.frame_time / 4)                # the same walk captured 4x as often
    per_frame = [wand.pose_graph(m).default_sigma for m in (walk, fast)]
    at_rate = [wand.pose_graph(m, sigma_rate=1.0 / walk.frame_time).default_sigma for m in (walk, fast)]
    assert per_frame[1] < 0.6 * per_frame[0]                 # the paper's form shrinks with the rate ...
    assert at_rate[1] == pytest.approx(at_rate[0], rel=0.05)  # ... the rate-independent one does not
    assert at_rate[0] == per_frame[0]                         # at the clip's own rate: the same table


def test_the_default_is_the_per_frame_form_and_sigma_rate_reaches_the_falloff(walk):
    a = wand.falloff(walk, 40)
    b = wand.falloff(walk, 40, sigma=wand.pose_graph(walk).default_sigma)
    assert np.array_equal(a, b)
    fast = walk.resample(walk.frame_time / 4)
    s = wand.pose_graph(fast, sigma_rate=1.0 / walk.frame_time).default_sigma
    assert np.array_equal(wand.falloff(fast, 160, sigma_rate=1.0 / walk.frame_time), wand.falloff(fast, 160, sigma=s))


@pytest.mark.parametrize("bad", [0, -30, float("nan"), float("inf")])
def test_a_bad_sigma_rate_is_refused_naming_it(walk, bad):
    with pytest.raises(ValueError, match="sigma_rate"):
        wand.pose_graph(walk, sigma_rate=bad)
