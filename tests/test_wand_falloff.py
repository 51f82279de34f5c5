"""Falloff weights of §3.3: [0, 1], 1 at the edited frame, 0 at the most dissimilar frame of the range."""
import numpy as np
import pytest
from wand_motions import cyclic_motion

from stagger_nb import wand
from stagger_nb.wand import normalize_row


def test_normalize_row_closed_form():
    g = np.array([0.0, 1.0, 3.0, 2.0, 5.0, 4.0])
    # (g - min) / (g[2] - min), clipped: frames above the edited one saturate at 1
    assert np.allclose(normalize_row(g, 2), [0, 1 / 3, 1, 2 / 3, 1, 1], atol=1e-15)
    # range [1, 4): min over the range is g[1] = 1; outside the range 0
    assert np.allclose(normalize_row(g, 2, (1, 4)), [0, 0, 1, 0.5, 0, 0], atol=1e-15)
    # a constant row: every frame of the range is as similar as the frame itself
    assert np.array_equal(normalize_row(np.ones(4), 1, (1, 3)), [0, 1, 1, 0])
    # the frame at the bottom of the range selects only itself
    assert np.array_equal(normalize_row(np.array([1.0, 0.0, 2.0]), 1), [0, 1, 0])


def test_valley_without_repetitions():
    # two bumps: repetitions=False keeps the bump of frame 2 only, zero at its valley ends
    g = np.array([0.0, 2.0, 3.0, 2.0, 0.5, 1.0, 2.9, 1.0, 0.2])
    keep = normalize_row(g, 2)
    assert keep[6] > 0.9
    w = normalize_row(g, 2, repetitions=False)
    assert w[2] == 1.0 and w[4] == 0.0 and w[0] == 0.0
    assert np.all(w[5:] == 0.0)
    # left side scaled between g[0] = 0 and g[2] = 3, right side between g[4] = 0.5 and 3
    assert np.allclose(w[:5], [0, 2 / 3, 1, 1.5 / 2.5, 0], atol=1e-15)


@pytest.mark.shared
def test_falloff_properties_on_a_real_clip(shared_motion, rng):
    m = shared_motion("xia_angry_run.bvh")
    basis = wand.greens_basis(m)
    for f in rng.choice(m.num_frames, size=12, replace=False):
        for rng_ in (None, (max(0, f - 30), min(m.num_frames, f + 25))):
            w = wand.greens_falloff(basis, int(f), rng_)
            start, stop = rng_ or (0, m.num_frames)
            assert w.shape == (m.num_frames,)
            assert w[f] == 1.0
            assert np.all((w >= 0) & (w <= 1))
            assert w[start:stop].min() == 0.0   # the most dissimilar frame of the range
            assert np.all(w[:start] == 0) and np.all(w[stop:] == 0)
    # the one-call public form gives the same numbers as the cached basis
    assert np.array_equal(wand.falloff(m, 20), wand.greens_falloff(basis, 20))
    assert np.array_equal(wand.falloff(m, 20, basis=basis, frame_range=(0, 60)),
                          wand.greens_falloff(basis, 20, (0, 60)))
    assert np.array_equal(wand.greens_distance(basis, 20), 1.0 - wand.greens_falloff(basis, 20))


def test_falloff_rejects_bad_ranges():
    m = cyclic_motion(F=40, period=13)
    with pytest.raises(ValueError, match="frame_range"):
        wand.falloff(m, 5, frame_range=(10, 5))
    with pytest.raises(ValueError, match="frame_range"):
        wand.falloff(m, 5, frame_range=(0, 41))
    with pytest.raises(ValueError, match="outside frame_range"):
        wand.falloff(m, 5, frame_range=(10, 20))
    with pytest.raises(ValueError, match="frame"):
        wand.falloff(m, 40)
    with pytest.raises(ValueError, match="sigma"):
        wand.falloff(m, 4, sigma=0.0)
    with pytest.raises(ValueError, match="basis"):
        wand.falloff(m, 4, basis=wand.greens_basis(cyclic_motion(F=30)))


