"""Keeping a timing edit's knots in order (Coleman et al. 2008, §5.2, made safe at any slider value):
:func:`saturate_offsets` soft-floors every segment's length (no segment plays more than ``limit`` times faster,
a joint's knots never cross) and :func:`inside_ends` eases interior knots that would reach the clip's ends.

Used by the temporal edits of :mod:`~.timing` (:func:`~.timing.succession`, :func:`~.timing.random_timing`);
the limits are declared once, in :mod:`stagger_nb.core.limits`.
"""
from __future__ import annotations

import weakref

import numpy as np

from ..core.limits import MAX_TIMING_LIMIT, TIMING_LIMIT
from ._checks import _finite
from .channel import ROTATION
from .evaluation import channel_at
from .representation import StaggeredMotion

__all__ = ["saturate_offsets", "inside_ends", "END_FLOOR"]


END_FLOOR = 0.25   # an end segment keeps at least this share of half its pose spacing (x8 squeeze at most)


def inside_ends(knots: np.ndarray, pose_times: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """Knot times ``knots (K, C)`` seconds with the ``moved (K, C)`` interior knots kept inside the clip's ends.

    The first and last staggered poses are the clip's first and last frames (§4.1: "We force the first and last
    frame of the motion to have poses, as this is necessary to fully reconstruct the motion"), so their knots
    bound every control variable. A timing edit (§5.2) that moves an interior knot of column ``c`` past
    ``U = knots[-1, c] - h`` (``h`` half the last pose spacing ``t_{K-1} - t_{K-2}``) is eased towards the end:

        T -> U + (1 - f) h (1 - exp(-(T - U) / ((1 - f) h))),   f = 0.25

    identity up to ``U`` (where every knot of an unedited extraction sits: a refinement is closer to its own
    pose than to the neighbours), C1 there, increasing, and below ``knots[-1, c] - f h``: the last segment
    keeps at least ``f h`` seconds (its motion plays at most 8x faster than over the pose spacing) instead of
    being squeezed into a frame or two, and the last pose's knot stays the last (the clip's last frame shows
    the last pose). The first segment mirrors it (``L = knots[0, c] + (t_1 - t_0) / 2``). Knots that are not
    ``moved`` and the end rows are returned as they are. ``K < 3``: no interior knots.
    """
    out = np.array(knots, dtype=float)
    K = out.shape[0]
    if K < 3:
        return out
    inner, mv = out[1:-1], np.asarray(moved, bool)[1:-1]
    for h, edge, sign in ((0.5 * (pose_times[-1] - pose_times[-2]), out[-1], 1.0),
                          (0.5 * (pose_times[1] - pose_times[0]), out[0], -1.0)):
        room = (1.0 - END_FLOOR) * h
        start = edge - sign * h                                   # U (last segment) or L (first)
        x = sign * (inner - start)                                # depth into the end zone (s), > 0 inside
        eased = start + sign * room * -np.expm1(-np.maximum(x, 0.0) / room)
        inner[...] = np.where(mv & (x > 0), eased, inner)
    return out


_IDENTITY_SHARE = 0.5  # a segment keeping at least this share of its room above its floor keeps its raw length


def _check_limit(limit) -> float | None:
    if limit is None:
        return None
    if isinstance(limit, (bool, np.bool_)):
        raise ValueError(f"limit must be a number > 1 or None (the paper's raw offsets), got {limit!r}")
    limit = _finite(limit, "limit")
    if not 1 < limit <= MAX_TIMING_LIMIT:
        raise ValueError(f"limit must be in (1, {MAX_TIMING_LIMIT:g}] (the largest speed-up of a segment) or None, "
                         f"got {limit}")
    return limit


_FAST_FLOOR = 0.9      # the fastest segment of a joint keeps at least this share of its length (a 1.1x speed-up)


def saturate_offsets(knots, offsets, limit: float = TIMING_LIMIT, *, source_knots=None,
                     floors=None, priority=None) -> np.ndarray:
    """Timing offsets ``offsets (K, C)`` (seconds) saturated smoothly so that no segment between two knots
    of a column shrinks below its floor: the edited knots ``knots + result`` stay strictly increasing, and
    no segment plays more than ``1 / floor`` times faster than in the source.

    Per column, with ``S_k`` a segment's length in the source (``source_knots``; default ``knots``) and
    ``x`` its edited length (the raw offsets added exactly), the length is soft-floored at ``a S_k``
    (``a`` = ``floors[k, c]``, default ``1 / limit``): with ``u = (x / S_k - a) / (1 - a)``, ``u`` is kept
    where ``u >= 1/2`` (every stretch, and compressions to ``a + (1 - a) / 2`` of the length, stay exact) and
    becomes ``exp(2 u - 1) / 2`` below (C1 there, > 0, tending to 0: the segment tends to, never reaches,
    ``a S_k``). The time a floored segment keeps in excess is given back by its neighbours, from their room
    above their own floors, passed on from segment to segment until it is absorbed: by the segments before
    it when its first knot moved later (a delay: the segment the delay stretched gives it back first), after
    it when its last knot moved earlier (a lead), in proportion when both; what reaches a column's end goes
    back the other way. The column's first and last knots stay where the raw offsets put them. So a pose's
    delay is cut locally (by the segment it stretched), a succession's uniform delay stays uniform through
    the clip and the joint catches up over its last segments (eased ends), random offsets are cut where they
    would squeeze a segment. Smooth (C1) in the offsets; columns without offsets stay exactly as they are,
    and so do columns whose knots are out of order (nothing to measure a speed-up against: their raw offsets).

    Parameters
    ----------
    knots : ndarray (K, C), seconds
        Knot times before the edit (``t_k + r[k, c]``).
    offsets : ndarray (K, C), seconds
    limit : float > 1
        Largest speed-up of a segment where ``floors`` is not given.
    source_knots : ndarray (K, C), seconds, optional
        The knots the floors refer to (before any timing edit: successive edits then cannot compound their
        speed-ups); default ``knots``.
    floors : ndarray (K - 1, C) in (0, 1), optional
        Per-segment floor ``a`` (e.g. higher where a joint moves fast: :func:`succession` uses the segment's
        speed); default ``1 / limit``.
    priority : array_like (K,), optional
        Per knot (pose), how much it holds its offsets when a segment is squeezed (magnitudes): a floored
        segment between knots of priorities ``p0, p1`` gives its excess back on the side of the lower one (that
        knot gives way), whichever way the knots moved: with ``d = (p1 - p0) / (p0 + p1)`` the share sent back
        moves linearly from the rule above (``d = 0``) to all of it (``d = 1``), forward at ``d = -1``. With a
        region's weights (``succession(weights=...)``) the poses the region selects keep their offsets and the
        transition to the poses it leaves alone moves outward (they may then move more than asked). Default
        (None) or equal priorities: the rule above.

    Returns
    -------
    ndarray (K, C), seconds: the offsets to add.
    """
    T = np.asarray(knots, dtype=float)
    o = np.asarray(offsets, dtype=float)
    limit = _check_limit(limit)
    out = np.array(o)
    if T.shape[0] < 2:
        return out
    Ts = T if source_knots is None else np.asarray(source_knots, dtype=float)
    D, S = np.diff(T, axis=0), np.diff(Ts, axis=0)
    cols = np.flatnonzero(np.any(o != 0, axis=0) & np.all(D > 0, axis=0) & np.all(S > 0, axis=0))
    if not cols.size:
        return out
    T, o, D, S = T[:, cols], o[:, cols], D[:, cols], S[:, cols]
    if floors is None:
        a = np.full(D.shape, 1.0 / limit)
    else:
        a = np.clip(np.asarray(floors, dtype=float)[:, cols], 1e-6, 1.0 - 1e-6)
    Tn = T + o

    def floor(x, k):          # segment k's soft-floored length for a wanted length x
        u = (x / S[k] - a[k]) / (1.0 - a[k])
        c = _IDENTITY_SHARE
        u = np.where(u >= c, u, c * np.exp(np.minimum(u - c, 0.0) / c))
        return S[k] * (a[k] + (1.0 - a[k]) * u)

    x = np.diff(Tn, axis=0)
    n = x.shape[0]
    Dp = np.stack([floor(x[k], k) for k in range(n)]) if n else x
    excess = Dp - x                                   # >= 0: what each floored segment keeps
    # a segment squeezed by its first knot moving later gives its excess back before it (the segments that
    # delay stretched), one squeezed by its last knot moving earlier after it; both: in proportion
    wb, wf = np.maximum(o[:-1], 0.0), np.maximum(-o[1:], 0.0)
    tot = wb + wf
    share = np.where(tot > 0, wb / np.where(tot > 0, tot, 1.0), 0.5)
    if priority is not None:
        p = np.asarray(priority, dtype=float).reshape(-1)
        if p.shape != (T.shape[0],) or not np.all(np.isfinite(p)):
            raise ValueError(f"priority must be {T.shape[0]} finite numbers (one per knot), got shape {p.shape}")
        p = np.abs(p)
        tp = p[:-1] + p[1:]
        d = np.where(tp > 0, (p[1:] - p[:-1]) / np.where(tp > 0, tp, 1.0), 0.0)[:, None]   # in [-1, 1]
        # d > 0: the first knot holds less, it gives way (the excess goes back, share -> 1 at d = 1); d < 0: the
        # last knot gives way (forward, share -> 0); linear in d: continuous as a sigma slider moves the weights
        share = np.where(d > 0, share + d * (1.0 - share), share + d * share)
    back = excess * share
    fwd = excess - back
    carry = np.zeros(cols.size)
    want = x.copy()                                   # each segment's length before its floor
    passes = ((range(n - 1, -1, -1), back), (range(n), fwd), (range(n - 1, -1, -1), None))
    for order, own in passes:
        for k in order:
            want[k] = want[k] - carry
            d = floor(want[k], k)
            carry = carry - (Dp[k] - d) + (own[k] if own is not None else 0.0)   # what it could not absorb
            Dp[k] = d
    if np.any(carry > 1e-12):                        # every segment at its floor: share the rest by room
        room = Dp - a * S
        R = room.sum(axis=0)
        lam = np.where(R > 0, np.clip(1.0 - carry / np.where(R > 0, R, 1.0), 0.0, 1.0), 1.0)
        Dp = np.where(carry > 1e-12, a * S + room * lam, Dp)
    new = Tn[:1] + np.concatenate([np.zeros((1, cols.size)), np.cumsum(Dp, axis=0)])
    new[-1] = Tn[-1]
    # knots the saturation left where the raw offsets put them (to the cumulative sum's rounding) keep the
    # raw offsets exactly: an edit that squeezes nothing is the paper's formula, bit for bit
    same = np.abs(new - Tn) <= 1e-12 * (1.0 + np.abs(Tn))
    out[:, cols] = np.where(same, o, new - T)
    return out


_PATHS: dict = {}     # id(displacement table) -> (weak reference to it, its paths): timing edits share tables


def _map_paths(table: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Path length of each displacement map ``table (..., M, 3)`` over its ``counts (...)`` valid samples
    (radians, or file units for the root translation); cached per table (timing edits do not copy it)."""
    hit = _PATHS.get(id(table))
    if hit is not None and hit[0]() is table:
        return hit[1]
    M = table.shape[-2]
    if M < 2:
        out = np.zeros(table.shape[:-2])
    else:
        d = np.diff(table, axis=-2)
        step = np.sqrt(np.einsum("...i,...i->...", d, d))
        out = np.where(np.arange(M - 1) < (counts[..., None] - 1), step, 0.0).sum(axis=-1)
    if len(_PATHS) > 64:
        _PATHS.clear()
    _PATHS[id(table)] = (weakref.ref(table), out)
    return out


_PEAK_FLOOR = 0.8     # a segment's peak speed plays at most 1 / 0.8 = 1.25 times the column's peak speed
_STATIC_RATE = 1e-9   # a column whose peak speed (rad/s, or file units/s) is below this is static (no peak floor)
_PEAKS: dict = {}     # id(rotation displacement table) -> (weak references to the curves' arrays, peak rates)


def _peak_rates(sm: StaggeredMotion) -> np.ndarray:
    """Largest rate of change ``(K - 1, J + 1)`` of each segment's curve ``s(t') ⊕ d(t')`` (§3) per unit of
    normalised segment time ``t'`` (radians, or file units for the root translation, column J): the largest
    step between ``n`` uniform samples of ``t'`` (``n`` the segment's displacement samples, one per source
    frame spanned), times ``n - 1``. Independent of the timing (the curves live on ``t'``), so cached per
    curve arrays (timing edits share them)."""
    chans = (sm.rotations, sm.translation)
    arrays = tuple(a for ch in chans for a in (ch.values, ch.tangents, ch.displacements, ch.counts))
    hit = _PEAKS.get(id(arrays[2]))
    if hit is not None and all(r() is a for r, a in zip(hit[0], arrays)):
        return hit[1]
    cols = []
    for ch in chans:
        n = np.asarray(ch.counts, dtype=np.int64).reshape(ch.counts.shape[0], -1)     # (K-1, C)
        seg, col = np.meshgrid(np.arange(n.shape[0]), np.arange(n.shape[1]), indexing="ij")
        reps = n.reshape(-1)
        first = np.concatenate([[0], np.cumsum(reps)[:-1]])
        i = np.arange(reps.sum()) - np.repeat(first, reps)                 # sample index inside its segment
        tn = i / np.repeat(reps - 1, reps)
        x = np.asarray(channel_at(ch, np.repeat(seg.reshape(-1), reps), np.repeat(col.reshape(-1), reps), tn))
        if ch.algebra is ROTATION:     # 4 asin(chord / 2), q ≡ -q: exact 0 between equal rotations (no arccos noise)
            sign = np.where(np.einsum("nc,nc->n", x[:-1], x[1:]) < 0, -1.0, 1.0)[:, None]
            chord = np.linalg.norm(x[1:] - sign * x[:-1], axis=-1)
            step = 4.0 * np.arcsin(np.clip(0.5 * chord, 0.0, 1.0))
        else:
            step = np.linalg.norm(np.diff(x, axis=0), axis=-1)
        step = np.append(step, 0.0)
        step[np.cumsum(reps) - 1] = 0.0                                    # no step across two segments
        top = np.maximum.reduceat(step, first) * (reps - 1)
        cols.append(top.reshape(n.shape))
    out = np.concatenate(cols, axis=1)
    if len(_PEAKS) > 64:
        _PEAKS.clear()
    _PEAKS[id(arrays[2])] = (tuple(weakref.ref(a) for a in arrays), out)
    return out


def _segment_floors(sm: StaggeredMotion, source: np.ndarray, limit: float) -> np.ndarray:
    """Per-segment floors ``(K - 1, J + 1)`` for :func:`saturate_offsets` (columns: the joints' rotations, then
    the root translation): ``a = clip(v / v_max, 1 / limit, 0.9)`` with ``v`` a segment's mean speed in
    the source's timing (the angle between its knots plus the path of its displacement map, over its source
    length; distances for the root translation) and ``v_max`` the column's fastest segment. A joint may play
    a slow segment up to ``limit`` times faster (never faster than its fastest segment plays in the source),
    its fastest ones at most 1.1 times (its frame-to-frame rotation then grows by at most a tenth where it
    is largest: no pop); static joints up to ``limit`` times.

    A long segment can hold the joint's fastest motion and still be slow on average (a run cycle's four
    poses on 24 frames; a kick between two far-apart poses): its floor is raised to ``min(0.8 p / p_max, 0.9)``
    (``p`` the segment's peak speed in the source's timing, :func:`_peak_rates` over its source length,
    ``p_max`` the column's), so that its peak plays at most 1.25 times ``p_max`` (the joint's largest
    frame-to-frame rotation grows by at most a quarter: 6.9° -> 3.2° of added pop on the run cycle's moderate
    edit). Where that is below the mean-speed floor the floor is unchanged (the same offsets, bit for bit)."""
    S = np.maximum(np.diff(source, axis=0), 1e-12)                       # (K-1, J+1) source lengths
    a = _mean_floors(sm, S, limit)
    peak = _peak_rates(sm) / S
    top = peak.max(axis=0)
    moving = top > _STATIC_RATE
    rel = np.where(moving, peak / np.where(moving, top, 1.0), 0.0)
    return np.maximum(a, np.minimum(_PEAK_FLOOR * rel, _FAST_FLOOR))


def _mean_floors(sm: StaggeredMotion, S: np.ndarray, limit: float) -> np.ndarray:
    """The mean-speed floors of :func:`_segment_floors` for source segment lengths ``S (K - 1, J + 1)`` s."""
    v = sm.values
    dots = np.abs(np.einsum("kjc,kjc->kj", v[:-1], v[1:]))
    ang = 2.0 * np.arccos(np.clip(dots, -1.0, 1.0)) + _map_paths(sm.displacements, sm.displacement_counts)
    rp = (np.linalg.norm(np.diff(sm.root_values, axis=0), axis=-1)
          + _map_paths(sm.root_displacements, sm.root_displacement_counts))
    speed = np.concatenate([ang, rp[:, None]], axis=1) / S
    top = speed.max(axis=0)
    rel = np.where(top > 0, speed / np.where(top > 0, top, 1.0), 0.0)
    return np.clip(rel, 1.0 / limit, _FAST_FLOOR)


def _eased(r: np.ndarray, t: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """Refinements ``r (K, C)`` whose knots :func:`inside_ends` eases, the others exactly as given."""
    T = t[:, None] + r
    E = inside_ends(T, t, moved)
    return np.where(E != T, E - t[:, None], r)
