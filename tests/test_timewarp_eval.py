"""The paper's evaluations on real clips: preservation (§4.1) and modification by a reference (§4.2).

Run with ``-s`` to see the figures (they are quoted in the issue report)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import wasserstein_distance
from timewarp_clips import airborne

from stagger_nb import data, positions_in_root_frame, timewarp


@pytest.mark.shared
def test_self_reference_preserves_ballistic_timing_cmu_01_01():
    if not data.path("cmu_01_01").is_file():
        pytest.skip("data/cmu_01_01.bvh not prepared (python -m stagger_nb.data.prepare)")
    m = data.load("cmu_01_01").resample(1 / 30)          # the paper works at 30 Hz; 688 frames, 5 forward jumps
    air = airborne(m)
    assert 60 < air.sum() < 200                          # the detector finds the flights, not the walking
    num = int(round(0.65 * (m.num_frames - 1))) + 1
    out, warp = timewarp.guided_warp(m, m, num)
    _, lin = timewarp.linear_warp(m, num)
    g = timewarp.speed_at_input_times(warp, m.frame_time, m.times)
    li = timewarp.speed_at_input_times(lin, m.frame_time, m.times)
    g_air, g_ground = np.median(g[air]), np.median(g[~air])
    print(f"\n[§4.1 CMU 01_01 @30Hz, {m.num_frames} -> {num} frames] median speed over airborne input frames: "
          f"guided {g_air:.3f}, linear {np.median(li[air]):.3f}; over walking/standing frames: guided "
          f"{g_ground:.3f}, linear {np.median(li[~air]):.3f}")
    assert abs(g_air - 1.0) <= 0.15                      # the issue's bound: flights keep their timing
    assert g_ground > 1.3                                # the rest absorbs the compression
    np.testing.assert_allclose(li, (m.num_frames - 1) / (num - 1), rtol=1e-9)  # linear: one speed everywhere


def _speeds(mo):
    """Per-frame mean joint speed in the torso frame, cm/s: shape (F - 1,)."""
    p = positions_in_root_frame(mo)
    return np.linalg.norm(np.diff(p, axis=0), axis=2).mean(axis=1) / mo.frame_time


def _p90(v):
    return np.percentile(v, 90)


def _xia_walk_and_run(shared_motion):
    """The §4.2 pair at 30 Hz: (neutral walk, angry run, the report's first line)."""
    walk = shared_motion("xia_neutral_walk.bvh").resample(1 / 30)
    angry = shared_motion("xia_angry_run.bvh").resample(1 / 30)
    s_in, s_ref = _speeds(walk), _speeds(angry)
    line = (f"\n[§4.2 xia neutral walk ({walk.num_frames} f) guided by angry run ({angry.num_frames} f) @30Hz] "
            f"per-frame mean joint speed (torso frame), cm/s: input median {np.median(s_in):.1f} p90 "
            f"{_p90(s_in):.1f}; reference median {np.median(s_ref):.1f} p90 {_p90(s_ref):.1f}")
    return walk, angry, line


@pytest.mark.shared
def test_faster_reference_moves_the_speed_distribution(shared_motion):
    walk, angry, line = _xia_walk_and_run(shared_motion)
    speeds, p90, lines = _speeds, _p90, [line]
    s_ref = speeds(angry)
    # (b) fixed durations (keytimes at the ends only): the mean speed is fixed by path length / duration, so
    # a faster reference can only reshape the distribution: faster peaks, slower lulls (the paper's V6 effect)
    for frac in (1.0, 0.65):
        num = int(round(frac * (walk.num_frames - 1))) + 1
        g = speeds(timewarp.guided_warp(walk, angry, num, upsample=2)[0])
        lin = speeds(timewarp.linear_warp(walk, num)[0])
        lines.append(f"  {num} frames: angry-guided median {np.median(g):.1f} p90 {p90(g):.1f}; linear median "
                     f"{np.median(lin):.1f} p90 {p90(lin):.1f}")
        assert p90(lin) < p90(g) < p90(s_ref)             # the peaks move toward the reference's
    print("\n".join(lines))


def _free_length_from_another_performer(shared_motion, **options):
    walk, angry, line = _xia_walk_and_run(shared_motion)
    speeds, p90, lines = _speeds, _p90, [line]
    s_in, s_ref = speeds(walk), speeds(angry)
    # (a) free output length (the unconstrained search, as for the paper's V8), input upsampled 4x so the
    # search may slow down as well as speed up; the walk's own timing as the control reference
    g_out = timewarp.guided_warp(walk, angry, None, upsample=4, **options)[0]
    c_out = timewarp.guided_warp(walk, walk, None, upsample=4, **options)[0]
    g, own = speeds(g_out), speeds(c_out)
    w1 = {k: wasserstein_distance(v, s_ref) for k, v in (("in", s_in), ("angry", g), ("self", own))}
    lines.append(f"  free length: angry-guided {g_out.num_frames} f, median {np.median(g):.1f}, p90 {p90(g):.1f}; "
                 f"self-guided {c_out.num_frames} f, median {np.median(own):.1f}; W1 to the reference's speeds: "
                 f"input {w1['in']:.1f}, self-guided {w1['self']:.1f}, angry-guided {w1['angry']:.1f} cm/s")
    print("\n".join(lines))
    assert w1["angry"] < 0.5 * w1["self"] and w1["angry"] < 0.5 * w1["in"]
    assert abs(np.median(g) / np.median(s_ref) - 1.0) < 0.25


@pytest.mark.shared
@pytest.mark.xfail(strict=True, reason="known limitation, open: free length follows a reference of the same activity "
                   "(a 1.5x faster / slower copy: 0.667 / 1.42-1.45 of the length, benchmarks/bench_claims.py) but "
                   "not another activity's: the angry run holds none of the neutral walk's poses (nearest-pose "
                   "distance 3.8 pose steps, as far as V8's unmatched frames), and the walk comes out 55 frames, "
                   "median 14.9 cm/s (the run's 19.8), W1 6.8 against the bound 5.7. Measured before issue 25: "
                   "input_time with the pelvis frame and the table-median penalty 18.1 cm/s, W1 4.5 (the "
                   "pelvis_height frame alone: 16.4, W1 5.1; with the penalty's free ratio 1.5: 14.9, 6.8)")
def test_free_length_takes_the_reference_speed_from_another_performer(shared_motion):
    _free_length_from_another_performer(shared_motion)
