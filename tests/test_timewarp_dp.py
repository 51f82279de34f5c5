"""Constrained DP of guided time warping (§3.3) against exhaustive search, bounds, keys and the heuristic."""
from __future__ import annotations

import itertools

import numpy as np
import pytest
from timewarp_reference import constrained_dp_loop

from stagger_nb import timewarp
from stagger_nb.timewarp import dp
from stagger_nb.timewarp.objective import knn_scores


def _admissible_paths(n, m, s):
    """Every admissible selection: 0 and n-1 kept, m frames, steps in [1, s] (brute force)."""
    for mid in itertools.combinations(range(1, n - 1), m - 2):
        f = (0,) + mid + (n - 1,)
        if max(np.diff(f)) <= s:
            yield f


def _exhaustive(scores, m, keys=()):
    n, s, _ = scores.shape
    best_cost, best = np.inf, None
    for f in _admissible_paths(n, m, s):
        if any(f[q] != y for q, y in keys):
            continue
        c = dp.path_cost(scores, f)
        if c < best_cost:
            best_cost, best = c, f
    return best_cost, best


def _random_table(rng, n, s, kind):
    if kind == "uniform":
        sc = rng.random((n, s, s))
    else:  # a real kNN table: random-walk poses against a random-walk reference
        X = np.cumsum(rng.standard_normal((n, 6)), axis=0)
        R = np.cumsum(rng.standard_normal((n + 3, 6)), axis=0)
        return knn_scores(X, R, s, k=2, dtype=np.float64)
    j = np.arange(n)[:, None, None]
    a = np.arange(1, s + 1)[None, :, None]
    b = np.arange(1, s + 1)[None, None, :]
    return np.where((j - a >= 0) & (j + b <= n - 1), sc, np.inf)


