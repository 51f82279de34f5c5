"""Constrained shortest path of guided time warping (Hsu et al. 2007, §3.1 and §3.3).

A discrete compression selects output frames ``y_0 < y_1 < ... < y_{m-1}`` among the input frames
``0 .. n-1`` with ``y_0 = 0``, ``y_{m-1} = n - 1`` and ``1 <= y_{q+1} - y_q <= s`` (§3.1). Its cost is
``sum_{q=1}^{m-2} f(y_{q-1}, y_q, y_{q+1})`` (eq. 1). Vertices are frame pairs ``(i, j)``, ``1 <= j - i <= s``;
edges ``(i, j) -> (j, k)`` weigh ``f(i, j, k)``; the path has exactly ``m - 2`` edges (eqs. 3-4, [Sai68]).

The recurrence runs over output frames ``q`` and is vectorised over the admissible frames of that output
frame, ``lo[q] <= y_q <= hi[q]``: the bounds follow from the skip limit, the end points, the keytimes
(vertices the path must pass at given ``q``, "restarting" the recurrence there) and, for the coarse-to-fine
heuristic, a band around a coarse solution. Backpointers are int8 (``s <= 127``). Where the optional C
extension ``_cdp.c`` is built (:func:`accelerated`) the recurrence's loop runs there: the same sums and minima, so
the same frames and cost, 1.4-2.5x faster per solve on CMU 01_01 (``benchmarks/bench_dp_accel.py``).

Score tables come from :func:`.objective.knn_scores`: ``scores[j, a-1, b-1] = f(j-a, j, j+b)``, shape
``(n, s, s)``, inf where not admissible.
"""
from __future__ import annotations

import numpy as np

from ..core.accel import accel_allowed

try:
    from . import _cdp  # the optional C kernel of constrained_dp's forward pass (setup.py builds it where it can)
except ImportError:  # pragma: no cover - depends on the build
    _cdp = None

KEEP_COSTS_BYTES = 256 << 20   # constrained_dp keeps every output frame's costs below this, else int8 backpointers

__all__ = ["warp_bounds", "constrained_dp", "accelerated", "unconstrained_dp", "mean_cost_dp", "input_time_dp",
           "step_weights", "path_cost", "validate_keys", "check_ends"]


def validate_keys(n: int, m: int, skip: int, keys=None) -> list[tuple[int, int]]:
    """Check ``keys``, a list of ``(output_frame q, input_frame y)`` pairs, and add the end points.

    Raises ``ValueError`` naming ``num_frames`` when ``m`` cannot be reached at all with skip ``s``
    (``m < (n - 1) / s + 1`` or ``m > n``), and naming ``keytimes`` when the keys are out of range, out of
    order, or leave a segment that is too short or too long for the skip limit.
    """
    if n < 2:
        raise ValueError(f"the input motion needs at least 2 frames, got {n}")
    if m < 2:
        raise ValueError(f"num_frames must be >= 2, got {m}")
    if m > n:
        raise ValueError(f"num_frames={m} is more than the {n} input frames: a compression cannot expand "
                         "time; upsample the input first (upsample=...)")
    if (m - 1) * skip < n - 1:
        raise ValueError(f"num_frames={m} is too short for skip={skip}: at most {skip} input frames per "
                         f"output frame needs num_frames >= {-(-(n - 1) // skip) + 1}")
    pts = [(0, 0)]
    for q, y in sorted(keys or [], key=lambda p: p[0]):
        q, y = int(q), int(y)
        if not (0 <= q <= m - 1) or not (0 <= y <= n - 1):
            raise ValueError(f"keytimes: key (output frame {q}, input frame {y}) is outside "
                             f"[0, {m - 1}] x [0, {n - 1}]")
        if (q, y) == pts[-1] or (q == m - 1 and y == n - 1):
            continue
        pts.append((q, y))
    pts.append((m - 1, n - 1))
    for (q0, y0), (q1, y1) in zip(pts[:-1], pts[1:]):
        if q1 <= q0 or y1 <= y0:
            raise ValueError(f"keytimes out of order: (output frame {q0}, input frame {y0}) then (output frame {q1}, "
                             f"input frame {y1}); both must increase strictly once rounded to frames (keys closer "
                             "than a frame apart collide)")
        if not (q1 - q0 <= y1 - y0 <= (q1 - q0) * skip):
            raise ValueError(f"keytimes: {y1 - y0} input frames between output frames {q0} and {q1} cannot be "
                             f"covered in {q1 - q0} steps of 1..{skip} frames")
    return pts


