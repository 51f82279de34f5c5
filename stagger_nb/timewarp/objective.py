"""The kNN local score of guided time warping (Hsu et al. 2007, §3.2, eq. 2).

``f(i, j, k)`` is the mean Euclidean distance from the feature vector of input frame ``j`` placed between
``i`` and ``k`` (see :mod:`.features`) to its ``k_nn`` nearest reference feature vectors. It is tabulated for
every admissible triple (``1 <= j - i <= s``, ``1 <= k - j <= s``) as ``scores[j, a - 1, b - 1] =
f(j - a, j, j + b)``, shape ``(n, s, s)``, ``inf`` where ``j - a < 0`` or ``j + b > n - 1``.

How it is fast (exact search, no approximation): the features are linear in the input frames, so for a
reference feature ``z_t = [w_p P_t, w_v V_t, w_a A_t]`` the squared distance splits as

    |phi(i, j, k) - z_t|^2 = |phi(i, j, k)|^2 + U[i, t] + W[j, t] + Y[k, t]

with three ``(n, r)`` matrices from BLAS products of the input poses and the reference blocks. The nearest
neighbours only depend on ``U[i] + W[j] + Y[k]``; for one skip pair ``(a, b)`` these are contiguous row
slices, processed in cache-sized chunks of middle frames. Memory is ``O(n r)`` for the matrices plus
``O(n s^2)`` for the table.
"""
from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor, as_completed

import numpy as np

from .features import feature_weights, reference_blocks

__all__ = ["knn_scores", "validate_skip", "end_scores", "candidate_scores"]

_BLOCK_ELEMS = 1 << 15  # reference rows x middle frames per elementwise block (128 KiB of float32, in L2)
_CHUNK_BYTES = 1 << 20  # one (r, L) slab of partial sums per chunk of middle frames ...
_MIN_CHUNK = 256        # ... but at least this many middle frames, or per-call overhead dominates for large r
_THREADS_MIN_PAIRS = 1500 * 1500   # workers=None: one thread below this many (input, reference) frame pairs
                                   # (Table-1 size, 493 x 491: 43.6 ms CPU on one thread, 45.7 ms on two, and
                                   # no shorter wall time even on an idle machine: 39 vs 41 ms)


def validate_skip(skip) -> int:
    if isinstance(skip, bool) or not isinstance(skip, (int, np.integer)) or skip < 1 or skip > 127:
        raise ValueError(f"skip must be an integer in [1, 127] (frames; backpointers are int8), got {skip!r}")
    return int(skip)


def _check_inputs(X, R, skip, k, ref_step=1.0):
    X = np.asarray(X, dtype=float)
    R = np.asarray(R, dtype=float)
    if X.ndim != 2 or R.ndim != 2 or X.shape[1] != R.shape[1]:
        raise ValueError(f"X (n, D) and R (r, D) must share D, got {X.shape} and {R.shape}")
    skip = validate_skip(skip)
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be a positive integer, got {k!r}")
    if R.shape[0] - 2 * int(np.ceil(ref_step - 1e-9)) < k:
        raise ValueError(f"reference must have at least k + 2 = {k + 2} frames (k + 2 * ref_step), got {R.shape[0]}")
    return X, R, skip, int(k)


def _merge_sorted(A: list, B: list, k: int) -> list:
    """Elementwise k smallest of the union of two ascending lists of arrays: the r-th smallest is
    ``min_p max(A_p, B_{r-p})`` (with ``A_0 = B_0 = -inf``)."""
    out = []
    for r in range(1, k + 1):
        best = np.minimum(A[r - 1], B[r - 1])
        for p in range(1, r):
            best = np.minimum(best, np.maximum(A[p - 1], B[r - p - 1]))
        out.append(best)
    return out


