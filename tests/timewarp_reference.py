"""Naive reference implementations of guided time warping's fast kernels (issue 23: they live beside the tests
that compare against them, not in the package): eq. (2) as one linear search per triple, eqs. (3-4) as Python
loops over steps, vertices and predecessors.  Used by tests/test_timewarp_*.py and benchmarks/bench_timewarp.py."""
from __future__ import annotations

import numpy as np

from stagger_nb.timewarp.dp import validate_keys
from stagger_nb.timewarp.features import reference_features, triple_features

__all__ = ["knn_scores_loop", "constrained_dp_loop"]


def knn_scores_loop(X: np.ndarray, R: np.ndarray, skip: int = 8, k: int = 3, weights=(1.0, 1.0, 1.0),
                    ref_step: float = 1.0) -> np.ndarray:
    """Straightforward reference implementation of ``timewarp.knn_scores``: one exact float64 linear search
    over the reference features per admissible triple (eq. 2 as written). Same return value."""
    X, R, s, k = np.asarray(X, dtype=float), np.asarray(R, dtype=float), int(skip), int(k)
    n = X.shape[0]
    Z = reference_features(R, weights, ref_step)
    scores = np.full((n, s, s), np.inf)
    for j in range(n):
        for a in range(1, s + 1):
            for b in range(1, s + 1):
                i, kk = j - a, j + b
                if i < 0 or kk > n - 1:
                    continue
                phi = triple_features(X, i, j, kk, weights)
                d = np.sqrt(np.sum((Z - phi) ** 2, axis=1))
                scores[j, a - 1, b - 1] = np.sort(d)[:k].mean()
    return scores


def constrained_dp_loop(scores: np.ndarray, m: int, keys=None):
    """Straightforward reference implementation of ``timewarp.constrained_dp`` (eqs. 3-4 as written: Python
    loops over steps, vertices and predecessors; no banding beyond the keys). Same return value."""
    scores = np.asarray(scores, dtype=float)
    n, s, _ = scores.shape
    pts = dict(validate_keys(n, m, s, keys))
    INF = float("inf")
    # cost[(i, j)] for paths with output frames 0..q ending with y_{q-1} = i, y_q = j
    cost = {(0, j): 0.0 for j in range(1, min(s, n - 1) + 1) if pts.get(1, j) == j}
    back = [None, None]
    for q in range(1, m - 1):
        new, bp = {}, {}
        for (i, j), cij in cost.items():
            for k in range(j + 1, min(j + s, n - 1) + 1):
                if pts.get(q + 1, k) != k:
                    continue
                v = cij + scores[j, j - i - 1, k - j - 1]
                if v < new.get((j, k), INF):
                    new[(j, k)] = v
                    bp[(j, k)] = i
        cost = new
        back.append(bp)
    finals = [(v, key) for key, v in cost.items() if key[1] == n - 1]
    if not finals:
        return np.round(np.linspace(0, n - 1, m)).astype(np.int64), INF
    v, (i, j) = min(finals)
    frames = [j, i]
    for q in range(m - 1, 1, -1):
        i, j = back[q][(i, j)], i
        frames.append(i)
    return np.array(frames[::-1], dtype=np.int64), float(v)