def warp_bounds(n: int, m: int, skip: int, keys=None) -> tuple[np.ndarray, np.ndarray]:
    """Admissible input frames ``lo[q] <= y_q <= hi[q]`` of every output frame, each (m,) int64.

    Every value in the range is reachable from the previous key and can reach the next one.
    """
    pts = validate_keys(n, m, skip, keys)
    q = np.arange(m)
    lo = np.zeros(m, dtype=np.int64)
    hi = np.full(m, n - 1, dtype=np.int64)
    for Q, Y in pts:
        after = q >= Q
        lo[after] = np.maximum(lo[after], Y + (q[after] - Q))
        hi[after] = np.minimum(hi[after], Y + (q[after] - Q) * skip)
        before = ~after
        hi[before] = np.minimum(hi[before], Y - (Q - q[before]))
        lo[before] = np.maximum(lo[before], Y - (Q - q[before]) * skip)
    return lo, hi


def check_ends(ends, skip: int):
    """``ends = (start (s,), end (s,))`` or None -> two float arrays (or None); ValueError naming ``ends``."""
    if ends is None:
        return None
    try:
        start, end = (np.asarray(e, dtype=float).reshape(-1) for e in ends)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"ends must be a (start, end) pair of ({skip},) arrays, got {ends!r}") from exc
    if start.shape != (skip,) or end.shape != (skip,):
        raise ValueError(f"ends must be a (start, end) pair of ({skip},) arrays, got shapes {start.shape}, {end.shape}")
    return start, end


