"""One forward pass of the constrained shortest path (Hsu et al. 2007, §3.3, eqs. 3-4) for a range of output
lengths: every length in the range is then a backtrack.

:func:`.dp.constrained_dp` computes, output frame by output frame, the best cost ``c_q[a, k]`` of a path from
input frame 0 whose ``q``-th output frame is ``k`` (reached by a step ``a``), over the band
:func:`.dp.warp_bounds` allows for its length ``m``. That cost does not depend on ``m``: the band of ``m`` is
exactly the states that lie on some path of ``m`` frames, so every path the recurrence compares for a state
of the band lies in the band, and a wider band (the union of the bands of every length ``m_lo .. m_hi``)
gives the same numbers, compared in the same order (the same minimising steps on exact ties), for those
states. Only the last output frame depends on ``m``: ``c_{m-1}[:, n - 1]``. :class:`LengthSweep` runs the
forward pass once over the union band (with the C kernel of :func:`.dp.constrained_dp`, in the same steps)
keeping every step's backpointers and the last frame's costs of each length, so :meth:`LengthSweep.solve`
gives :func:`.dp.constrained_dp`'s frames and cost for any length in the range, bit for bit, in O(m).

What a duration slider asks for: a new length a frame or a few away from the last (the editor's search on
CMU 01_01, measured: at 90 % 27 ms CPU per length, a sweep of +-128 lengths 49 ms once (7.7 MB); at 60 % 65 ms,
the sweep 80 ms (15 MB)).
"""
from __future__ import annotations

import numpy as np

from .dp import _cdp, accelerated, check_ends, validate_keys, warp_bounds

__all__ = ["LengthSweep", "sweep_bytes", "MAX_SWEEP_BYTES"]

#: The largest sweep :class:`LengthSweep` builds (its int8 backpointers, one per state of the union band and step).
MAX_SWEEP_BYTES = 96 << 20


def _union_bounds(n: int, m_lo: int, m_hi: int, s: int, inner: tuple):
    """``(lo, hi, feasible)``: per output frame ``q < m_hi`` the union of the bands of every length
    ``m_lo .. m_hi`` that has a frame ``q``, and whether each length has a path at all."""
    lo = np.full(m_hi, n, dtype=np.int64)
    hi = np.full(m_hi, -1, dtype=np.int64)
    feasible = np.zeros(m_hi - m_lo + 1, dtype=bool)
    for i, m in enumerate(range(m_lo, m_hi + 1)):
        keys = [(0, 0), *inner, (m - 1, n - 1)]
        try:
            validate_keys(n, m, s, keys)
        except ValueError:
            continue
        bl, bh = warp_bounds(n, m, s, keys)
        if np.any(bl > bh):
            continue
        feasible[i] = True
        np.minimum(lo[:m], bl, out=lo[:m])
        np.maximum(hi[:m], bh, out=hi[:m])
    return lo, hi, feasible


def sweep_bytes(n: int, m_lo: int, m_hi: int, skip: int, keys=None) -> int:
    """Bytes of a :class:`LengthSweep` of ``n`` searched frames over lengths ``m_lo .. m_hi`` (its backpointers;
    ``keys`` as the sweep's, the end points left out), before building it."""
    lo, hi, feasible = _union_bounds(n, m_lo, m_hi, skip, tuple(keys or ()))
    if not feasible.any():
        return 0
    M = m_lo + int(np.nonzero(feasible)[0][-1])
    return int((hi[1:M - 1] - lo[1:M - 1] + 1).sum()) * int(skip)