def _min_frames(n: int, s: int) -> int:
    """The fewest output frames of a path over ``n`` input frames that keeps both ends with steps of at most ``s``."""
    return -(-(n - 1) // s) + 1


def _draw_sizes(rng, n_range, s_range):
    """A random input length ``n`` and skip ``s`` (drawn in that order) and their :func:`_min_frames`."""
    n = int(rng.integers(*n_range))
    s = int(rng.integers(*s_range))
    return n, s, _min_frames(n, s)


def _cases():
    rng = np.random.default_rng(7)
    out = []
    for n, s in [(5, 1), (6, 2), (8, 3), (10, 2), (11, 4), (12, 3), (12, 8)]:
        m_min = _min_frames(n, s)
        for m in sorted(set([m_min, (m_min + n) // 2, n - 1, n]) - {1}):
            if max(2, m_min) <= m <= n:
                out.append((n, s, m, int(rng.integers(1 << 30))))
    return out


@pytest.mark.parametrize("kind", ["uniform", "knn"])
@pytest.mark.parametrize("n,s,m,seed", _cases())
def test_dp_equals_exhaustive_search(n, s, m, seed, kind):
    scores = _random_table(np.random.default_rng(seed), n, s, kind)
    best_cost, best = _exhaustive(scores, m)
    frames, cost = dp.constrained_dp(scores, m)
    # same sums in another order: float64 round-off only
    assert cost == pytest.approx(best_cost, rel=1e-12, abs=1e-12)
    assert tuple(frames) == best  # continuous random scores: the optimum is unique
    assert dp.path_cost(scores, frames) == pytest.approx(cost, rel=1e-12, abs=1e-12)
    loop_frames, loop_cost = constrained_dp_loop(scores, m)
    assert tuple(loop_frames) == best and loop_cost == pytest.approx(best_cost, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("seed", range(12))
def test_dp_with_keys_equals_exhaustive_search(seed):
    rng = np.random.default_rng(100 + seed)
    n, s, m_min = _draw_sizes(rng, (7, 13), (2, 5))
    m = int(rng.integers(m_min, n + 1))
    paths = list(_admissible_paths(n, m, s))
    through = paths[int(rng.integers(len(paths)))]           # keys taken from an admissible path: feasible
    qs = rng.choice(np.arange(1, m - 1), size=min(2, m - 2), replace=False) if m > 2 else []
    keys = [(int(q), int(through[q])) for q in qs]
    scores = _random_table(rng, n, s, "uniform")
    best_cost, best = _exhaustive(scores, m, keys)
    frames, cost = dp.constrained_dp(scores, m, keys=keys)
    assert tuple(frames) == best
    assert cost == pytest.approx(best_cost, rel=1e-12, abs=1e-12)  # float64 round-off only
    for q, y in keys:
        assert frames[q] == y


def test_vectorised_dp_equals_loop_dp_on_a_larger_problem():
    rng = np.random.default_rng(3)
    n, s, m = 60, 5, 31
    scores = _random_table(rng, n, s, "uniform")
    keys = [(10, 17), (20, 42)]
    f1, c1 = dp.constrained_dp(scores, m, keys=keys)
    f2, c2 = constrained_dp_loop(scores, m, keys=keys)
    np.testing.assert_array_equal(f1, f2)
    assert c1 == pytest.approx(c2, rel=1e-12)  # float64 round-off only


@pytest.mark.parametrize("n,s", [(9, 2), (12, 3), (11, 5)])
def test_bounds_are_exactly_the_frames_some_admissible_path_uses(n, s):
    for m in range(_min_frames(n, s), n + 1):
        paths = np.array(list(_admissible_paths(n, m, s)))
        lo, hi = dp.warp_bounds(n, m, s)
        np.testing.assert_array_equal(lo, paths.min(axis=0))
        np.testing.assert_array_equal(hi, paths.max(axis=0))
        for q in range(m):  # and every value in between is used (the band has no holes)
            assert set(paths[:, q]) == set(range(lo[q], hi[q] + 1))


def test_identity_when_m_equals_n():
    rng = np.random.default_rng(5)
    scores = _random_table(rng, 40, 8, "uniform")
    frames, cost = dp.constrained_dp(scores, 40)
    np.testing.assert_array_equal(frames, np.arange(40))
    assert cost == pytest.approx(scores[1:-1, 0, 0].sum(), rel=1e-12)  # round-off only


@pytest.mark.parametrize("seed", range(20))
def test_first_and_last_frames_kept_and_skip_respected(seed):
    rng = np.random.default_rng(200 + seed)
    n, s, m_min = _draw_sizes(rng, (20, 120), (1, 10))
    if m_min > n:
        return
    m = int(rng.integers(m_min, n + 1))
    frames, cost = dp.constrained_dp(_random_table(rng, n, s, "uniform"), m)
    assert frames.size == m and frames[0] == 0 and frames[-1] == n - 1
    steps = np.diff(frames)
    assert steps.min() >= 1 and steps.max() <= s
    assert np.isfinite(cost)


@pytest.mark.parametrize("n,s", [(6, 2), (9, 3), (11, 4)])
def test_unconstrained_equals_exhaustive_over_all_lengths(n, s):
    scores = _random_table(np.random.default_rng(n * s), n, s, "uniform")
    best = min((_exhaustive(scores, m) for m in range(2, n + 1) if (m - 1) * s >= n - 1), key=lambda t: t[0])
    frames, cost = dp.unconstrained_dp(scores)
    assert tuple(frames) == best[1]
    assert cost == pytest.approx(best[0], rel=1e-12, abs=1e-12)  # float64 round-off only


@pytest.mark.parametrize("n,s", [(6, 2), (9, 3), (11, 4)])
def test_mean_cost_equals_exhaustive_over_all_lengths(n, s):
    # free length: the least mean score per interior frame over every admissible path of every length >= 3
    scores = _random_table(np.random.default_rng(7 * n + s), n, s, "uniform")
    best = min(((dp.path_cost(scores, f) / (m - 2), f) for m in range(3, n + 1) if (m - 1) * s >= n - 1
                for f in _admissible_paths(n, m, s)), key=lambda t: t[0])
    frames, mean = dp.mean_cost_dp(scores)
    assert mean == pytest.approx(best[0], rel=1e-12, abs=1e-12)
    assert dp.path_cost(scores, frames) / (frames.size - 2) == pytest.approx(best[0], rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("kind", ["uniform", "knn"])
@pytest.mark.parametrize("n,s", [(6, 2), (9, 3), (11, 4), (12, 8)])
def test_input_time_cost_equals_exhaustive_over_all_lengths(n, s, kind):
    # free length: the least local score integrated over input time, sum f(i, j, k) (k - i) / 2, over every
    # admissible path of every length, written out here in the most straightforward manner
    scores = _random_table(np.random.default_rng(11 * n + s), n, s, kind)

    def integrated(f):
        return sum(scores[f[q], f[q] - f[q - 1] - 1, f[q + 1] - f[q] - 1] * (f[q + 1] - f[q - 1]) / 2.0
                   for q in range(1, len(f) - 1))
    best = min(((integrated(f), f) for m in range(2, n + 1) if (m - 1) * s >= n - 1
                for f in _admissible_paths(n, m, s)), key=lambda t: t[0])
    frames, cost = dp.input_time_dp(scores)
    assert cost == pytest.approx(best[0], rel=1e-12, abs=1e-12)
    assert integrated(tuple(frames)) == pytest.approx(best[0], rel=1e-12, abs=1e-12)


def test_progress_is_reported_up_to_one():
    seen = []
    dp.constrained_dp(_random_table(np.random.default_rng(0), 300, 4, "uniform"), 200, progress=seen.append)
    assert seen and seen[-1] == 1.0 and np.all(np.diff(seen) >= 0)


def test_band_that_excludes_every_path_gives_inf():
    scores = _random_table(np.random.default_rng(1), 30, 4, "uniform")
    lo = np.zeros(20, dtype=int)
    hi = np.zeros(20, dtype=int)  # y_q <= 0 everywhere: impossible after q = 0
    frames, cost = dp.constrained_dp(scores, 20, lo=lo, hi=hi)
    assert cost == np.inf and frames.size == 20


@pytest.mark.parametrize("n,m,skip,keys,match", [
    (100, 10, 8, None, "num_frames"),          # m < (n - 1) / s + 1
    (100, 101, 8, None, "num_frames"),         # expansion without upsampling
    (100, 1, 8, None, "num_frames"),
    (100, 60, 8, [(30, 50), (20, 60)], "keytimes"),   # output order vs input order
    (100, 60, 8, [(30, 50), (40, 45)], "keytimes"),   # input times decrease
    (100, 60, 8, [(30, 5)], "keytimes"),              # 5 input frames cannot fill 30 output frames
    (100, 60, 8, [(70, 5)], "keytimes"),              # outside the output range
])
def test_infeasible_requests_raise_naming_the_parameter(n, m, skip, keys, match):
    with pytest.raises(ValueError, match=match):
        dp.validate_keys(n, m, skip, keys)


@pytest.mark.parametrize("seed", range(6))
def test_kept_costs_and_int8_backpointers_pick_the_same_frames(seed, monkeypatch):
    # constrained_dp backtracks from kept costs below KEEP_COSTS_BYTES, from int8 backpointers above: same
    # frames bit for bit (ties included: integer scores tie often)
    rng = np.random.default_rng(seed)
    n, s = int(rng.integers(20, 120)), int(rng.integers(2, 9))
    scores = np.floor(3 * rng.random((n, s, s)))
    m = int(rng.integers(_min_frames(n, s), n + 1))
    keys = [(m // 2, (n - 1) // 2)] if seed % 2 and m - 1 - m // 2 <= n - 1 - (n - 1) // 2 <= (m - 1 - m // 2) * s \
        and m // 2 <= (n - 1) // 2 <= (m // 2) * s else None
    kept = dp.constrained_dp(scores, m, keys=keys)
    monkeypatch.setattr(dp, "KEEP_COSTS_BYTES", 0)
    ptr = dp.constrained_dp(scores, m, keys=keys)
    np.testing.assert_array_equal(kept[0], ptr[0])
    assert kept[1] == ptr[1]


def _ends(rng, s):
    return rng.random(s), rng.random(s)


@pytest.mark.parametrize("n,s", [(6, 2), (9, 3), (11, 4), (12, 8)])
def test_end_terms_equal_exhaustive_search(n, s):
    """With ``ends`` every output frame is charged: the first by start[first step - 1], the last by end[last step
    - 1]; the constrained, unconstrained, least-mean and input-time searches against all admissible paths."""
    rng = np.random.default_rng(5 * n + s)
    scores = _random_table(rng, n, s, "uniform")
    ends = _ends(rng, s)

    def total(f):
        return dp.path_cost(scores, f) + ends[0][f[1] - f[0] - 1] + ends[1][f[-1] - f[-2] - 1]
    paths = [f for m in range(2, n + 1) if (m - 1) * s >= n - 1 for f in _admissible_paths(n, m, s)]
    for m in sorted({len(f) for f in paths}):
        best = min((total(f), f) for f in paths if len(f) == m)
        frames, cost = dp.constrained_dp(scores, m, ends=ends)
        assert cost == pytest.approx(best[0], rel=1e-12, abs=1e-12) and dp.path_cost(scores, frames, ends) == \
            pytest.approx(best[0], rel=1e-12, abs=1e-12)
    best = min((total(f), f) for f in paths)
    frames, cost = dp.unconstrained_dp(scores, ends=ends)
    assert tuple(frames) == best[1] and cost == pytest.approx(best[0], rel=1e-12, abs=1e-12)
    best = min((total(f) / len(f), f) for f in paths)
    frames, mean = dp.mean_cost_dp(scores, ends=ends)
    assert mean == pytest.approx(best[0], rel=1e-12, abs=1e-12)

    def integrated(f):
        inner = sum(scores[f[q], f[q] - f[q - 1] - 1, f[q + 1] - f[q] - 1] * (f[q + 1] - f[q - 1]) / 2.0
                    for q in range(1, len(f) - 1))
        a, b = f[1] - f[0], f[-1] - f[-2]
        return inner + ends[0][a - 1] * a / 2.0 + ends[1][b - 1] * b / 2.0
    best = min((integrated(f), f) for f in paths)
    frames, cost = dp.input_time_dp(scores, ends=ends)
    assert cost == pytest.approx(best[0], rel=1e-12, abs=1e-12)
    with pytest.raises(ValueError, match="ends"):
        dp.constrained_dp(scores, n, ends=(np.zeros(s + 1), np.zeros(s)))


def test_end_scores_are_the_knn_distance_of_the_one_sided_features():
    rng = np.random.default_rng(3)
    X = np.cumsum(rng.standard_normal((12, 4)), axis=0)
    R = np.cumsum(rng.standard_normal((15, 4)), axis=0)
    w = (1.0, 2.0, 3.0)
    start, end = timewarp.end_scores(X, R, 4, 2, w)
    Z = np.array([np.r_[w[0] * R[t], w[1] * 0.5 * (R[t + 1] - R[t - 1])] for t in range(1, 14)])
    for b in range(1, 5):
        for base, other, out in ((0, b, start), (11, 11 - b, end)):
            q = np.r_[w[0] * X[base], w[1] * (X[base] - X[other]) * (1 if base else -1)]
            d = np.sort(np.linalg.norm(Z - q, axis=1))[:2].mean()
            assert out[b - 1] == pytest.approx(d, rel=1e-9)
