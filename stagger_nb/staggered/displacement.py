"""Displacement maps (Coleman et al. 2008, §3, §4.1.1): ``d = v ⊖ s``, what the spline leaves of the motion, as
rotation vectors unwrapped along each (segment, joint) grid; and their re-measuring after an edit (§5.1): the
grid of each re-measured map, its sample count, and the rows measured against a target motion.
"""
from __future__ import annotations

import numpy as np

from . import _kernels as K

__all__ = ["displacement_rotvecs"]


_LOG_SMALL = 1e-12   # below this |v| the logarithm uses its Taylor branch (as core.rotations)


def displacement_rotvecs(s, targets, pair):
    """Displacement samples ``d = v ⊖ s`` as rotation vectors (N, 3), unwrapped along each pair.

    The quaternions ``s^-1 v`` are made sign-continuous along each pair's samples (starting on the
    ``w >= 0`` side), then mapped by the logarithm without hemisphere folding, so angles run continuously
    in [0, 2 pi): linear interpolation between neighbouring samples then never jumps across the pi
    ambiguity (large residuals occur on long merged segments).

    ``s, targets (N, 4)`` (transposed views of component-first ``(4, N)`` arrays are used without a
    copy); ``pair (N,)``, samples of a pair contiguous. Works on ``(4, N)`` rows throughout."""
    S = np.asarray(s, dtype=float).T
    T = np.asarray(targets, dtype=float).T
    N = S.shape[1]
    if N == 0:
        return np.zeros((0, 3))
    CH = K.CHUNK                                     # blocks of samples: every temporary stays in cache
    e = np.empty((4, N))                             # s^-1 v
    sc, tmp = np.empty((4, CH)), np.empty(CH)
    for a in range(0, N, CH):
        b = min(N, a + CH)
        np.negative(S[:3, a:b], out=sc[:3, :b - a])
        sc[3, :b - a] = S[3, a:b]
        K.qmul_into(sc[:, :b - a], T[:, a:b], e[:, a:b], tmp[:b - a])
    first = np.concatenate([[True], pair[1:] != pair[:-1]])
    f = np.flatnonzero(first)
    e[:, f] = np.where(e[3, f] < 0, -e[:, f], e[:, f])                  # each pair starts with w >= 0
    d = np.empty(max(N - 1, 0))
    for a in range(0, N - 1, CH):
        b = min(N - 1, a + CH)
        K.dot_into(e[:, a + 1:b + 1], e[:, a:b], d[a:b], tmp[:b - a])
    neg = np.concatenate([[0], np.cumsum((d < 0) & ~first[1:])])
    scale2 = np.where((neg - np.repeat(neg[f], np.diff(np.append(f, N)))) % 2 == 1, -2.0, 2.0)
    out = np.empty((N, 3))
    for a in range(0, N, CH):
        b = min(N, a + CH)
        x = e[:, a:b] * scale2[a:b]                 # sign-continuous, and x2: rotvec = 2 log(q)
        n = np.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])          # 2 |v|
        half = np.arctan2(n, x[3])                                      # half angle in [0, pi]
        big = n > 2.0 * _LOG_SMALL
        # angle / |v| = 2 half / |v|; Taylor below _LOG_SMALL: 2 / w (as core.rotations.quat_log)
        sc_ = np.where(big, 2.0 * half / np.where(big, n, 1.0), 2.0 / np.where(x[3] != 0, x[3], 1.0))
        out[a:b] = (x[:3] * sc_).T
    return out