def constrained_dp(scores: np.ndarray, m: int, keys=None, lo=None, hi=None, progress=None, ends=None):
    """Optimal discrete compression with exactly ``m`` output frames (eqs. 3-4).

    Parameters
    ----------
    scores : (n, s, s) local scores, ``scores[j, a-1, b-1] = f(j-a, j, j+b)``
    m : number of output frames
    keys : list of (output_frame, input_frame) pairs the warp must pass, or None
    lo, hi : optional (m,) int arrays that further restrict ``y_q`` (the coarse-to-fine band)
    progress : callable(fraction) or None
    ends : ``(start (s,), end (s,))`` or None: the scores of the first and last output frame for each first /
        last step (:func:`.objective.end_scores`), added to eq. (1) (None: eq. (1) as printed, which charges
        no term for the end frames, see :func:`path_cost`)

    Returns
    -------
    frames : (m,) int64, the selected input frames ``y_q`` (0 first, n-1 last, steps in [1, s])
    cost : float, the summed score of eq. (1) (+ the end terms); inf if the band leaves no path
    """
    scores = np.asarray(scores, dtype=float)
    n, s, _ = scores.shape
    ends = check_ends(ends, s)
    blo, bhi = warp_bounds(n, m, s, keys)
    if lo is not None:
        blo = np.maximum(blo, np.asarray(lo, dtype=np.int64))
    if hi is not None:
        bhi = np.minimum(bhi, np.asarray(hi, dtype=np.int64))
    if np.any(blo > bhi):
        return np.round(np.linspace(0, n - 1, m)).astype(np.int64), np.inf
    if m == 2:
        return np.array([0, n - 1], dtype=np.int64), (0.0 if ends is None else
                                                       float(ends[0][n - 2] + ends[1][n - 2]))
    # Sab[a-1, b-1, j] = f(j - a, j, j + b): middle frames innermost, so every step below runs over long
    # contiguous rows (c broadcast along b, the min over a) instead of 8-element inner loops
    Sab = np.ascontiguousarray(np.transpose(scores, (1, 2, 0)))
    # c[a-1, k - lo[q]]: best cost of output frames 0..q with y_q = k, y_{q-1} = k - a.
    # q = 1: y_0 = 0, so the pair (0, k) has a = k and cost 0.
    k = np.arange(blo[1], bhi[1] + 1)
    c = np.full((s, k.size), np.inf)
    ok = (k >= 1) & (k <= s)
    c[k[ok] - 1, np.nonzero(ok)[0]] = 0.0 if ends is None else ends[0][k[ok] - 1]
    # Backtracking needs, per output frame, the minimising a of every (y_q, b). Keeping the cost arrays c of
    # every q (8 bytes per state) and re-deriving the single argmin met while backtracking is ~2x faster than
    # int8 backpointers for the whole band (one comparison pass per a); above KEEP_COSTS_BYTES the
    # backpointers are used. Both pick the largest a on exact ties: the same frames, bit for bit.
    widths = bhi[1:m - 1] - blo[1:m - 1] + 1
    if accelerated() and not np.isnan(Sab).any():   # the C loop (the same sums and minima, the same frames)
        c, back = _forward_c(Sab, blo, bhi, c, m, progress)
        return _backtrack(Sab, blo, c, back, m, n, s, ends, keep_costs=False)
    keep_costs = int(widths.sum()) * s * 8 <= KEEP_COSTS_BYTES
    back = [None, None]
    step = max(1, (m - 2) // 100)
    tmp_buf = np.empty((s, s, int((bhi - blo).max()) + 1))
    item = np.dtype(float).itemsize
    for q in range(1, m - 1):
        l0, l1 = blo[q], bhi[q]
        # best[b-1, j] = min_a c[a-1, j] + f(j - a, j, j + b) over the middle frames j = l0..l1
        Lq = l1 - l0 + 1
        tmp = np.add(c[:, None, :], Sab[:, :, l0:l1 + 1], out=tmp_buf[:, :, :Lq])     # (a, b, Lq)
        # best lands inside an inf-padded buffer B (b, columns j = jlo .. jhi: every j = k - b the next
        # output frame can ask for); the next costs c[b-1, k - n0] = B[b-1, k - b - jlo] are a strided *view*
        # of B (no shifting copies; the same numbers)
        n0, n1 = blo[q + 1], bhi[q + 1]
        jlo, jhi = min(l0, n0 - s), max(l1, n1 - 1)
        W = jhi - jlo + 1
        B = np.empty((s, W))
        B[:, :l0 - jlo] = np.inf
        B[:, l1 - jlo + 1:] = np.inf
        best = np.minimum.reduce(tmp, axis=0, out=B[:, l0 - jlo:l1 - jlo + 1])
        if keep_costs:
            back.append(c)
        else:
            # argmin over a by comparisons (faster than ndarray.argmin(axis=0), which copies); on exact ties
            # the largest a wins (any minimiser is optimal)
            arg = np.zeros((s, Lq), dtype=np.int8)
            for a in range(1, s):
                np.copyto(arg, np.int8(a), where=tmp[a] == best)
            back.append(arg)
        # element (b-1, kk) of the next c sits at column (n0 - 1 - jlo) + kk - (b-1) of row b-1 of B
        c = np.ndarray((s, n1 - n0 + 1), dtype=float, buffer=B, offset=(n0 - 1 - jlo) * item,
                       strides=((W - 1) * item, item))
        if progress is not None and (q % step == 0 or q == m - 2):
            progress(q / (m - 2))
    return _backtrack(Sab, blo, c, back, m, n, s, ends, keep_costs)


def accelerated() -> bool:
    """Whether :func:`constrained_dp`'s forward pass runs in C (``_cdp.c`` is built and ``STAGGER_NB_NO_ACCEL``
    is unset or 0; scores holding a NaN always take the numpy path)."""
    return _cdp is not None and accel_allowed()


def _forward_c(Sab, blo, bhi, c, m: int, progress):
    """:func:`constrained_dp`'s loop over output frames 1 .. m - 2 in C (``_cdp.forward``), in chunks of 1 % for
    ``progress``: ``(c, back)``, the costs of output frame m - 1 and the int8 backpointers of every step (views
    of one buffer, indexed as the numpy path's)."""
    s, _, n = Sab.shape
    blo = np.ascontiguousarray(blo, dtype=np.int64)
    bhi = np.ascontiguousarray(bhi, dtype=np.int64)
    widths = bhi - blo + 1
    wmax = int(widths.max())
    cur = np.empty((s, wmax))
    cur[:, :c.shape[1]] = c
    sizes = np.zeros(m, dtype=np.int64)
    sizes[1:m - 1] = widths[1:m - 1] * s
    offsets = np.ascontiguousarray(np.cumsum(sizes) - sizes)
    buf = np.empty(int(sizes.sum()), dtype=np.int8)
    step = max(1, (m - 2) // 100)
    q = 1
    while q < m - 1:
        q1 = min(m - 1, q + step)
        _cdp.forward(Sab, n, s, blo, bhi, q, q1, cur, wmax, buf, offsets)
        if progress is not None:
            progress((q1 - 1) / (m - 2))
        q = q1
    back = [None, None] + [buf[offsets[q]:offsets[q] + sizes[q]].reshape(s, int(widths[q])) for q in range(1, m - 1)]
    return cur[:, :int(widths[m - 1])], back


def _backtrack(Sab, blo, c, back, m: int, n: int, s: int, ends, keep_costs: bool):
    """The frames and cost of :func:`constrained_dp` from the last output frame's costs ``c`` and the per-step
    ``back`` (cost arrays with ``keep_costs``, else int8 backpointers)."""
    # q = m - 1: y = n - 1 (lo = hi = n - 1)
    last = c[:, 0] if ends is None else c[:, 0] + ends[1]
    b = int(np.argmin(last))
    cost = float(last[b])
    if not np.isfinite(cost):   # no admissible path (an infeasible band or inadmissible triples): nothing to follow
        return np.round(np.linspace(0, n - 1, m)).astype(np.int64), np.inf
    frames = np.empty(m, dtype=np.int64)
    frames[m - 1] = n - 1
    y, bb = n - 1, b + 1
    for q in range(m - 1, 1, -1):
        j = y - bb
        if keep_costs:
            v = back[q][:, j - blo[q - 1]] + Sab[:, bb - 1, j]      # the same sums as the forward pass
            a = int(s - np.argmin(v[::-1]))                          # the largest minimising a
        else:
            a = int(back[q][bb - 1, j - blo[q - 1]]) + 1
        frames[q - 1] = j
        y, bb = j, a
    frames[0] = 0
    return frames, cost


def unconstrained_dp(scores: np.ndarray, offset: float = 0.0, ends=None):
    """Shortest path from frame 0 to frame n-1 with any number of output frames (§3.3, "a simple shortest
    path search").

    ``offset`` is subtracted from every edge weight (``f - offset``, and from both end terms; used by
    :func:`mean_cost_dp`); ``ends = (start (s,), end (s,))`` adds the end frames' terms (:func:`constrained_dp`).
    Returns ``(frames (m,) int64, cost)``, cost the summed ``f - offset``; ``m`` is whatever the optimum uses.

    One pass over the input frames, O(n s^2): the state is ``g[j, b-1]``, the best cost of a path that leaves
    frame ``j`` with step ``b`` (its frames up to ``j`` charged); the cost of arriving at ``j`` with step ``a`` is
    ``g[j - a, a - 1]``, read as one strided view of the flat table (a few numpy calls per frame: ~4 us, 55 ms
    on 11,000 searched frames); the minimising predecessors are re-derived only along the path.
    """
    scores = np.asarray(scores, dtype=float)
    n, s, _ = scores.shape
    if n < 2:
        raise ValueError(f"the input motion needs at least 2 frames, got {n}")
    ends = check_ends(ends, s)
    off = float(offset)
    start = np.zeros(s) if ends is None else ends[0]
    end = np.zeros(s) if ends is None else ends[1]
    start, end = start - off * (ends is not None), end - off * (ends is not None)
    S = scores - off if off else scores
    G = np.full((n + s, s), np.inf)          # row s + j: g[j]; s rows of inf before frame 0
    G[s] = start                             # leaving frame 0 with step b: no triple yet
    flat = G.reshape(-1)
    tmp = np.empty((s, s))

    def arriving(j):
        """(s,) view: the cost of arriving at frame j with step a = 1..s (inf where j - a < 0)."""
        if s == 1:
            return flat[(j + s) * s - 1:(j + s) * s]
        hi = (j + s) * s - s
        lo = j * s + s - 1
        return flat[hi:lo - 1 if lo >= 1 else None:-(s - 1)]

    for j in range(1, n - 1):
        np.add(arriving(j)[:, None], S[j], out=tmp)
        np.min(tmp, axis=0, out=G[s + j])
    c_last = arriving(n - 1) + end
    a = int(np.argmin(c_last))
    cost = float(c_last[a])
    frames = [n - 1]
    y, b = n - 1, a + 1
    while True:
        j = y - b
        frames.append(j)
        if j <= 0:
            break
        v = arriving(j) + S[j, :, b - 1]
        a = int(np.argmin(v)) + 1
        y, b = j, a
    return np.array(frames[::-1], dtype=np.int64), cost


def mean_cost_dp(scores: np.ndarray, max_iter: int = 50, ends=None):
    """Free-length warp: the path from frame 0 to frame n-1 with the least *mean* score per interior output
    frame, ``min_P sum_P f / (m_P - 2)`` (any number of output frames).

    The paper's plain shortest path (§3.3, V8) sums one non-negative ``f`` per output frame, so it always
    prefers fewer output frames: on CMU 01_01 it plays a self-referenced clip at 0.70x its length and a 1.5x
    slow-motion reference at 1.0x. The mean per output frame is length-neutral: every output frame is judged
    by how well its pose/velocity/acceleration matches the reference (eq. 2), whatever the count.
    Solved exactly by Dinkelbach's parametric method: repeat ``frames = argmin sum (f - lam)`` (a shortest
    path, :func:`unconstrained_dp` with ``offset=lam``) and ``lam = mean f of frames`` until ``lam`` stops
    decreasing (it decreases strictly until the optimum; a few iterations in practice).

    With ``ends`` (the end frames' terms, :func:`constrained_dp`) every output frame carries a score, and the
    mean is over all ``m`` frames: ``(start + sum f + end) / m``.

    Returns ``(frames (m,) int64, mean)``; ``mean`` is the mean ``f`` over the interior frames (0 if m == 2),
    or over all frames with ``ends``.
    """
    scores = np.asarray(scores, dtype=float)
    ends = check_ends(ends, scores.shape[1])

    def count(f):
        return max(f.size - 2, 1) if ends is None else f.size

    frames, cost = unconstrained_dp(scores, ends=ends)
    lam = cost / count(frames)
    for _ in range(max_iter):
        if not np.isfinite(lam):
            break
        cand, _ = unconstrained_dp(scores, offset=lam, ends=ends)
        c = path_cost(scores, cand, ends)
        new = c / count(cand)
        if not new < lam - 1e-12 * max(abs(lam), 1.0):
            break
        frames, lam = cand, new
    return frames, float(lam)


def step_weights(skip: int) -> np.ndarray:
    """``W[a-1, b-1] = (a + b) / 2``, shape (s, s): the input time (in searched frames) that an output frame
    placed between steps ``a`` and ``b`` stands for (half of each neighbouring step)."""
    a = np.arange(1, int(skip) + 1, dtype=float)
    return 0.5 * (a[:, None] + a[None, :])


def input_time_dp(scores: np.ndarray, ends=None):
    """Free-length warp: the path from frame 0 to frame n-1 (any number of output frames) minimising the local
    score *integrated over input time*, ``sum_q f(y_{q-1}, y_q, y_{q+1}) (y_{q+1} - y_{q-1}) / 2``.

    Each stretch of the input is judged once, by how well the speed the warp gives it matches the reference
    (eq. 2), however many output frames it spends there: the objective is length-neutral.  The paper's plain
    sum over output frames (§3.3, V8) always prefers fewer frames (a self-referenced clip comes out at 0.70x
    its length on CMU 01_01); the mean per output frame (:func:`mean_cost_dp`) is neutral for a self reference
    but rewards lingering (many slow frames) on poses that match the reference well, which, with another
    performer's motion as reference, plays the clip slower instead of at the reference's speed.  The price:
    input poses the reference lacks are timed by whatever speed matches best, and with a slow-motion
    reference that is slow (V8's ground frames, see :func:`.guided.guided_warp`).  A plain shortest path
    (:func:`unconstrained_dp`) on the weighted scores ``f * (a + b) / 2``: ``O(n s^2)``.

    With ``ends`` the first and last frames are charged too, weighted by half their step (the weights then sum
    to the input's length).

    Returns ``(frames (m,) int64, weighted cost)``.
    """
    scores = np.asarray(scores, dtype=float)
    s = scores.shape[1]
    ends = check_ends(ends, s)
    half = 0.5 * np.arange(1, s + 1)
    we = None if ends is None else (ends[0] * half, ends[1] * half)
    return unconstrained_dp(scores * step_weights(s)[None], ends=we)


def path_cost(scores: np.ndarray, frames, ends=None) -> float:
    """Objective (eq. 1) of a selection ``frames (m,)``: the sum of ``f`` over its interior frames, plus with
    ``ends = (start, end)`` the end frames' terms ``start[first step - 1] + end[last step - 1]``."""
    f = np.asarray(frames, dtype=np.int64)
    extra = 0.0
    if ends is not None and f.size >= 2:
        start, end = check_ends(ends, np.asarray(scores).shape[1])
        extra = float(start[f[1] - f[0] - 1] + end[f[-1] - f[-2] - 1])
    if f.size < 3:
        return extra
    a = f[1:-1] - f[:-2]
    b = f[2:] - f[1:-1]
    return float(scores[f[1:-1], a - 1, b - 1].sum()) + extra