def _tree_k_smallest(M: list, k: int) -> list:
    """Reduce ascending lists ``M[l] (rows, L)`` over the rows to ``(L,)`` arrays, k of them."""
    while M[0].shape[0] > 1:
        h = M[0].shape[0] // 2
        odd = M[0].shape[0] % 2
        merged = _merge_sorted([m[:h] for m in M], [m[h:2 * h] for m in M], k)
        if odd:
            merged = [np.concatenate([mm, m[2 * h:]]) for mm, m in zip(merged, M)]
        M = merged
    return [m[0] for m in M]


def _gram_bands(X: np.ndarray, dmax: int) -> np.ndarray:
    """``G[d, j] = X[j] . X[j + d]`` for ``d = 0 .. dmax`` (0 past the end), shape (dmax + 1, n)."""
    n = X.shape[0]
    G = np.zeros((dmax + 1, n))
    for d in range(min(dmax, n - 1) + 1):
        G[d, :n - d] = np.einsum("nd,nd->n", X[:n - d], X[d:])
    return G


def _phi_norms(G: np.ndarray, s: int, wp: float, wv: float, wa: float) -> np.ndarray:
    """``|phi(j - a, j, j + b)|^2`` for all middle frames and skips, shape (n, s, s) (garbage where not
    admissible), from the Gram bands of the centred poses."""
    n = G.shape[1]
    out = np.empty((n, s, s))
    g0 = G[0]
    j = np.arange(n)
    for a in range(1, s + 1):
        i = np.clip(j - a, 0, n - 1)
        for b in range(1, s + 1):
            kk = np.clip(j + b, 0, n - 1)
            vel = g0[kk] + g0[i] - 2.0 * G[a + b, i]
            acc = g0[kk] + 4.0 * g0 + g0[i] - 4.0 * G[b, j] - 4.0 * G[a, i] + 2.0 * G[a + b, i]
            out[:, a - 1, b - 1] = wp * wp * g0 + 0.25 * wv * wv * vel + wa * wa * acc
    return out


