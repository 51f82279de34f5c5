"""One forward pass of guided warping's constrained DP for a range of lengths (timewarp/sweep.py,
``length_sweep``): every length's frames and cost are constrained_dp's own, bit for bit (Hsu et al. 2007, §3.3),
and a precomputed solution gives guided_warp's own arrays."""
from __future__ import annotations

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import timewarp
from stagger_nb.timewarp import sweep as sweep_mod
from stagger_nb.timewarp.dp import accelerated, constrained_dp

pytestmark = pytest.mark.skipif(not accelerated(), reason="LengthSweep runs the C kernel (timewarp/_cdp.c)")


def _random_problem(rng, trial):
    n, s = int(rng.integers(10, 70)), int(rng.integers(1, 6))
    S = rng.integers(0, 4, size=(n, s, s)).astype(float)      # small integers: many exact ties
    if trial % 3 == 0:
        S[rng.random(S.shape) < 0.1] = np.inf                 # inadmissible triples
    ends = None if trial % 2 else (rng.integers(0, 3, s).astype(float), rng.integers(0, 3, s).astype(float))
    return n, s, S, ends


def test_every_length_of_a_sweep_is_constrained_dps_own():
    rng = np.random.default_rng(7)
    compared = infeasible = 0
    for trial in range(80):
        n, s, S, ends = _random_problem(rng, trial)
        m_min = max(3, -(-(n - 1) // s) + 1)
        if m_min > n:
            continue
        m_lo = int(rng.integers(m_min, n + 1))
        m_hi = int(rng.integers(m_lo, n + 1))
        keys = ()
        if trial % 4 == 1 and m_lo > 4:          # an inner key, the same for every length
            q = int(rng.integers(1, m_lo - 2))
            keys = ((q, int(rng.integers(q, min(q * s, n - 2) + 1))),)
        sw = timewarp.LengthSweep(S, m_lo, m_hi, keys=keys, ends=ends)
        for m in range(m_lo, m_hi + 1):
            try:
                f0, c0 = constrained_dp(S, m, keys=[(0, 0), *keys, (m - 1, n - 1)] if keys else None, ends=ends)
            except ValueError:                   # the key cannot be met at this length
                assert np.isinf(sw.solve(m)[1])
                infeasible += 1
                continue
            f1, c1 = sw.solve(m)
            assert np.array_equal(f0, f1), (trial, m)
            assert c0 == c1 or (np.isinf(c0) and np.isinf(c1)), (trial, m, c0, c1)
            compared += 1
    assert compared > 300 and infeasible > 0


def test_sweep_checks_its_arguments(monkeypatch):
    S = np.ones((20, 3, 3))
    with pytest.raises(ValueError, match="m_lo, m_hi"):
        timewarp.LengthSweep(S, 2, 10)
    with pytest.raises(ValueError, match="m_lo, m_hi"):
        timewarp.LengthSweep(S, 12, 10)
    bad = S.copy()
    bad[3, 1, 1] = np.nan
    with pytest.raises(ValueError, match="scores"):
        timewarp.LengthSweep(bad, 8, 10)
    sw = timewarp.LengthSweep(S, 8, 10)
    with pytest.raises(ValueError, match="m: 11"):
        sw.solve(11)
    assert sw.covers(9) and not sw.covers(11) and not sw.covers(9, [(0, 0), (3, 5), (8, 19)])
    monkeypatch.setattr(sweep_mod, "MAX_SWEEP_BYTES", 100)
    with pytest.raises(ValueError, match="MiB"):
        timewarp.LengthSweep(S, 8, 20)


def test_sweep_bytes_is_the_sweeps_size():
    S = np.ones((60, 4, 4))
    sw = timewarp.LengthSweep(S, 30, 40)
    assert sweep_mod.sweep_bytes(60, 30, 40, 4) == sw.back.nbytes > 0


@pytest.fixture(scope="module")
def clip():
    return sn.data.load("cmu_01_01").slice(0, 480)


@pytest.mark.parametrize("keytimes", [None, [(1.5, 1.2)]])
def test_solve_warp_with_a_sweep_gives_the_same_solution(clip, keytimes):
    tables = timewarp.prepare_warp(clip, clip, 8, 1)
    m = 400
    sw = timewarp.length_sweep(tables, m - 6, m + 6, keytimes)
    for mm in (m - 6, m - 1, m, m + 3, m + 6, m + 9):            # m + 9: outside the sweep, searched as usual
        a = timewarp.solve_warp(tables, mm, keytimes)
        b = timewarp.solve_warp(tables, mm, keytimes, sweep=sw)
        assert np.array_equal(a.frames, b.frames) and np.array_equal(a.times, b.times)
        assert a.cost == b.cost and a.pinned == b.pinned
    # a sweep made with other search options is not used: the result is the options' own
    other = timewarp.length_sweep(tables, m - 6, m + 6, keytimes, speed_penalty=0.0)
    a = timewarp.solve_warp(tables, m, keytimes)
    assert np.array_equal(a.frames, timewarp.solve_warp(tables, m, keytimes, sweep=other).frames)
    assert np.array_equal(timewarp.solve_warp(tables, m, keytimes, speed_penalty=0.0).frames,
                          timewarp.solve_warp(tables, m, keytimes, speed_penalty=0.0, sweep=other).frames)


def test_guided_warp_with_a_solution_gives_the_same_arrays(clip):
    tables = timewarp.prepare_warp(clip, clip, 8, 1)
    sol = timewarp.solve_warp(tables, 400)
    out0, warp0 = timewarp.guided_warp(clip, clip, 400, tables=tables)
    out1, warp1 = timewarp.guided_warp(clip, clip, 400, tables=tables, solution=sol)
    assert np.array_equal(warp0, warp1) and np.array_equal(out0.local_quats, out1.local_quats)
    assert np.array_equal(out0.root_positions, out1.root_positions)
    with pytest.raises(ValueError, match="solution"):
        timewarp.guided_warp(clip, clip, 401, tables=tables, solution=sol)     # solved for another length
    with pytest.raises(ValueError, match="solution"):
        timewarp.guided_warp(clip, clip, 400, tables=tables, solution=sol.frames)
