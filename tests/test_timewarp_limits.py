"""Guided warping for editors and hostile input (issue 13 items 6, 11, 12; issue 11 item 5): clear ValueErrors
before allocating, playback without speed pops, same-duration style warps, free length, backward warps."""
from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from timewarp_clips import airborne

from stagger_nb import data, timewarp, wand


@pytest.fixture(scope="module")
def walk():
    return data.load("walk")                       # 361 frames at 60 Hz


@pytest.mark.parametrize("call,name", [
    (lambda m: timewarp.guided_warp(m, m, 10 ** 9), "num_frames"),
    (lambda m: timewarp.guided_warp(m, m, 10 ** 6), "num_frames"),
    (lambda m: timewarp.guided_warp(m, m, 1000, upsample=10 ** 5), "upsample"),
    (lambda m: timewarp.linear_warp(m, 10 ** 7), "num_frames"),
    (lambda m: timewarp.guided_warp(m.slice(0, 1), m, 10), "m must have at least 2 frames"),
    (lambda m: timewarp.linear_warp(m.slice(0, 1), 10), "m must have at least 2 frames"),
    (lambda m: wand.falloff(m, 1, sigma=1e-300), "sigma"),
    (lambda m: timewarp.guided_warp(m, m, 100, speed_penalty=-1.0), "speed_penalty"),
])
def test_hostile_sizes_raise_before_allocating(walk, call, name):
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=name) as info:
            call(walk)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50e6, peak                       # refused before the big arrays (the wand builds its graph)
    msg = str(info.value)
    if "GiB" in msg:                                # size errors say how to shrink the request
        assert "slice" in msg or "resample" in msg or "fewer" in msg


def test_size_limit_is_what_the_tables_need(walk):
    n, r, s = walk.num_frames, walk.num_frames, 8
    est = timewarp.warp_memory(n, r, s, 1, 3 * walk.num_joints)
    t = timewarp.prepare_warp(walk, walk, s)
    real = t.scores.nbytes + t.X.nbytes + t.R.nbytes + 3 * 4 * r * (n + 2 * s)
    assert 0.9 * real <= est <= 1.5 * real


def test_speed_jumps_measure():
    ft = 1 / 30
    w = np.cumsum(np.r_[0.0, np.ones(10), 8 * np.ones(10)]) * ft       # speed 1 then 8: one jump of log 8
    j = timewarp.speed_jumps(w, ft)
    assert j.max() == pytest.approx(np.log(8)) and np.count_nonzero(j > 1e-12) == 1
    j120 = timewarp.speed_jumps(np.cumsum(np.r_[0.0, np.ones(40), 8 * np.ones(40)]) / 120, 1 / 120)
    assert np.count_nonzero(j120 > 1e-12) == 4      # measured over 1/30 s at any frame rate


def _smooth_enough(m, frac=0.65):
    num = int(round(frac * (m.num_frames - 1))) + 1
    _, warp = timewarp.guided_warp(m, m, num)
    j = timewarp.speed_jumps(warp, m.frame_time)
    _, paper = timewarp.guided_warp(m, m, num, speed_penalty=0.0, smoothing=0.0)
    return warp, j, timewarp.speed_jumps(paper, m.frame_time)


@pytest.mark.shared
def test_self_reference_compression_has_no_speed_pops_cmu_01_01():
    """Goal: 95th percentile of |change of log speed| per 1/30 s <= 0.12, max <= 0.25 (measured 0.090 / 0.166;
    the paper's objective unsmoothed: 0.69 / 2.08), and §4.1 still holds: airborne frames at speed ~1, the
    walking between jumps faster."""
    if not data.path("cmu_01_01").is_file():
        pytest.skip("data/cmu_01_01.bvh not prepared (python -m stagger_nb.data.prepare)")
    m = data.load("cmu_01_01").resample(1 / 30)
    warp, j, paper = _smooth_enough(m)
    assert np.percentile(paper, 95) > 0.3          # the bursts the measure is there to catch
    assert np.percentile(j, 95) <= 0.12 and j.max() <= 0.25, (np.percentile(j, 95), j.max())
    air = airborne(m)
    g = timewarp.speed_at_input_times(warp, m.frame_time, m.times)
    assert abs(np.median(g[air]) - 1.0) <= 0.15 and np.median(g[~air]) > 1.3


@pytest.mark.shared
def test_self_reference_compression_has_no_speed_pops_cmu_131(shared_motion):
    m = shared_motion("cmu_131_01_walk_startstop.bvh").resample(1 / 30)
    _, j, paper = _smooth_enough(m)
    assert np.percentile(paper, 95) > 0.3
    assert np.percentile(j, 95) <= 0.12 and j.max() <= 0.25, (np.percentile(j, 95), j.max())


