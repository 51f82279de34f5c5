"""Sample grids of the fit (Coleman et al. 2008, §4.1.1): the uniform normalised-time grid of every (segment,
control variable) pair, the subset the splines are fitted to, source samples read at fractional frames, and the
sign continuity of sampled quaternions (``q`` and ``-q`` are one rotation; a fit needs one continuous sign).
"""
from __future__ import annotations

import numpy as np

from ..core.rotations import slerp

__all__ = ["sample_segments", "fit_subset"]


_ON_FRAME = 1e-6    # fractional frames closer than this to an integer are read directly (no slerp)


def sample_segments(knots: np.ndarray, frame_time: float, start_time: float = 0.0, oversample: int = 1):
    """Uniform ``t'`` sample grids of every segment of every control variable.

    Parameters
    ----------
    knots : (K, C) knot times (seconds), strictly increasing down each column
    frame_time : seconds between source frames; a segment of length L gets ``round(L / frame_time) + 1``
        samples (>= 2), so knots on source frames put every grid point on a source frame
    start_time : time of the source's frame 0
    oversample : samples per frame (``round(oversample * L / frame_time) + 1`` per segment)

    Returns
    -------
    pair : (N,) int, segment-major pair index ``k * C + c`` of each sample
    m : (N,) int, sample index within its pair
    counts : (P,) int, samples per pair, ``P = (K - 1) * C``
    tn : (N,) normalised time ``m / (count - 1)``
    frames : (N,) fractional source frame of each sample
    """
    a = knots[:-1].reshape(-1)
    b = knots[1:].reshape(-1)
    counts = np.maximum(np.rint(oversample * (b - a) / frame_time).astype(np.int64) + 1, 2)
    pair = np.repeat(np.arange(counts.size), counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    m = np.arange(pair.size) - starts[pair]
    tn = m / (counts[pair] - 1.0)
    t = a[pair] + tn * (b - a)[pair]
    return pair, m, counts, tn, (t - start_time) / frame_time


def fit_subset(m: np.ndarray, counts: np.ndarray, pair: np.ndarray, max_samples: int | None) -> np.ndarray:
    """Boolean (N,) mask of the samples the splines are fitted to: every sample of a pair with at most
    ``max_samples`` samples, else ``max_samples`` evenly spaced ones, ``m = round(j (n - 1) / (S - 1))``,
    ``j = 0 .. S - 1`` (first and last included). ``None`` selects all."""
    n = counts[pair]
    if max_samples is None:
        return np.ones(pair.size, dtype=bool)
    S = int(max_samples)
    step = (n - 1.0) / (S - 1.0)
    big = n > S
    j = np.rint(m / np.where(big, step, 1.0))        # step > 1: each m is near at most one grid point j
    return ~big | (np.rint(j * step) == m)


def _read(arr: np.ndarray, frames: np.ndarray, cols: np.ndarray | None, quat: bool) -> np.ndarray:
    """Sample ``arr (F, C, D)`` (or ``(F, D)`` when ``cols`` is None) at fractional frames (clamped)."""
    F = arr.shape[0]
    f = np.clip(frames, 0.0, F - 1)
    r = np.rint(f)
    if np.all(np.abs(f - r) < _ON_FRAME):
        i = r.astype(np.int64)
        return arr[i] if cols is None else arr[i, cols]
    i0 = np.minimum(np.floor(f).astype(np.int64), F - 1)
    i1 = np.minimum(i0 + 1, F - 1)
    w = f - i0
    x0 = arr[i0] if cols is None else arr[i0, cols]
    x1 = arr[i1] if cols is None else arr[i1, cols]
    if quat:
        return slerp(x0, x1, w)
    return x0 * (1.0 - w[:, None]) + x1 * w[:, None]


def _continuous_per_pair(e, first):
    """Flip signs of ``e (N, 4)`` so consecutive samples of a pair (runs starting where ``first``) have
    non-negative dot products; the first sample of each pair keeps its sign."""
    d = np.sum(e[1:] * e[:-1], axis=1)
    neg = np.concatenate([[0], np.cumsum((d < 0) & ~first[1:])])
    start = np.flatnonzero(first)
    base = np.repeat(neg[start], np.diff(np.concatenate([start, [first.size]])))
    return np.where(((neg - base) % 2 == 1)[:, None], -e, e)


def _segment_major(seg, joint, m) -> bool:
    """True when samples are in (segment, joint, sample) order (as :func:`sample_segments` lays them out):
    then a stable sort by joint alone gives the (joint, segment, sample) order."""
    dk, dj, dm = np.diff(seg), np.diff(joint), np.diff(m)
    return bool(np.all((dk > 0) | ((dk == 0) & ((dj > 0) | ((dj == 0) & (dm > 0))))))


def _continuous_per_joint(q, joint, seg, m):
    """Flip signs of samples ``q (N, 4)`` so each joint's samples, taken in time order (segment, then
    sample index), have non-negative consecutive dot products."""
    if _segment_major(seg, joint, m):
        return _continuous_segment_major(q, joint, seg)
    order = np.lexsort((m, seg, joint))
    seq = q[order]
    js = joint[order]
    d = np.sum(seq[1:] * seq[:-1], axis=1)
    neg = np.concatenate([[0], np.cumsum((d < 0) & (js[1:] == js[:-1]))])
    start = np.concatenate([[0], np.flatnonzero(np.diff(js)) + 1])
    base = np.repeat(neg[start], np.diff(np.concatenate([start, [js.size]])))
    out = np.empty_like(q)
    out[order] = np.where(((neg - base) % 2 == 1)[:, None], -seq, seq)
    return out


def _continuous_segment_major(q, joint, seg):
    """:func:`_continuous_per_joint` for samples in (segment, joint, sample) order with every (segment,
    joint) pair present (as :func:`sample_segments` lays them out), without sorting: a sample's flip is the
    parity of the negative consecutive dot products before it in its joint's sequence, counted inside its
    pair, plus those of the joint's earlier pairs and of the joins between them (per pair, a cumulative sum
    down the segments)."""
    N = q.shape[0]
    new_pair = np.concatenate([[True], (np.diff(seg) != 0) | (np.diff(joint) != 0)])
    starts = np.flatnonzero(new_pair)
    ends = np.concatenate([starts[1:], [N]]) - 1
    C = int(joint[starts].max()) + 1
    Ks = starts.size // C
    neg = np.einsum("ij,ij->i", q[1:], q[:-1]) < 0
    neg[new_pair[1:]] = False                                   # joins between pairs are counted below
    cnt = np.concatenate([[0], np.cumsum(neg)])                 # negatives before each sample
    inside = (cnt[ends] - cnt[starts]).reshape(Ks, C)           # within each pair
    join = np.zeros((Ks, C), dtype=np.int64)                   # pair (k - 1, c) -> (k, c)
    join[1:] = (np.einsum("ij,ij->i", q[ends[:-C]], q[starts[C:]]) < 0).reshape(Ks - 1, C)
    before = np.cumsum(join, axis=0)
    before[1:] += np.cumsum(inside, axis=0)[:-1]
    pair_of = np.cumsum(new_pair) - 1
    flip = (before.reshape(-1)[pair_of] + cnt[:N] - cnt[starts][pair_of]) % 2 == 1
    return np.where(flip[:, None], -q, q)