class LengthSweep:
    """:func:`.dp.constrained_dp` of ``scores`` for every length ``m_lo <= m <= m_hi`` at once (see the module).

    Parameters
    ----------
    scores : (n, s, s) local scores as :func:`.dp.constrained_dp` takes them (no NaN)
    m_lo, m_hi : the lengths, ``3 <= m_lo <= m_hi``
    keys : the keys of the lengths other than the end points ``(0, 0)`` and ``(m - 1, n - 1)`` (output frame,
        input frame), the same for every length; None for none
    ends : as :func:`.dp.constrained_dp`
    progress : callable(fraction) or None, called between chunks of the pass (it may raise to stop it: the
        partial sweep is thrown away)
    options : anything hashable the caller records with the sweep (what the scores were made with)

    Raises ``ValueError`` naming the parameter: lengths out of order or below 3, scores holding a NaN, no C
    kernel (:func:`.dp.accelerated`), a sweep larger than :data:`MAX_SWEEP_BYTES`.
    """

    def __init__(self, scores: np.ndarray, m_lo: int, m_hi: int, keys=None, ends=None, progress=None,
                 options=None):
        scores = np.asarray(scores, dtype=float)
        if scores.ndim != 3 or scores.shape[1] != scores.shape[2]:
            raise ValueError(f"scores must be (n, s, s), got shape {scores.shape}")
        n, s, _ = scores.shape
        if not (isinstance(m_lo, (int, np.integer)) and isinstance(m_hi, (int, np.integer)) and 3 <= m_lo <= m_hi):
            raise ValueError(f"m_lo, m_hi must be integers with 3 <= m_lo <= m_hi, got {m_lo!r}, {m_hi!r}")
        if not accelerated():
            raise ValueError("LengthSweep needs the C kernel of constrained_dp (timewarp/_cdp.c, built and allowed)")
        Sab = np.ascontiguousarray(np.transpose(scores, (1, 2, 0)))
        if np.isnan(Sab).any():
            raise ValueError("scores: hold a NaN (constrained_dp takes its numpy path there)")
        self.n, self.skip, self.m_lo, self.m_hi, self.options = int(n), int(s), int(m_lo), int(m_hi), options
        self.ends = check_ends(ends, s)
        self.keys = tuple((int(q), int(y)) for q, y in (keys or ()))
        lo, hi, self.feasible = _union_bounds(n, self.m_lo, self.m_hi, s, self.keys)
        self.last = np.full((self.m_hi - self.m_lo + 1, s), np.inf)   # c_{m-1}[:, n - 1] of each length
        M = self.m_lo + int(np.nonzero(self.feasible)[0][-1]) if self.feasible.any() else self.m_lo
        lo, hi = np.ascontiguousarray(lo[:M]), np.ascontiguousarray(hi[:M])   # past the longest feasible: none
        widths = np.maximum(hi - lo + 1, 0)
        sizes = np.zeros(M, dtype=np.int64)
        sizes[1:M - 1] = widths[1:M - 1] * s
        if int(sizes.sum()) > MAX_SWEEP_BYTES:
            raise ValueError(f"m_lo, m_hi: a sweep of {self.m_lo}..{self.m_hi} frames over {n} searched frames "
                             f"needs {int(sizes.sum()) >> 20} MiB (at most {MAX_SWEEP_BYTES >> 20}): a narrower range")
        self.lo, self.widths = lo, widths
        self.offsets = np.ascontiguousarray(np.cumsum(sizes) - sizes)
        self.back = np.empty(int(sizes.sum()), dtype=np.int8)
        if not self.feasible.any():
            return
        # q = 1: y_0 = 0, so the pair (0, k) has a = k and cost 0 (or the start's end term), as constrained_dp
        k = np.arange(lo[1], hi[1] + 1)
        wmax = int(widths.max())
        cur = np.full((s, wmax), np.inf)
        ok = (k >= 1) & (k <= s)
        cur[k[ok] - 1, np.nonzero(ok)[0]] = 0.0 if self.ends is None else self.ends[0][k[ok] - 1]
        step = max(1, (M - 2) // 100)
        q = 1
        while q < M - 1:
            # in chunks up to the shortest length's last frame, then one output frame at a time: each length's
            # last costs are read as the pass reaches them
            q1 = min(q + step, self.m_lo - 1) if q + 1 < self.m_lo - 1 else q + 1
            _cdp.forward(Sab, n, s, lo, hi, q, q1, cur, wmax, self.back, self.offsets)
            self._keep(cur, q1 + 1)
            if progress is not None:
                progress((q1 - 1) / max(1, M - 2))
            q = q1

    def _keep(self, cur: np.ndarray, m: int) -> None:
        """Record ``cur`` (the costs of output frame ``m - 1``) as length ``m``'s last costs, if in range."""
        if self.m_lo <= m <= self.m_hi and self.feasible[m - self.m_lo]:
            col = self.n - 1 - int(self.lo[m - 1])
            if 0 <= col < self.widths[m - 1]:
                self.last[m - self.m_lo] = cur[:, col]

    @property
    def nbytes(self) -> int:
        return int(self.back.nbytes + self.last.nbytes + self.lo.nbytes + self.offsets.nbytes + self.widths.nbytes)

    def covers(self, m: int, keys=None) -> bool:
        """Whether :meth:`solve` serves ``m`` output frames through ``keys`` (the end points included or not)."""
        if not self.m_lo <= int(m) <= self.m_hi:
            return False
        inner = tuple((int(q), int(y)) for q, y in (keys or ()) if (q, y) not in ((0, 0), (m - 1, self.n - 1)))
        return inner == self.keys

    def solve(self, m: int):
        """``(frames (m,) int64, cost)``: :func:`.dp.constrained_dp` of the sweep's scores for ``m`` output frames,
        the same frames and cost."""
        if not self.m_lo <= int(m) <= self.m_hi:
            raise ValueError(f"m: {m} is outside the sweep's lengths {self.m_lo}..{self.m_hi}")
        m, n = int(m), self.n
        if not self.feasible[m - self.m_lo]:
            return np.round(np.linspace(0, n - 1, m)).astype(np.int64), np.inf
        c = self.last[m - self.m_lo]
        last = c if self.ends is None else c + self.ends[1]
        b = int(np.argmin(last))
        cost = float(last[b])
        if not np.isfinite(cost):
            return np.round(np.linspace(0, n - 1, m)).astype(np.int64), np.inf
        frames = np.empty(m, dtype=np.int64)
        frames[m - 1] = n - 1
        back, off, lo, widths = self.back, self.offsets, self.lo, self.widths
        y, bb = n - 1, b + 1
        for q in range(m - 1, 1, -1):
            j = y - bb
            p = q - 1     # the step computed at middle frame y_{q-1} = j: an (s, width) block
            a = int(back[off[p] + (bb - 1) * widths[p] + (j - lo[p])]) + 1
            frames[q - 1] = j
            y, bb = j, a
        frames[0] = 0
        return frames, cost
