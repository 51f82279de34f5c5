"""The claims of issue 25 on clips built here (procedural, plus the set-up clips where present): each of these
failed with the previous defaults (numbers in the docstrings; ``benchmarks/bench_claims.py`` prints every clip).
Airborne speed: :func:`stagger_nb.timewarp.airborne_speed`."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data, timewarp
from stagger_nb.core.body import airborne_frames

# the defaults before issue 25 (the paper's frame, eq. 1, no end terms, issue 13's penalty)
OLD = dict(frame="pelvis", weighting="output", end_terms=False, penalty_scale="median", penalty_free_ratio=1.0)


@pytest.fixture(scope="module")
def jump30():
    return data.load("jump").resample(1 / 30)        # 166 frames, one jump: 6.6 % of the frames airborne


@pytest.fixture(scope="module")
def walk30():
    return data.load("walk").resample(1 / 30)        # 181 frames


def _copy_at(m, factor):
    """``m`` played ``factor`` times faster, at its own frame time."""
    return m.replace(frame_time=m.frame_time / factor).resample(m.frame_time)


def _compressed_flight(m, **options):
    n = int(round(0.65 * (m.num_frames - 1))) + 1
    air = airborne_frames(m)
    guided = timewarp.airborne_speed(timewarp.guided_warp(m, m, n, **options)[1], m.frame_time, m, air)
    linear = timewarp.airborne_speed(timewarp.linear_warp(m, n)[1], m.frame_time, m, air)
    return guided, linear


def test_compressing_a_jump_keeps_its_flight_in_real_time(jump30):
    """§4.1: a clip with a jump (few airborne frames) compressed to 65 % guided by itself. Measured: 1.00 (the
    previous defaults 4.77: the flight was what eq. 1 compressed first), linear 1.54."""
    assert 10 <= airborne_frames(jump30).sum() <= 14
    guided, linear = _compressed_flight(jump30)
    assert linear == pytest.approx(165 / 107, rel=1e-6)     # one speed everywhere: the overall compression
    assert abs(guided - 1) <= 0.15 and abs(guided - 1) <= 0.5 * abs(linear - 1)
    old, _ = _compressed_flight(jump30, **OLD)
    assert abs(old - 1) > 0.5                              # what the previous defaults did (4.77)


def test_the_first_and_last_steps_are_charged():
    """Eq. (1) charges no score to the end frames, so the shortest path may put the fastest step allowed there
    (the procedural run at 65 %: last step 8; CMU 01_01, bandai_kick: 8 at both ends, with the previous defaults);
    with the end terms (``objective.end_scores``) the ends play like the rest."""
    run30 = data.load("run").resample(1 / 30)
    n = int(round(0.65 * (run30.num_frames - 1))) + 1
    old = timewarp.solve_warp(timewarp.prepare_warp(run30, run30, frame="pelvis", end_terms=False), n,
                              weighting="output", penalty_scale="median", penalty_free_ratio=1.0)
    assert np.diff(old.frames)[-1] == 8
    t = timewarp.prepare_warp(run30, run30)
    steps = np.diff(timewarp.solve_warp(t, n).frames)
    assert steps[0] <= 3 and steps[-1] <= 3
    start, end = t.ends
    assert start.shape == end.shape == (8,) and np.all(np.diff(end) > 0)   # a longer last step fits worse


@pytest.mark.parametrize("hop", [0, 4])
def test_a_single_real_hop_keeps_its_flight(hop):
    """CMU 01_01 (set-up clip) cut around one hop with 0.27 s of standing held either side, 1.6 s: previous
    defaults 1.74 on the first hop, now 0.88-0.95 on all five measured."""
    if not data.path("cmu_01_01").is_file():
        pytest.skip("data/cmu_01_01.bvh not prepared (python -m stagger_nb.data.prepare)")
    cmu = data.load("cmu_01_01").resample(1 / 30)
    a, b = timewarp.intervals(airborne_frames(cmu))[hop]
    ft = cmu.frame_time
    t0, t1 = (a - 9) * ft, (b + 8) * ft
    t = np.arange(49) * ft - (1.6 - (t1 - t0)) / 2 + t0
    m = cmu.sample(np.clip(t, t0, t1) / ft, ft)
    guided, linear = _compressed_flight(m)
    assert abs(guided - 1) <= 0.15 and abs(guided - 1) <= 0.5 * abs(linear - 1), guided


def test_backward_free_length_of_a_clip_against_itself_keeps_its_length(walk30):
    """Reversing the input only (§3.1) opposes every velocity to the reference's: the free-length search played
    the walk 2.63x slower. With the reference reversed too (the default) it is the clip backwards, 1.00x."""
    out, warp = timewarp.guided_warp(walk30, walk30, None, backward=True)
    assert out.num_frames == walk30.num_frames
    np.testing.assert_allclose(warp, walk30.duration - walk30.times, atol=1e-9)
    old, _ = timewarp.guided_warp(walk30, walk30, None, backward=True, reverse_reference=False)
    assert old.num_frames > 2 * walk30.num_frames


@pytest.mark.parametrize("factor,goal", [(1.5, 1 / 1.5), (1 / 1.5, 1.5)])
def test_free_length_follows_a_faster_and_a_slower_copy_of_a_clip_that_stands_still(factor, goal):
    """MocapBank get-down (set-up clip: stands 4 s, gets down for 7 s): the least-mean objective lingered on the
    still poses (faster copy 0.70, slower 2.00); integrated over input time 0.67 / 1.45."""
    if not data.path("mocapbank_get_down").is_file():
        pytest.skip("data/mocapbank_get_down.bvh not prepared (python -m stagger_nb.data.prepare)")
    m = data.load("mocapbank_get_down").resample(1 / 30)
    out, _ = timewarp.guided_warp(m, _copy_at(m, factor), None)
    assert abs(out.num_frames / m.num_frames / goal - 1) <= 0.1


def test_keytimes_between_frames_are_met_exactly(walk30):
    ft = walk30.frame_time
    key = (2.0123, 1.20456)                                 # 0.37 and 0.14 frames off the grid
    n = 140
    t_out = np.arange(n) * ft
    for warp in (timewarp.guided_warp(walk30, walk30, n, keytimes=[key])[1],
                 timewarp.linear_warp(walk30, n, keytimes=[key])[1]):
        assert np.interp(key[1], t_out, warp) == pytest.approx(key[0], abs=1e-12)
        assert np.all(np.diff(warp) > 0) and warp[0] == 0 and warp[-1] == pytest.approx(walk30.duration, abs=1e-12)
    # snapped to frames (before): 2.1 ms off here
    snapped = [(round(key[0] / ft) * ft, round(key[1] / ft) * ft)]
    w = timewarp.guided_warp(walk30, walk30, n, keytimes=snapped)[1]
    assert abs(np.interp(key[1], t_out, w) - key[0]) > 1e-3


def test_a_keytime_inside_the_clip_gives_a_warp_where_a_segment_plays_slower_than_real_time(walk30):
    """Shorter overall (a compression), but the keytime makes the second segment 0.97x: a search without
    upsampling cannot play it (the case of issue 26 on CMU 01_01: 22.83 s with 2 s -> 1.5 s)."""
    ft = walk30.frame_time
    n = walk30.num_frames - 5
    keys = [(1.0, 0.8)]                                       # 1.25x, then 5.0 s of input in 5.13 s
    with pytest.raises(ValueError, match="keytimes"):
        timewarp.guided_warp(walk30, walk30, n, keytimes=keys, upsample=1)
    assert timewarp.required_upsample(walk30.num_frames, n, keytimes=keys, frame_time=ft, skip=8) == 3
    assert timewarp.required_upsample(walk30.num_frames, n) == 1          # without keytimes: a compression
    out, warp = timewarp.guided_warp(walk30, walk30, n, keytimes=keys)
    assert out.num_frames == n and np.interp(0.8, np.arange(n) * ft, warp) == pytest.approx(1.0, abs=1e-12)
    speed = timewarp.warp_speed(warp, ft)
    assert speed[np.arange(n) * ft > 1.5].min() < 1.0                     # slower than real time in places


def test_required_upsample_with_keytimes_closed_form():
    ft = 0.01
    # 101 frames (1 s) to 81 (0.8 s) with 0.5 s of input at 0.1 s: 5x, then 0.5 s in 0.7 s (0.714x)
    keys = [(0.5, 0.1)]
    assert timewarp.required_upsample(101, 81, keytimes=keys, frame_time=ft) == 3          # ceil(2 / 0.714)
    assert timewarp.required_upsample(101, 81, keytimes=keys, frame_time=ft, skip=8) == 2  # 5x needs u <= 1.6:
    # capped at floor(8 / 5) = 1 but never below ceil(1 / 0.714) = 2 (the search then cannot reach 5x: an error)
    assert timewarp.required_upsample(101, 81) == 1
    assert timewarp.required_upsample(101, 81, keytimes=[(0.5, 0.3)], frame_time=ft) == 1  # both compress


@pytest.mark.parametrize("frame_time,expected", [(1 / 30, (4, 1)), (1 / 60, (2, 2)), (1 / 100, (2, 2)),
                                                 (1 / 120, (1, 4)), (1 / 240, (1, 4)), (1 / 24, (4, 1))])
def test_free_length_search_keeps_the_speeds_and_searches_at_most_30_hz(frame_time, expected):
    u, r = timewarp.free_length_search(frame_time)
    assert (u, r) == expected and u * r == timewarp.FREE_UPSAMPLE
    assert r == 1 or r * frame_time <= 1 / 30 + 1e-9


def test_free_length_at_120_hz_searches_a_quarter_of_the_frames(walk30):
    """The same clip at 120 Hz: the search runs on its 120 Hz frames with output frames 1/30 s apart (out_step 4)
    instead of upsampling 4x to 480 Hz, and the result follows the 30 Hz one."""
    m = walk30.resample(1 / 120)
    u, r = timewarp.free_length_search(m.frame_time)
    t = timewarp.prepare_warp(m, m, 8, u, k=timewarp.FREE_K, out_step=r)
    assert t.n_up == m.num_frames and t.out_step == 4
    out, warp = timewarp.guided_warp(m, _copy_at(m, 1.5), None)
    assert abs(out.num_frames / m.num_frames * 1.5 - 1) <= 0.1
    same, w = timewarp.guided_warp(m, m, None, tables=t)
    assert abs(same.num_frames - m.num_frames) <= 4 and np.all(np.diff(w) > 0)
    with pytest.raises(ValueError, match="out_step"):
        timewarp.solve_warp(t, 100)


def test_airborne_speed_closed_form():
    """A piecewise-linear warp: 2 s of input at 2x, then 1 s at 1x, then 1 s at 4x; frames 0.1 s apart."""
    ft = 0.1
    t_out = np.arange(0, 2.25 + 1e-9, ft / 4)
    warp = np.interp(t_out, [0.0, 1.0, 2.0, 2.25], [0.0, 2.0, 3.0, 4.0])
    mask = np.zeros(41, dtype=bool)
    mask[21:30] = True                                      # input frames 21..29: times 2.05 .. 2.95 s
    assert timewarp.speed_inside(warp, ft / 4, mask, ft) == pytest.approx(1.0)
    mask[:] = False
    mask[5:10] = True                                       # 0.45 .. 0.95 s, inside the 2x part
    assert timewarp.speed_inside(warp, ft / 4, mask, ft) == pytest.approx(2.0)
    assert timewarp.overall_speed(warp, ft / 4) == pytest.approx(4.0 / 2.25)
    assert np.isnan(timewarp.speed_inside(warp, ft / 4, np.zeros(41, dtype=bool), ft))
