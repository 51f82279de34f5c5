"""The optional C forward pass of ``timewarp.dp.constrained_dp`` (``_cdp.c``): the same frames and the same cost as
the numpy path, bit for bit, on score tables full of exact ties and inadmissible (inf) triples, with keys, a
coarse-to-fine band and end terms; the optimum of a brute-force enumeration on small problems; NaN scores take
the numpy path; ``STAGGER_NB_NO_ACCEL=1`` switches it off. Skipped (said so) where the extension is not built."""
from __future__ import annotations

import importlib.util
import itertools
import math

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import timewarp
from stagger_nb.core.accel import NO_ACCEL_ENV
from stagger_nb.timewarp import dp

needs_c = pytest.mark.skipif(importlib.util.find_spec("stagger_nb.timewarp._cdp") is None,
                             reason="the C extension stagger_nb.timewarp._cdp is not built")


def _scores(rng, n, s, ties=True, inf_share=0.1):
    """Scores ``(n, s, s)``: small integers (many exact ties) or floats, some triples inadmissible (inf)."""
    S = rng.integers(0, 4, size=(n, s, s)).astype(float) if ties else rng.random((n, s, s))
    S[rng.random((n, s, s)) < inf_share] = np.inf
    return S


def _both(monkeypatch, *args, **kw):
    monkeypatch.setenv(NO_ACCEL_ENV, "1")
    assert not dp.accelerated()
    ref = dp.constrained_dp(*args, **kw)
    monkeypatch.setenv(NO_ACCEL_ENV, "0")
    assert dp.accelerated()
    got = dp.constrained_dp(*args, **kw)
    return ref, got