def test_same_duration_style_warp_upsamples(walk):
    """A same-length warp against a different reference is no longer silently the identity (issue 11 item 5).

    The reference is the walk itself, its first half fast and its second slow: every pose of the cyclic walk is
    in it both fast and slow, so only the objective's preferences decide.  Eq. (1) (``weighting="output"``)
    prefers fewer output frames and plays part of it faster (input half at 45 % of the output); the default
    input-time weighting has no such preference and the kNN, finding more slow reference frames (the slow half
    is denser), keeps every pose at 1x: the identity (max deviation 2e-14 s).  The upsampling is what is
    tested here, with eq. (1)."""
    n, d = walk.num_frames, walk.duration
    ref, _ = timewarp.linear_warp(walk, n, keytimes=[(0.5 * d, 0.3 * d)])   # first half fast, second slow
    assert timewarp.required_upsample(n, n, reference_differs=True) == 2
    out, warp = timewarp.guided_warp(walk, ref, n, weighting="output")
    assert out.num_frames == n and warp[0] == 0.0 and warp[-1] == pytest.approx(d)
    assert np.abs(warp - walk.times).max() > 5 * walk.frame_time          # the timing changed
    t = timewarp.prepare_warp(walk, ref, 8, 2)
    sol = timewarp.solve_warp(t, n, speed_penalty=0.0, weighting="output")
    assert sol.cost < timewarp.path_cost(t.scores, 2 * np.arange(n), t.ends)     # better than the identity (eq. 1)
    # with itself as reference the only same-length answer is the identity (§3.1)
    _, same = timewarp.guided_warp(walk, walk, n)
    np.testing.assert_allclose(same, walk.times, atol=1e-9)


@pytest.mark.parametrize("factor,tol", [(1.0, 0.02), (1.5, 0.15), (1 / 1.5, 0.05)])
def test_free_length_scales_with_a_resampled_reference_cmu(factor, tol):
    # issue: the plain shortest path (sum of one score per output frame) played CMU 01_01 at 0.70x / 1.00x /
    # 0.49x its length for a self / 1.5x slower / 1.5x faster reference. Free length now follows the reference
    # (measured 1.000 / 1.686 / 0.669: the slow case stays ~12 % slower than asked, within the stated 15 %;
    # free_objective="input_time" gives 1.000 / 1.401 / 0.669).
    m = data.load("cmu_01_01").resample(1 / 30)
    n = m.num_frames
    ref = m if factor == 1.0 else timewarp.linear_warp(m, int(round((n - 1) * factor)) + 1)[0]
    out, warp = timewarp.guided_warp(m, ref, None)
    assert abs(out.num_frames / n - factor) <= tol * factor
    assert warp[0] == 0.0 and warp[-1] == pytest.approx(m.duration) and np.all(np.diff(warp) >= 0)


def test_free_length_follows_the_reference_speed(walk):
    n = walk.num_frames
    out, _ = timewarp.guided_warp(walk, walk, None)
    assert out.num_frames == n                              # its own timing: the same length
    fast, _ = timewarp.linear_warp(walk, n // 2)           # the reference plays twice as fast
    out, warp = timewarp.guided_warp(walk, fast, None)
    assert abs(out.num_frames - n // 2) <= 0.1 * n
    assert warp[0] == 0.0 and warp[-1] == pytest.approx(walk.duration) and np.all(np.diff(warp) > 0)


def test_backward_warp(walk):
    out, warp = timewarp.guided_warp(walk, walk, 200, backward=True)
    assert out.num_frames == 200 and warp[0] == pytest.approx(walk.duration) and warp[-1] == pytest.approx(0.0)
    assert np.all(np.diff(warp) < 0)
    _, warp2 = timewarp.guided_warp(walk, walk, 200, reverse=True)
    np.testing.assert_array_equal(warp, warp2)
    out, warp = timewarp.guided_warp(walk, walk, None, backward=True)
    assert warp[0] == pytest.approx(walk.duration) and np.all(np.diff(warp) < 0)


def test_box_average_is_the_mean_of_the_linear_interpolation():
    """The adaptive smoothing's prefix-sum average against a dense sampling of np.interp (naive reference)."""
    from stagger_nb.timewarp.postprocess import _box_average
    rng = np.random.default_rng(5)
    v = rng.normal(size=(12, 2))
    a = np.array([0.0, 0.3, 2.5, 7.9, 10.2])
    b = np.array([1.0, 4.7, 2.6, 11.0, 11.0])
    got = _box_average(v, a, b)
    for i in range(a.size):
        x = np.linspace(a[i], b[i], 200001)
        want = [np.interp(x, np.arange(12), v[:, c]).mean() for c in range(2)]
        np.testing.assert_allclose(got[i], want, atol=1e-5)   # the dense sampling's quadrature error


def test_tables_of_a_smaller_skip_are_a_slice_of_a_larger_ones():
    m = data.load("walk")
    m = m.slice(0, min(m.num_frames, 120))
    big = timewarp.prepare_warp(m, m, 10, 2, reverse=True)
    for s in (1, 4, 7, 10):
        small = timewarp.prepare_warp(m, m, s, 2, reverse=True)
        np.testing.assert_array_equal(timewarp.slice_tables(big, s).scores, small.scores)
    with pytest.raises(ValueError, match="skip"):
        timewarp.slice_tables(big, 11)
