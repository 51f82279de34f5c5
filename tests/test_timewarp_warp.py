"""Public guided/linear warps, keytimes, post-processing (§3.4), cached tables, validation."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import timewarp
from stagger_nb.core.rotations import quat_angle
from stagger_nb.timewarp import dp


@pytest.fixture(scope="module")
def walk30(shared_motion):
    return shared_motion("bandai_walk.bvh")          # 195 frames at 30 Hz


@pytest.fixture(scope="module")
def walk_tables(walk30):
    return timewarp.prepare_warp(walk30, walk30, skip=8)


def test_m_equals_n_is_the_identity(walk30, walk_tables):
    out, warp = timewarp.guided_warp(walk30, walk30, walk30.num_frames, tables=walk_tables)
    np.testing.assert_allclose(warp, walk30.times, atol=1e-12)   # frame index * frame time, round-off
    assert quat_angle(out.local_quats, walk30.local_quats).max() < 1e-6  # slerp at t = 0: renormalisation only
    np.testing.assert_allclose(out.root_positions, walk30.root_positions, atol=1e-9)


@pytest.mark.parametrize("num_frames", [26, 60, 130, 194])
def test_discrete_solution_keeps_the_ends_and_respects_skip(walk30, walk_tables, num_frames):
    sol = timewarp.solve_warp(walk_tables, num_frames)
    assert sol.frames.size == num_frames
    assert sol.frames[0] == 0 and sol.frames[-1] == walk30.num_frames - 1
    steps = np.diff(sol.frames)
    assert steps.min() >= 1 and steps.max() <= 8
    assert sol.cost == pytest.approx(dp.path_cost(walk_tables.scores, sol.frames, walk_tables.ends), rel=1e-12)
    out, warp = timewarp.guided_warp(walk30, walk30, num_frames, tables=walk_tables)
    assert out.num_frames == num_frames and out.frame_time == walk30.frame_time
    assert warp[0] == 0.0 and warp[-1] == pytest.approx(walk30.duration, abs=1e-12)
    assert np.all(np.diff(warp) > 0)


def test_keytimes_are_honoured(walk30, walk_tables):
    ft = walk30.frame_time
    keys = [(40 * ft, 10 * ft), (150 * ft, 70 * ft)]     # input frame 40 at output frame 10, 150 at 70
    sol = timewarp.solve_warp(walk_tables, 100, keytimes=keys)
    assert sol.frames[10] == 40 and sol.frames[70] == 150
    out, warp = timewarp.guided_warp(walk30, walk30, 100, keytimes=keys, tables=walk_tables, adaptive=False)
    assert warp[10] == pytest.approx(40 * ft, abs=1e-9) and warp[70] == pytest.approx(150 * ft, abs=1e-9)
    # the key poses are shown at the key times (no adaptive averaging): exact frames
    assert quat_angle(out.local_quats[70], walk30.local_quats[150]).max() < 1e-6


def test_keytimes_between_frames_round_to_the_nearest_frame(walk30, walk_tables):
    ft = walk30.frame_time
    sol = timewarp.solve_warp(walk_tables, 100, keytimes=[(40.3 * ft, 9.8 * ft)])
    assert sol.frames[10] == 40


def test_keytimes_repeating_the_end_points_are_accepted(walk30, walk_tables):
    end_out = 99 * walk30.frame_time
    plain = timewarp.solve_warp(walk_tables, 100)
    for keys in ([(0.0, 0.0)], [(walk30.duration, end_out)], [(walk30.duration + 1e-7, end_out - 1e-7)]):
        np.testing.assert_array_equal(timewarp.solve_warp(walk_tables, 100, keytimes=keys).frames, plain.frames)
    with pytest.raises(ValueError, match="keytimes"):       # the last pose before the end: not increasing
        timewarp.solve_warp(walk_tables, 100, keytimes=[(walk30.duration, 1.0)])


def test_derivative_weights_follow_the_frame_rate(walk30):
    t30 = timewarp.prepare_warp(walk30, walk30)
    fast = walk30.resample(walk30.frame_time / 2)
    t60 = timewarp.prepare_warp(fast, fast)
    # per-frame differences at 60 Hz are half those at 30 Hz: velocity weight x2, acceleration weight x4
    assert t60.weights[1] == pytest.approx(2 * t30.weights[1]) and t60.weights[2] == pytest.approx(4 * t30.weights[2])
    assert t30.weights == pytest.approx((1.0, 1.0, 1.0), rel=1e-5)  # 30 Hz time unit; the file rounds 1/30 s


def test_cached_tables_give_the_same_result(walk30, walk_tables):
    ref = walk30.slice(20, 120)
    a_out, a_warp = timewarp.guided_warp(walk30, ref, 120)
    tables = timewarp.prepare_warp(walk30, ref)
    b_out, b_warp = timewarp.guided_warp(walk30, ref, 120, tables=tables)
    np.testing.assert_array_equal(a_warp, b_warp)
    np.testing.assert_array_equal(a_out.local_quats, b_out.local_quats)


def test_progress_callback_runs_from_zero_to_one(walk30):
    seen = []
    timewarp.guided_warp(walk30, walk30, 120, progress=seen.append)
    assert len(seen) > 3 and seen[-1] == 1.0
    assert np.all(np.diff(seen) >= 0) and 0.0 <= seen[0] <= 1.0


def test_expansion_upsamples_and_reverse_plays_backwards(walk30):
    n = walk30.num_frames
    out, warp = timewarp.guided_warp(walk30, walk30, 300)
    assert out.num_frames == 300 and warp[-1] == pytest.approx(walk30.duration) and np.all(np.diff(warp) > 0)
    with pytest.raises(ValueError, match="num_frames"):
        timewarp.guided_warp(walk30, walk30, 300, upsample=1)
    out, warp = timewarp.guided_warp(walk30, walk30, n, reverse=True)
    np.testing.assert_allclose(warp, walk30.duration - walk30.times, atol=1e-9)  # m = n: the reversed identity
    assert quat_angle(out.local_quats[0], walk30.local_quats[-1]).max() < 1e-6
    out, warp = timewarp.guided_warp(walk30, walk30, 60, reverse=True, adaptive=False)
    assert warp[0] == pytest.approx(walk30.duration) and warp[-1] == pytest.approx(0.0, abs=1e-12)
    assert np.all(np.diff(warp) < 0)
    smoothed = timewarp.apply_warp(walk30, warp, adaptive=True)   # compression backwards is smoothed too
    assert quat_angle(smoothed.local_quats[1:-1], out.local_quats[1:-1]).max() > 1e-3


def test_unconstrained_length(walk30, walk_tables):
    out, warp = timewarp.guided_warp(walk30, walk30, None, tables=walk_tables)
    sol = timewarp.solve_warp(walk_tables, None, speed_penalty=0.0, free_objective="input_time")
    assert out.num_frames == timewarp.solve_warp(walk_tables, None).frames.size >= -(-(walk30.num_frames - 1) // 8) + 1
    # free length minimises the mean score per output frame (default) or the score integrated over input time
    # (free_objective="input_time"): no constrained solution of any length does better on either
    W = dp.step_weights(walk_tables.skip)

    def integrated(f):
        a, b = np.diff(f)[:-1], np.diff(f)[1:]
        return float((walk_tables.scores[f[1:-1], a - 1, b - 1] * W[a - 1, b - 1]).sum())
    mean_sol = timewarp.solve_warp(walk_tables, None, speed_penalty=0.0)
    for m in (40, 100, 195):
        other = timewarp.solve_warp(walk_tables, m, speed_penalty=0.0)
        assert integrated(other.frames) >= integrated(sol.frames) - 1e-9
        assert other.cost / (m - 2) >= mean_sol.cost / (mean_sol.frames.size - 2) - 1e-9
    with pytest.raises(ValueError, match="free_objective"):
        timewarp.solve_warp(walk_tables, None, free_objective="sum")
    with pytest.raises(ValueError, match="keytimes"):
        timewarp.solve_warp(walk_tables, None, keytimes=[(1.0, 1.0)])


@pytest.mark.parametrize("factor", [2, 4, 8])
def test_coarse_to_fine_agrees_with_the_full_dp_on_an_easy_case(shared_motion, factor):
    # Easy case: the input is the reference walk for 40 frames, then the rest of it in 2x slow motion.
    # Warped to the reference's length, the optimum plays the first part at speed 1 and the rest at 2.
    ref = shared_motion("xia_neutral_walk.bvh").resample(1 / 30)       # 82 frames
    n = ref.num_frames
    src_frames = np.concatenate([np.arange(40), 40 + np.arange(0, 2 * (n - 1 - 40) + 1) / 2])
    inp = ref.sample(src_frames)                                       # 123 frames
    tables = timewarp.prepare_warp(inp, ref)
    full = timewarp.solve_warp(tables, n)
    np.testing.assert_array_equal(np.diff(full.frames), np.r_[np.ones(40, int), np.full(n - 41, 2)])
    # narrow bands for factors 2 and 4: the coarse path must be close; at the paper's factor 8 the coarse problem has
    # 17 frames and starts its path fast (frame 16 at output 9 where the optimum has 9), so the default band
    band = 2 * factor if factor < 8 else None
    fast = timewarp.solve_warp(tables, n, coarse=factor, band=band)
    np.testing.assert_array_equal(fast.frames, full.frames)
    assert fast.cost == pytest.approx(full.cost, rel=1e-12)            # same path, same sum


def test_coarse_to_fine_never_beats_the_exact_dp(walk30, walk_tables):
    full = timewarp.solve_warp(walk_tables, 120)
    for factor in (3, 8):
        fast = timewarp.solve_warp(walk_tables, 120, coarse=factor, band=6)
        assert fast.cost >= full.cost - 1e-9                            # the band only restricts the search
        assert fast.frames[0] == 0 and fast.frames[-1] == walk30.num_frames - 1
        assert np.diff(fast.frames).max() <= 8


def test_linear_warp_is_piecewise_linear_through_the_keys(walk30):
    out, warp = timewarp.linear_warp(walk30, 97)
    np.testing.assert_allclose(warp, np.linspace(0, walk30.duration, 97), atol=1e-12)  # round-off
    keys = [(2.0, 1.0)]
    out, warp = timewarp.linear_warp(walk30, 97, keytimes=keys)
    t = np.arange(97) * walk30.frame_time
    expected = np.where(t <= 1.0, 2.0 * t, 2.0 + (t - 1.0) * (walk30.duration - 2.0) / (t[-1] - 1.0))
    np.testing.assert_allclose(warp, expected, atol=1e-12)
    same = walk30.sample_times(warp)
    np.testing.assert_array_equal(out.local_quats, same.local_quats)
    out, warp = timewarp.linear_warp(walk30, walk30.num_frames)
    assert quat_angle(out.local_quats, walk30.local_quats).max() < 1e-6   # identity: renormalisation only


@pytest.mark.parametrize("keytimes", [[(3.0, 1.0), (2.0, 1.5)], [(1.0, 2.0), (2.0, 1.0)], [(1.0, 0.0)],
                                      [(10.0, 1.0)], [(1.0,)], "abc"])
def test_bad_keytimes_raise(walk30, walk_tables, keytimes):
    with pytest.raises(ValueError, match="keytimes"):
        timewarp.linear_warp(walk30, 100, keytimes=keytimes)
    with pytest.raises(ValueError, match="keytimes"):
        timewarp.guided_warp(walk30, walk30, 100, keytimes=keytimes, tables=walk_tables)


def test_infeasible_or_bad_arguments_raise(walk30, walk_tables, shared_motion):
    with pytest.raises(ValueError, match="num_frames"):
        timewarp.guided_warp(walk30, walk30, 20, tables=walk_tables)      # 195 frames need >= 26 at s = 8
    with pytest.raises(ValueError, match="num_frames"):
        timewarp.guided_warp(walk30, walk30, 1)
    with pytest.raises(ValueError, match="keytimes out of order.*once rounded to frames"):  # both 30 input frames
        timewarp.guided_warp(walk30, walk30, 150, keytimes=[(1.0, 1.0), (1.01, 1.02)], tables=walk_tables)
    with pytest.raises(ValueError, match="keytimes"):                  # 3 s of input in 0.1 s of output
        timewarp.guided_warp(walk30, walk30, 150, keytimes=[(3.0, 0.1)], tables=walk_tables)
    with pytest.raises(ValueError, match="reference"):
        timewarp.guided_warp(walk30, shared_motion("xia_angry_run.bvh"), 100)
    with pytest.raises(ValueError, match="skip"):
        timewarp.guided_warp(walk30, walk30, 100, skip=0)
    with pytest.raises(ValueError, match="upsample"):
        timewarp.guided_warp(walk30, walk30, 100, upsample=0)
    for bad in (-0.1, float("nan"), "0.1"):
        with pytest.raises(ValueError, match="smoothing"):
            timewarp.guided_warp(walk30, walk30, 100, smoothing=bad, tables=walk_tables)
    with pytest.raises(ValueError, match="k must"):
        timewarp.guided_warp(walk30, walk30, 100, k="3")


def test_smooth_warp_keeps_pins_and_monotonicity():
    rng = np.random.default_rng(0)
    w = np.cumsum(rng.integers(1, 6, size=60)).astype(float)
    sm = timewarp.smooth_warp(w, 5, pinned=[20, 41])
    for q in (0, 20, 41, 59):
        assert sm[q] == pytest.approx(w[q], abs=1e-9)   # cumulative sums of rescaled increments: round-off
    assert np.all(np.diff(sm) > 0)
    assert np.abs(np.diff(sm, 2)).max() < np.abs(np.diff(w, 2)).max()   # it does smooth
    np.testing.assert_array_equal(timewarp.smooth_warp(w, 1), w)
    line = 3.0 * np.arange(30)
    np.testing.assert_allclose(timewarp.smooth_warp(line, 7), line, atol=1e-9)  # constant speed is kept


def test_speed_at_input_times_is_the_inverse_view_of_warp_speed():
    ft = 0.1
    warp = np.concatenate([np.arange(10) * 0.1, 0.9 + np.arange(1, 11) * 0.3])   # speed 1, then 3
    sp = timewarp.speed_at_input_times(warp, ft, np.array([0.35, 2.0, 3.5]))
    np.testing.assert_allclose(sp, [1.0, 3.0, 3.0], atol=1e-12)   # piecewise-constant slopes: exact


def test_adaptive_smoothing_only_acts_under_compression(walk30):
    slow = np.linspace(0.0, walk30.duration, 300)          # expansion: speed < 1 everywhere
    a = timewarp.apply_warp(walk30, slow, adaptive=True)
    b = walk30.sample_times(slow)
    np.testing.assert_array_equal(a.local_quats, b.local_quats)
    fast = np.linspace(0.0, walk30.duration, 40)           # ~5x compression
    a = timewarp.apply_warp(walk30, fast, adaptive=True)
    b = walk30.sample_times(fast)
    assert quat_angle(a.local_quats[0], walk30.local_quats[0]).max() < 1e-6     # ends stay exact
    assert quat_angle(a.local_quats[-1], walk30.local_quats[-1]).max() < 1e-6
    assert quat_angle(a.local_quats[1:-1], b.local_quats[1:-1]).max() > 1e-3    # interior frames are averaged
    # averaging over a window reduces frame-to-frame jitter of the output
    jitter = lambda mo: quat_angle(mo.local_quats[1:], mo.local_quats[:-1]).mean()  # noqa: E731
    assert jitter(a) < jitter(b)