@needs_c
@pytest.mark.parametrize("seed", range(6))
def test_the_c_pass_gives_the_numpy_paths_frames_and_cost(monkeypatch, seed):
    rng = np.random.default_rng(seed)
    for _ in range(8):
        s = int(rng.integers(1, 10))
        n = int(rng.integers(s + 3, 200))
        m = int(rng.integers(max(3, -(-(n - 1) // s) + 1), n + 1))
        S = _scores(rng, n, s, ties=bool(rng.integers(2)))
        ends = (rng.random(s), rng.random(s)) if rng.integers(2) else None
        keys = None
        if m > 6 and rng.integers(2):   # one key on a feasible path: the straight line's frame at m // 2
            q = m // 2
            keys = [(q, int(round(q * (n - 1) / (m - 1))))]
        (f0, c0), (f1, c1) = _both(monkeypatch, S, m, keys=keys, ends=ends)
        assert np.array_equal(f0, f1) and (c0 == c1 or (math.isinf(c0) and math.isinf(c1))), (n, s, m, keys)
        # a band around the straight line (as coarse-to-fine restricts it)
        y = np.linspace(0, n - 1, m)
        lo, hi = np.floor(y - 3 * s).astype(np.int64), np.ceil(y + 3 * s).astype(np.int64)
        (f0, c0), (f1, c1) = _both(monkeypatch, S, m, keys=keys, lo=lo, hi=hi, ends=ends)
        assert np.array_equal(f0, f1) and (c0 == c1 or (math.isinf(c0) and math.isinf(c1))), (n, s, m, "band")


@needs_c
def test_the_c_pass_matches_the_numpy_path_that_keeps_the_costs(monkeypatch):
    """The numpy path re-derives the minimiser from kept cost arrays below KEEP_COSTS_BYTES, else from int8
    backpointers; the C pass (backpointers) picks the same frames as both (the largest minimising step on ties)."""
    rng = np.random.default_rng(7)
    S = _scores(rng, 300, 6)
    monkeypatch.setenv(NO_ACCEL_ENV, "0")
    got = dp.constrained_dp(S, 120)
    monkeypatch.setenv(NO_ACCEL_ENV, "1")
    kept = dp.constrained_dp(S, 120)
    monkeypatch.setattr(dp, "KEEP_COSTS_BYTES", 0)
    pointers = dp.constrained_dp(S, 120)
    assert np.array_equal(got[0], kept[0]) and np.array_equal(got[0], pointers[0])
    assert got[1] == kept[1] == pointers[1]


@needs_c
@pytest.mark.parametrize("n, m, s", [(7, 4, 3), (9, 5, 2), (8, 6, 4), (10, 4, 3)])
def test_the_c_pass_finds_the_brute_force_optimum(monkeypatch, n, m, s):
    """Every path 0 = y_0 < ... < y_{m-1} = n - 1 with steps 1..s enumerated: the least eq. (1) sum (plus the
    end terms) is the C pass's cost, and its frames reach it."""
    rng = np.random.default_rng(n * 100 + m * 10 + s)
    S = _scores(rng, n, s, ties=False, inf_share=0.0)
    ends = (rng.random(s), rng.random(s))
    monkeypatch.setenv(NO_ACCEL_ENV, "0")
    frames, cost = dp.constrained_dp(S, m, ends=ends)

    def total(y):
        inner = sum(S[y[q], y[q] - y[q - 1] - 1, y[q + 1] - y[q] - 1] for q in range(1, m - 1))
        return inner + ends[0][y[1] - 1] + ends[1][y[-1] - y[-2] - 1]
    best = min(total((0,) + mid + (n - 1,)) for mid in itertools.combinations(range(1, n - 1), m - 2)
               if all(1 <= b - a <= s for a, b in zip((0,) + mid, mid + (n - 1,))))
    assert cost == pytest.approx(best, rel=1e-12) and total(tuple(frames)) == pytest.approx(cost, rel=1e-12)


@needs_c
def test_nan_scores_take_the_numpy_path(monkeypatch):
    rng = np.random.default_rng(3)
    S = _scores(rng, 80, 4)
    S[40, 1, 2] = np.nan
    (f0, c0), (f1, c1) = _both(monkeypatch, S, 50)
    assert np.array_equal(f0, f1) and (c0 == c1 or (np.isnan(c0) and np.isnan(c1)))


@needs_c
def test_progress_runs_to_one_and_a_guided_warp_is_bit_identical(monkeypatch):
    """``progress`` rises to 1; ``timewarp.guided_warp`` of the procedural walk to 80 % and 120 % gives the same
    warp and motion with and without the C pass."""
    rng = np.random.default_rng(5)
    seen = []
    monkeypatch.setenv(NO_ACCEL_ENV, "0")
    dp.constrained_dp(_scores(rng, 400, 8), 300, progress=seen.append)
    assert seen and seen[-1] == 1.0 and all(b >= a for a, b in zip(seen, seen[1:]))
    walk = sn.data.load("walk")
    for frac in (0.8, 1.2):
        n = int(round(frac * (walk.num_frames - 1))) + 1
        out = {}
        for env in ("1", "0"):
            monkeypatch.setenv(NO_ACCEL_ENV, env)
            timewarp.clear_tables_cache()
            out[env] = timewarp.guided_warp(walk, walk, n)
        (m0, w0), (m1, w1) = out["1"], out["0"]
        assert np.array_equal(w0, w1) and np.array_equal(m0.local_quats, m1.local_quats)


@pytest.mark.parametrize("env", ["1", "0"])
def test_a_table_with_no_admissible_path_gives_the_straight_line_and_inf(monkeypatch, env):
    """Every triple inadmissible: both paths return the straight line with cost inf (the numpy path that keeps
    its costs used to backtrack out of its band first: IndexError)."""
    monkeypatch.setenv(NO_ACCEL_ENV, env)
    frames, cost = dp.constrained_dp(np.full((20, 3, 3), np.inf), 10)
    assert cost == np.inf and np.array_equal(frames, np.round(np.linspace(0, 19, 10)).astype(np.int64))
