"""Issue 25 limits measured in session 7 on the procedural walk (numbers: ``benchmarks/bench_claims.py``).

* The free-length search's speeds are ``a / upsample``: with the default 4, a 1.5x slower reference (speed 2/3)
  gives 1.37x the length (2:1 mix of 3/4 and 2/4, the smoothness terms prefer 3/4); ``upsample=6, skip=12``
  (the same 2x top speed) holds 4/6 exactly.
* The default sigma is the distance to a frame's 8th nearest neighbour, which at high frame rates is a frame
  of its own 0.1 s: the procedural walk's sigma at 60 Hz is half its 30 Hz one (0.086 / 0.166), the rate
  dependence that leaves CMU 01_01's hops short at 120 Hz (strict xfail until the default is made rate-free).
  Session 11: a graph built on the poses resampled to a fixed rate is rate-free by construction, but no rate,
  kernel width, Theiler-window scale or row normalisation measured meets the hops and issue 13's turning walks
  together (``benchmarks/bench_wand_variants.py``; the table in ``bench_claims.py``'s docstring).
"""
from __future__ import annotations

import pytest

from stagger_nb import data, timewarp, wand


@pytest.fixture(scope="module")
def walk30():
    return data.load("walk").resample(1 / 30)        # 181 frames


def _copy_at(m, factor):
    return m.replace(frame_time=m.frame_time / factor).resample(m.frame_time)


def test_free_length_with_sixths_follows_a_slower_reference_exactly(walk30):
    """Default (quarters): 1.37x, inside the goal's 10 % but 9 % short; sixths: 1.500 (measured)."""
    ref = _copy_at(walk30, 1 / 1.5)
    span = walk30.num_frames - 1
    quarters = (timewarp.guided_warp(walk30, ref, None)[0].num_frames - 1) / span
    sixths = (timewarp.guided_warp(walk30, ref, None, upsample=6, skip=12)[0].num_frames - 1) / span
    assert abs(quarters / 1.5 - 1) <= 0.1
    assert abs(sixths / 1.5 - 1) <= 0.02 and abs(sixths - 1.5) < abs(quarters - 1.5)


def test_free_length_with_sixths_still_follows_a_faster_reference(walk30):
    """The top speed skip / upsample = 2 is kept, so a 1.5x faster copy still gives 2/3 (measured 0.667)."""
    out = timewarp.guided_warp(walk30, _copy_at(walk30, 1.5), None, upsample=6, skip=12)[0]
    assert abs((out.num_frames - 1) / (walk30.num_frames - 1) / (2 / 3) - 1) <= 0.02


@pytest.mark.xfail(strict=True, reason="issue 25: the default sigma halves at 60 Hz (0.086 vs 0.166 at 30 Hz); "
                   "measured on 30 Hz frames (pose_graph(sigma_rate=30), opt-in) it fails 16 of 400 wand / compose / "
                   "session tests (session 8); a graph at a fixed rate (session 11) misses the hops or issue 13's "
                   "turning walks (benchmarks/bench_claims.py docstring)")
def test_default_sigma_does_not_depend_on_the_frame_rate():
    m = data.load("walk")                              # 60 Hz
    s_file = wand.pose_graph(m).basis().sigma
    s_30 = wand.pose_graph(m.resample(1 / 30)).basis().sigma
    assert 0.8 <= s_file / s_30 <= 1.25