def _grid(a: np.ndarray, b: np.ndarray, counts: np.ndarray):
    """Uniform t' grids of P segments ``[a, b]``: sample's pair index, index within pair, t', time."""
    pair = np.repeat(np.arange(counts.size), counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    m = np.arange(pair.size) - starts[pair]
    tn = m / (counts[pair] - 1.0)
    return pair, m, tn, a[pair] + tn * (b - a)[pair]


_OVERSAMPLE = 4  # grid refinement of re-measured maps whose ends are off the frame grid (interpolation error / 4)


def _counts_for(a, b, frame_time):
    """Samples of re-measured displacement maps on segments ``[a, b]``: one per source frame spanned (+1),
    so knots on frames put every grid point on a frame (exact there); segments with an end off the frame
    grid (after timing edits) get ``_OVERSAMPLE`` times more samples to keep the linear interpolation close."""
    fa, fb = a / frame_time, b / frame_time
    aligned = (np.abs(fa - np.rint(fa)) < 1e-6) & (np.abs(fb - np.rint(fb)) < 1e-6)
    per = np.where(aligned, 1, _OVERSAMPLE)
    return np.maximum(np.rint((b - a) / frame_time * per).astype(np.int64) + 1, 2)


def measure(algebra, values, tangents, knots, seg, col, counts, target_fn, grid=None, into=None):
    """Displacement rows ``(P, max(counts), 3)`` of the pairs ``(seg[p], col[p])`` of a channel of ``algebra``
    with knots ``values (K, C, D)``, inner controls ``tangents (K - 1, C, 2, D)`` and knot times ``knots (K, C)``,
    such that ``spline ⊕ displacement`` equals ``target_fn(times, cols, pair, tn) (N, D)`` on each pair's grid
    (``grid``: :func:`_grid` of these pairs when the caller has it): ``d = target ⊖ spline`` (unwrapped along
    each grid for rotations, as at extraction). With ``into`` (the channel's table ``(K - 1, C, M, 3)``): that
    table with these pairs' rows replaced instead, ``_put_rows(into, (seg, col), rows)`` written in one pass."""
    if grid is None:
        knots = np.maximum.accumulate(knots, axis=0)
        grid = _grid(knots[seg, col], knots[seg + 1, col], counts)
    pair, m, tn, t = grid
    s = algebra.spline_pairs(values[seg, col], tangents[seg, col, 0], tangents[seg, col, 1], values[seg + 1, col],
                             pair, tn, K.WORK.get("ms_s", (algebra.dim, tn.size)))   # read before the next call
    d = algebra.difference(s, target_fn(t, col[pair], pair, tn), pair)
    if into is not None:
        M = max(into.shape[-2], int(counts.max()))
        out = np.zeros(into.shape[:-2] + (M, 3))
        out[..., :into.shape[-2], :] = into
        out[seg, col] = 0.0
        out[seg[pair], col[pair], m] = d
        return out
    return displacement_table(pair, m, d, (counts.size, int(counts.max()), 3))


def displacements_of(algebra, c0, c1, c2, c3, idx, tn, targets, pair) -> np.ndarray:
    """``d = target ⊖ s(t')`` ``(N, 3)``: what the splines of controls ``c0 .. c3 (P, D)`` leave of ``targets
    (N, D)`` at the samples ``tn (N,)`` of controls ``idx (N,)``, unwrapped along the runs of ``pair (N,)``."""
    return algebra.difference(algebra.spline_pairs(c0, c1, c2, c3, idx, tn), targets, pair)


def displacement_table(pair, m, d, shape) -> np.ndarray:
    """Zero-padded displacement table of ``shape`` (pairs first, sample index second) holding sample ``m[n]``
    of pair ``pair[n]``: ``d[n]``."""
    table = np.zeros(shape)
    table[pair, m] = d
    return table


def _put_rows(table: np.ndarray, index: tuple, rows: np.ndarray) -> np.ndarray:
    """Copy of a displacement table (sample axis -2, e.g. ``(K-1, C, M, 3)``) with the rows at
    ``index`` replaced by ``rows (P, M', 3)``; the sample axis grows if ``M' > M``."""
    M = max(table.shape[-2], rows.shape[1])
    out = np.zeros(table.shape[:-2] + (M, 3))
    out[..., :table.shape[-2], :] = table
    out[index] = 0.0
    out[index + (slice(0, rows.shape[1]),)] = rows
    return out