def test_static_clip_and_tiny_clips():
    from wand_motions import chain_skeleton

    from stagger_nb import Motion
    static = Motion(chain_skeleton(3), 0.1, np.zeros((10, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (10, 3, 1)))
    # all poses alike: the wand selects them all (no eigenpair carries weight, the row is exactly 0)
    assert np.array_equal(wand.falloff(static, 4), np.ones(10))
    m = cyclic_motion(F=5, period=9)
    for F in (2, 3):
        for method in ("dense", "sparse"):
            w = wand.falloff(m.slice(0, F), 0, method=method)
            assert w[0] == 1.0 and w[F - 1] == 0.0
    with pytest.raises(ValueError, match="2 frames"):
        wand.falloff(m.slice(0, 1), 0)


def test_repetitions_switch_on_a_periodic_motion():
    m = cyclic_motion(F=120, period=40, noise=0.01, seed=7)
    b = wand.greens_basis(m)
    w = wand.greens_falloff(b, 20)
    assert w[60] > 0.8 and w[100] > 0.8          # the same phase one and two periods later
    w1 = wand.greens_falloff(b, 20, repetitions=False)
    assert w1[20] == 1.0 and np.all(w1[60:] == 0)  # only the movement around frame 20
    nz = np.flatnonzero(w1)
    assert np.all(np.diff(nz) == 1)                # one contiguous piece


def test_normalize_row_invariants_property():
    from hypothesis import given, settings
    from hypothesis import strategies as st

    @settings(max_examples=200, deadline=None)
    @given(st.lists(st.floats(-1e6, 1e6, allow_nan=False), min_size=2, max_size=40), st.data())
    def check(values, data):
        g = np.array(values)
        F = len(g)
        start = data.draw(st.integers(0, F - 1))
        stop = data.draw(st.integers(start + 1, F))
        frame = data.draw(st.integers(start, stop - 1))
        reps = data.draw(st.booleans())
        w = normalize_row(g, frame, (start, stop), repetitions=reps)
        assert w[frame] == 1.0
        assert np.all((w >= 0) & (w <= 1))
        assert np.all(w[:start] == 0) and np.all(w[stop:] == 0)
        seg = g[start:stop]
        if reps and np.ptp(seg) > 0 and g[frame] > seg.min():
            assert w[start:stop].min() == 0.0        # 0 at the most dissimilar frame of the range
            # order-preserving below the frame's value: a larger g never gets a smaller weight
            below = np.flatnonzero((g <= g[frame]) & (np.arange(F) >= start) & (np.arange(F) < stop))
            o = below[np.argsort(g[below], kind="stable")]
            assert np.all(np.diff(w[o]) >= -1e-15)   # rounding of (g - min) / den only

    check()


def test_temporal_term_suppresses_repetitions():
    # §3.1: "it may be desirable to include the temporal distance between poses": with a strong temporal
    # term the later cycles are far away in the augmented pose space, and the falloff no longer rises
    # again there; it decays along the timeline like the Green's function of a chain (linearly, so not
    # to 0 at once: w[60] = 0.36, w[100] = 0.04 measured, vs 1.00 and 1.00 without the term)
    m = cyclic_motion(F=120, period=40, noise=0.01, seed=7)
    w0 = wand.falloff(m, 20)
    wt = wand.falloff(m, 20, time_weight=5.0)   # 5 units per second: one period (1.33 s) = 6.7 units
    assert w0[60] > 0.8 and w0[100] > 0.8
    assert wt[20] == 1.0 and wt[60] < 0.5 and wt[100] < 0.1
    assert np.all(np.diff(wt[25:]) <= 1e-3)     # no second peak after the edited frame (rounding slack)


@pytest.mark.shared
@pytest.mark.parametrize("name", ["bandai_walk.bvh", "xia_neutral_walk.bvh"])
def test_clipping_at_one_changes_the_weights_little(shared_motion, name):
    # The default spectrum (1/lambda - 1) has no maximum principle: some rows exceed their own value
    # elsewhere, and §3.3's scaling clips those frames to w = 1 (the full edit).  Measured: the largest
    # unclipped weight is 1.015 (bandai_walk) and 1.016 (xia_neutral_walk), so a clipped repetition would
    # get about the full edit anyway (the falloff module docstring quotes these figures)
    m = shared_motion(name)
    P = wand.greens_basis(m).matrix()
    d = np.diag(P)
    unclipped_max = (P.max(axis=1) - P.min(axis=1)) / (d - P.min(axis=1))
    assert np.any(unclipped_max > 1.0)           # clipping does happen with the defaults ...
    assert unclipped_max.max() <= 1.03           # ... by a few per cent at most (the docstring's bound)