def knn_scores(X: np.ndarray, R: np.ndarray, skip: int = 8, k: int = 3, weights=(1.0, 1.0, 1.0),
               dtype=np.float32, progress=None, ref_step: float = 1.0, workers: int | None = None) -> np.ndarray:
    """Tabulate the local score ``f`` of eq. (2) for all admissible triples (exact kNN).

    Parameters
    ----------
    X : (n, D) input pose features (:func:`.features.pose_features`), one row per input frame
    R : (r, D) reference pose features, sampled at the *output* frame time
    skip : s, the largest allowed step between consecutive selected input frames (§3.1)
    k : number of nearest neighbours averaged (the paper uses 3)
    weights : (w_pose, w_velocity, w_acceleration), scales of the feature blocks
    dtype : float32 (default, ~2x faster) or float64 for the neighbour search. Distances are formed as
        ``|phi|^2 + |z|^2 - 2 phi.z`` after centring on the mean reference pose; in float32 their squared
        values carry an absolute error of about ``1e-7 * |features|^2``.
    progress : callable(fraction in [0, 1]) or None, called (from the calling thread) as work units finish
    workers : threads sharing the work units (chunk of middle frames x skip a); None = min(4, CPUs), or 1 for
        tables smaller than ``_THREADS_MIN_PAIRS`` frame pairs
    ref_step : reference frames spanned by one output frame (1; larger for the coarse problem, see
        :func:`.features.reference_blocks`)

    Returns
    -------
    scores : (n, s, s) float64, ``scores[j, a-1, b-1] = f(j-a, j, j+b)``, inf where not admissible.
    """
    X, R, s, k = _check_inputs(X, R, skip, k, ref_step)
    wp, wv, wa = feature_weights(weights)
    n = X.shape[0]
    mu = R.mean(axis=0)
    X = X - mu  # distances are unchanged (differences are shift-invariant); norms become small
    R = R - mu
    P, V, A = reference_blocks(R, ref_step)
    rr = P.shape[0]
    Z = np.concatenate([wp * P, wv * V, wa * A], axis=1)
    znorm = np.einsum("td,td->t", Z, Z)
    # phi.z = wp^2 x_j.P + (wv^2 / 2)(x_k - x_i).V + wa^2 (x_k - 2 x_j + x_i).A, split into rows i / j / k;
    # stored reference-major (rr, s + n + s) with inf columns where i < 0 or k > n - 1.
    UT = np.full((rr, n + 2 * s), np.inf, dtype=dtype)
    WT = np.full((rr, n + 2 * s), np.inf, dtype=dtype)
    YT = np.full((rr, n + 2 * s), np.inf, dtype=dtype)
    Xt = X.T.astype(dtype)   # products in the search precision: no (r, n) float64 temporaries
    UT[:, s:s + n] = (wv * wv * V - 2.0 * wa * wa * A).astype(dtype) @ Xt               # -2 (i part)
    WT[:, s:s + n] = (2.0 * wp * wp * P - 4.0 * wa * wa * A).astype(dtype) @ Xt
    np.subtract(znorm.astype(dtype)[:, None], WT[:, s:s + n], out=WT[:, s:s + n])      # |z|^2 - 2 (j part)
    YT[:, s:s + n] = (-wv * wv * V - 2.0 * wa * wa * A).astype(dtype) @ Xt              # -2 (k part)
    phi2 = _phi_norms(_gram_bands(X, 2 * s), s, wp, wv, wa)
    scores = np.full((n, s, s), np.inf)
    itemsize = np.dtype(dtype).itemsize
    L = int(min(n, max(_MIN_CHUNK, _CHUNK_BYTES // (itemsize * rr))))
    nb = int(max(1, min(rr, _BLOCK_ELEMS // L)))
    local = threading.local()
    kl = max(1, k - 1)   # sorted values kept per lane (row of a reference block); exactness is checked below

    def work(j0: int, a: int) -> None:
        """All b for middle frames [j0, j0 + L) and skip a (numpy releases the GIL inside each ufunc)."""
        if not hasattr(local, "T"):
            local.T = np.empty((rr, L), dtype=dtype)
            local.M = [np.empty((nb, L), dtype=dtype) for _ in range(kl)]
            local.pad = [np.full((nb, L), np.inf, dtype=dtype) for _ in range(k - kl)]
            local.v = np.empty((nb, L), dtype=dtype)
            local.tmp = np.empty((nb, L), dtype=dtype)
        T, M = local.T, local.M
        j1 = min(n, j0 + L)
        w = j1 - j0
        np.add(UT[:, s + j0 - a:s + j1 - a], WT[:, s + j0:s + j1], out=T[:, :w])
        for b in range(1, s + 1):
            for m in M:
                m.fill(np.inf)
            for t0 in range(0, rr, nb):
                h = min(nb, rr - t0)
                vv, tt = local.v[:h, :w], local.tmp[:h, :w]
                np.add(T[t0:t0 + h, :w], YT[t0:t0 + h, s + j0 + b:s + j1 + b], out=vv)
                # insert vv into the ascending lists M[0] <= M[1] <= ... (elementwise, per lane)
                for li, m in enumerate(M):
                    mm = m[:h, :w]
                    if li == kl - 1:
                        np.minimum(mm, vv, out=mm)
                    else:
                        np.maximum(mm, vv, out=tt)
                        np.minimum(mm, vv, out=mm)
                        vv, tt = tt, vv
            lanes = [m[:, :w] for m in M] + [p[:, :w] for p in local.pad]
            best = _tree_k_smallest(lanes, k)
            sel = np.stack(best, axis=1).astype(np.float64)
            if kl < k:
                # The k smallest of the lanes' kept values are the true k smallest unless some lane has all
                # its kl kept values below the k-th: then its next value may belong too. Redo those exactly.
                bad = np.nonzero(np.any(M[kl - 1][:, :w] < best[k - 1][None, :], axis=0))[0]
                if bad.size:
                    jj = j0 + bad
                    full = UT[:, s + jj - a] + WT[:, s + jj] + YT[:, s + jj + b]          # (rr, nbad)
                    sel[bad] = np.partition(full, k - 1, axis=0)[:k].T.astype(np.float64)
            with np.errstate(invalid="ignore"):
                d = np.sqrt(np.maximum(sel + phi2[j0:j1, a - 1, b - 1, None], 0.0))
            scores[j0:j1, a - 1, b - 1] = d.mean(axis=1)

    units = [(j0, a) for j0 in range(0, n, L) for a in range(1, s + 1)]
    if workers is None and n * rr < _THREADS_MIN_PAIRS:
        workers = 1   # small tables: the elementwise calls are too short to release the GIL for long
    nw = _workers(workers, len(units))
    if nw == 1:
        for i, u in enumerate(units):
            work(*u)
            if progress is not None:
                progress((i + 1) / len(units))
    else:
        with ThreadPoolExecutor(max_workers=nw) as pool:
            futures = [pool.submit(work, *u) for u in units]
            for i, f in enumerate(as_completed(futures)):
                f.result()
                if progress is not None:
                    progress((i + 1) / len(units))
    return scores


def _workers(workers, units: int) -> int:
    if workers is None:
        workers = min(4, os.cpu_count() or 1)
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ValueError(f"workers must be a positive integer or None, got {workers!r}")
    return int(max(1, min(workers, units)))


def candidate_scores(X: np.ndarray, R: np.ndarray, skip: int = 8, k: int = 3, weights=(1.0, 1.0, 1.0),
                     candidates: int = 32, ref_step: float = 1.0, chunk: int = 1024, progress=None) -> np.ndarray:
    """Approximate :func:`knn_scores` for long takes: the k nearest among ``candidates`` reference frames.

    For every middle frame ``j`` the candidates are the ``candidates`` reference frames whose *pose* block is
    nearest to ``x_j`` (a k-d tree on the pose features, ``scipy.spatial.cKDTree``); eq. (2)'s distances are
    then exact (float64) on those frames only, for every skip pair ``(a, b)``.  A reference frame with a far
    pose but a close velocity is missed, so scores can only be over-estimated.  Cost ``O(n C s (s + D))`` and
    memory ``O(n s^2 + chunk C s D)`` instead of ``O(n r s^2)`` and ``O(n r)``: usable for n = r = 20,000+.
    Measured at Table-1 size (n = r = 493, s = 8, CMU 01_01 poses), C = 32: the optimal warp under these scores
    costs within 0.5 % of the exact optimum when evaluated on the exact scores (``benchmarks/bench_timewarp.py``).

    Parameters and return value as :func:`knn_scores`; ``candidates`` C >= k; ``chunk`` middle frames per batch.
    """
    from scipy.spatial import cKDTree

    X, R, s, k = _check_inputs(X, R, skip, k, ref_step)
    wp, wv, wa = feature_weights(weights)
    n, D = X.shape
    mu = R.mean(axis=0)
    X = X - mu
    R = R - mu
    P, V, A = reference_blocks(R, ref_step)
    rr = P.shape[0]
    C = int(min(max(int(candidates), k), rr))
    znorm = wp * wp * np.einsum("td,td->t", P, P) + wv * wv * np.einsum("td,td->t", V, V) \
        + wa * wa * np.einsum("td,td->t", A, A)
    Bu = wv * wv * V - 2.0 * wa * wa * A          # -2 (i part) = x_i . Bu_t
    Bw = 2.0 * wp * wp * P - 4.0 * wa * wa * A    # |z|^2 - x_j . Bw_t
    By = -wv * wv * V - 2.0 * wa * wa * A         # -2 (k part) = x_k . By_t
    _, cand = cKDTree(P).query(X, C, workers=1)
    cand = np.asarray(cand, dtype=np.int64).reshape(n, C)
    phi2 = _phi_norms(_gram_bands(X, 2 * s), s, wp, wv, wa)
    scores = np.full((n, s, s), np.inf)
    Xp = np.concatenate([np.zeros((s, D)), X, np.zeros((s, D))])   # rows j - a and j + b stay in range
    offs = np.arange(1, s + 1)
    for c0 in range(0, n, chunk):
        c1 = min(n, c0 + chunk)
        j = np.arange(c0, c1)
        cj = cand[c0:c1]                                          # (L, C)
        W = znorm[cj] - np.einsum("lcd,ld->lc", Bw[cj], X[c0:c1])   # (L, C)
        U = np.einsum("lcd,lad->lac", Bu[cj], Xp[s + j[:, None] - offs[None, :]])   # (L, s_a, C)
        Y = np.einsum("lcd,lbd->lbc", By[cj], Xp[s + j[:, None] + offs[None, :]])   # (L, s_b, C)
        for a in range(s):
            T = U[:, a] + W                                       # (L, C)
            d = T[:, None, :] + Y                                 # (L, s_b, C)
            if k < C:
                d = np.partition(d, k - 1, axis=2)[:, :, :k]
            d = np.sqrt(np.maximum(d + phi2[c0:c1, a, :, None], 0.0))
            scores[c0:c1, a, :] = d.mean(axis=2)
        if progress is not None:
            progress(c1 / n)
    jj = np.arange(n)[:, None]
    scores[:, :, :][(jj - offs[None, :] < 0)[:, :, None].repeat(s, axis=2)] = np.inf   # i = j - a < 0
    scores[(jj + offs[None, :] > n - 1)[:, None, :].repeat(s, axis=1)] = np.inf        # k = j + b > n - 1
    return scores


def end_scores(X: np.ndarray, R: np.ndarray, skip: int = 8, k: int = 3, weights=(1.0, 1.0, 1.0),
               ref_step: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Local scores of the first and the last output frame, for every first / last step (an addition to eq. 1).

    Eq. (1) sums ``f`` over the interior output frames only, so the first and the last step of a warp are each
    charged by one triple where every other step is charged by two: the shortest path dumps speed there (a
    self-referenced compression of CMU 01_01 to 65 % starts and ends with a skip-8 step; every clip measured
    did, issue 25).  The end frames are scored like the others, on what is known there: the pose and the
    one-sided velocity ``[w_p x_0, w_v (x_a - x_0)]`` (start, first step ``a``) and ``[w_p x_{n-1},
    w_v (x_{n-1} - x_{n-1-b})]`` (end, last step ``b``), against the pose and velocity blocks of the reference
    (:func:`.features.reference_blocks`), mean distance to the ``k`` nearest (exact, float64).

    Returns ``(start (s,), end (s,))``; ``inf`` where the step is longer than the input.
    """
    X, R, s, k = _check_inputs(X, R, skip, k, ref_step)
    wp, wv, _ = feature_weights(weights)
    n = X.shape[0]
    P, V, _ = reference_blocks(R, ref_step)
    Z = np.concatenate([wp * P, wv * V], axis=1)
    out = []
    for base, sign in ((0, 1), (n - 1, -1)):
        steps = np.arange(1, s + 1)
        ok = steps <= n - 1
        other = base + sign * np.minimum(steps, n - 1)
        vel = sign * (X[other] - X[base])                     # per output frame, forward in time
        q = np.concatenate([np.broadcast_to(wp * X[base], vel.shape), wv * vel], axis=1)
        d2 = np.einsum("sd,sd->s", q, q)[:, None] + np.einsum("td,td->t", Z, Z)[None, :] - 2.0 * q @ Z.T
        d = np.sqrt(np.maximum(d2, 0.0))
        kk = min(k, d.shape[1])
        e = np.partition(d, kk - 1, axis=1)[:, :kk].mean(axis=1)
        out.append(np.where(ok, e, np.inf))
    return out[0], out[1]
