"""Where a time falls on a column of knot times (Coleman et al. 2008, §3): the segment index and the
normalised time ``t'`` in it, for every column at the same times (:func:`segment_coordinates`: a grid of frames)
or one column per sample (:func:`pair_coordinates`). The evaluator (:mod:`.evaluation`) samples the channels'
splines and displacement maps at these coordinates."""
from __future__ import annotations

import numpy as np

__all__ = ["segment_coordinates", "pair_coordinates"]


#: Knot intervals shorter than this (seconds) are treated as zero-length by :func:`segment_coordinates`:
#: far below any frame time (>= 1e-4 s), far above where 1 / length overflows.
_MIN_SEGMENT = 1e-12


def segment_coordinates(knots: np.ndarray, times: np.ndarray):
    """Segment index and normalised time ``t'`` of each time for each column of knot times.

    Parameters
    ----------
    knots : (K, C) knot times per control variable (made non-decreasing by a running maximum)
    times : (N,) seconds

    Returns
    -------
    seg : (N, C) int in [0, K - 2]
    tn : (N, C) float in [0, 1] (clamped outside the first/last knot)
    """
    knots = np.maximum.accumulate(knots, axis=0)
    K, C = knots.shape
    seg = np.empty((C, times.size), dtype=np.int64)                 # one contiguous row per column
    for c in range(C):
        np.subtract(np.searchsorted(knots[:, c], times, side="right"), 1, out=seg[c])
    np.clip(seg, 0, K - 2, out=seg)
    seg = np.ascontiguousarray(seg.T)
    # per segment (K - 1, C): 1 / length, and t' = 1 on zero-length segments; gathered by flat index
    length = knots[1:] - knots[:-1]
    # segments shorter than _MIN_SEGMENT count as zero-length (1 / 1e-320 overflows to inf, then NaN)
    inv = np.divide(1.0, length, out=np.zeros_like(length), where=length > _MIN_SEGMENT)
    flat = seg * C + np.arange(C)
    tn = times[:, None] - np.take(knots.reshape(-1), flat)
    tn *= np.take(inv.reshape(-1), flat)
    tn += np.take((length <= _MIN_SEGMENT).astype(float).reshape(-1), flat)
    return seg, np.clip(tn, 0.0, 1.0, out=tn)


def _segments_of_pairs(T: np.ndarray, times: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """``searchsorted(T[:, joints[n]], times[n], side="right") - 1`` for every sample n, in one search.

    ``T (K, J)`` non-decreasing down each column. Complex numbers order lexicographically in numpy's sort
    and search, so the joint-major keys ``joint + 1j * time`` of all knots form one sorted array and each
    query ``joints[n] + 1j * times[n]`` lands in its own joint's run, compared by time exactly (no
    floating offsets that could move a sample lying on a knot)."""
    Kp, J = T.shape
    keys = np.empty((J, Kp), dtype=complex)
    keys.real = np.arange(J)[:, None]
    keys.imag = T.T
    q = np.empty(times.size, dtype=complex)
    q.real = joints
    q.imag = times
    seg = np.searchsorted(keys.reshape(-1), q, side="right")
    seg -= joints * Kp + 1
    return seg


def pair_coordinates(knots: np.ndarray, times: np.ndarray, cols: np.ndarray):
    """Segment and normalised time ``t'`` of each sample ``(times[n], cols[n])`` in its own column of the knot
    times ``knots (K, C)`` (made non-decreasing by a running maximum): ``seg (N,)`` in [0, K - 2], ``tn (N,)``
    in [0, 1] (clamped outside the first/last knot; 1 on zero-length segments)."""
    T = np.maximum.accumulate(knots, axis=0)
    seg = _segments_of_pairs(T, times, cols)
    np.clip(seg, 0, T.shape[0] - 2, out=seg)
    a, b = T[seg, cols], T[seg + 1, cols]
    tn = np.clip(np.where(b > a, (times - a) / np.where(b > a, b - a, 1.0), 1.0), 0.0, 1.0)
    return seg, tn
