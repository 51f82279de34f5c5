"""Temporal editing of staggered poses (Coleman et al. 2008, §5.2): succession, random timing, retiming poses
as units, one knot at a time (:func:`refine`, the dope sheet's drag), and the per-control-variable time warp
these edits apply.

The editing tools' conventions and notation: :mod:`stagger_nb.staggered`.

Temporal edits only change ``t_k`` / ``r[k, i]``: splines and displacement maps live on normalised segment time,
so they follow; editing knots are re-created at ``t_k`` by evaluation (Figure 6c, :func:`_refresh`, the common
tail of every edit, geometric and structural too). By default succession and random timing saturate their offsets
(:func:`saturate_offsets`, ``limit``): every joint's knots stay in order and no segment plays more than
``limit`` times faster; what was limited noticeably is said in one sentence
(:func:`~.timing_report.timing_summary`). Refined times that come closer to a neighbouring pose than to
their own are reported as :class:`~.timing_report.TimingWarning` objects in ``sm.metadata["warnings"]`` (also
available from :func:`~.timing_report.timing_warnings`), never printed.
"""
from __future__ import annotations

import weakref

import numpy as np

from ..core.limits import MAX_TAU, MAX_TIMING_LIMIT, TIMING_LIMIT
from . import timing_report
from ._checks import _check, _finite, _joint_mask, _pose_index, _pose_mask, _pose_weights
from .evaluation import evaluate_samples
from .representation import StaggeredMotion
from .timing_report import _LazyWarnings

__all__ = ["succession", "random_timing", "retime", "refine", "source_knot_times", "source_pose_times", "warp_times",
           "inside_ends", "MAX_TAU", "TIMING_LIMIT", "saturate_offsets"]


def source_knot_times(sm: StaggeredMotion) -> np.ndarray:
    """Source time of every knot, shape (K, J + 1), seconds: columns ``0 .. J-1`` the joint rotations'
    knots, column ``J`` the root translation's.

    The per-control-variable time warp that the temporal edits (§5.2) applied is the piecewise-linear map
    ``source_knot_times(sm)[:, c] -> knots[:, c]`` (splines and displacement maps live on normalised segment
    time, so between two knots the edited motion replays the source segment linearly in time; see
    :func:`warp_times`). The editing tools record it in ``sm.metadata["source_knots"]`` at their first
    edit and carry it through retiming, succession, random timing and pose insertion/deletion (and a later
    :func:`~stagger_nb.staggered.cull`, which keeps a subset of the poses at their times: their rows are
    kept). An ``sm`` without the record (a fresh extraction), or whose poses no longer match it (retimed
    by something other than these tools), is taken as unedited: its own knots.
    """
    K, J = sm.num_poses, sm.num_joints
    rec = sm.metadata.get("source_knots")
    if rec is not None:
        rec = np.asarray(rec, dtype=float)
        at = np.asarray(sm.metadata.get("source_knots_pose_times", ()), dtype=float)
        if rec.shape == (K, J + 1) and (at.shape != (K,) or np.allclose(at, sm.pose_times, rtol=0, atol=1e-9)):
            return rec
        if at.shape == (rec.shape[0],) and rec.shape[1:] == (J + 1,):
            # poses culled since the record (cull keeps a subset of the poses at their times): keep their rows
            row = np.searchsorted(at, sm.pose_times)
            row = np.clip(row, 0, at.size - 1)
            if np.allclose(at[row], sm.pose_times, rtol=0, atol=1e-9):
                return rec[row]
    return np.concatenate([ch.knots(sm.pose_times) for ch in sm.channels], axis=1)


def _recorded_rows(sm: StaggeredMotion, rec: np.ndarray) -> np.ndarray | None:
    """The rows of a per-pose record ``rec (K0, ...)`` that belong to ``sm``'s poses (the record's own poses
    are ``metadata["source_knots_pose_times"]``; a cull since keeps a subset of them at their times), or None
    when the record does not fit ``sm``'s poses."""
    K = sm.num_poses
    at = np.asarray(sm.metadata.get("source_knots_pose_times", ()), dtype=float)
    if rec.shape[0] == K and (at.shape != (K,) or np.allclose(at, sm.pose_times, rtol=0, atol=1e-9)):
        return rec
    if at.shape == (rec.shape[0],) and at.size:
        row = np.clip(np.searchsorted(at, sm.pose_times), 0, at.size - 1)
        if np.allclose(at[row], sm.pose_times, rtol=0, atol=1e-9):
            return rec[row]
    return None


def source_pose_times(sm: StaggeredMotion) -> np.ndarray:
    """Source time of every staggered pose, shape (K,), seconds: the time ``t_k`` had in the motion the
    representation was extracted from, before the temporal edits (§5.2) that moved the poses (:func:`retime`,
    a guided retiming of the poses). Recorded by the editing tools in ``sm.metadata["source_pose_times"]``
    beside :func:`source_knot_times` and carried the same way (an inserted pose gets the source time its place
    between its neighbours maps to, linearly); an ``sm`` without the record is taken as unedited: its own
    ``pose_times``. E.g. a magic-wand falloff over the source's frames is read at these times."""
    rec = sm.metadata.get("source_pose_times")
    if rec is not None:
        rows = _recorded_rows(sm, np.asarray(rec, dtype=float).reshape(-1))
        if rows is not None:
            return rows
    return np.array(sm.pose_times)


def _current_knots(sm: StaggeredMotion) -> np.ndarray:
    """Knot times (K, J + 1) in the column layout of :func:`source_knot_times`."""
    return np.concatenate([ch.knots(sm.pose_times) for ch in sm.channels], axis=1)


def warp_times(sm: StaggeredMotion, times, joint, *, inverse: bool = False) -> np.ndarray:
    """Map source times to edited times (or back, ``inverse=True``) through the time warp of one control
    variable: piecewise linear between its knots (§3: each segment is replayed on normalised time).

    Parameters
    ----------
    sm : StaggeredMotion
    times : array_like (N,), seconds
    joint : str or int
        Joint name or index (its rotation's knots), or ``"<root translation>"`` / ``sm.num_joints``.

    Returns
    -------
    (N,) seconds; times outside the first/last knot move with the nearest end knot (slope 1).
    """
    J = sm.num_joints
    if isinstance(joint, str):
        c = J if joint == "<root translation>" else _joint_mask(sm, [joint]).argmax()
    else:
        c = int(joint)
        if not 0 <= c <= J:
            raise ValueError(f"joint: index {joint} outside [0, {J}]")
    return _warp_column(*_warp_tables(sm), c, times, inverse)


def _warp_tables(sm: StaggeredMotion) -> tuple[np.ndarray, np.ndarray]:
    """``(S, T)``, both (K, J + 1): the source and current knot times of every control variable, made
    non-decreasing down each column (the breakpoints of :func:`warp_times`). Computed once, they serve
    any number of :func:`_warp_column` calls (one per contact in ``keep_contacts``)."""
    return np.maximum.accumulate(source_knot_times(sm), axis=0), np.maximum.accumulate(_current_knots(sm), axis=0)


def _warp_column(S: np.ndarray, T: np.ndarray, c: int, times, inverse: bool = False) -> np.ndarray:
    """:func:`warp_times` of column ``c`` from the tables of :func:`_warp_tables`."""
    x = np.asarray(times, dtype=float).reshape(-1)
    a, b = (T[:, c], S[:, c]) if inverse else (S[:, c], T[:, c])
    y = np.interp(x, a, b)
    y = np.where(x < a[0], b[0] + (x - a[0]), y)
    return np.where(x > a[-1], b[-1] + (x - a[-1]), y)


def _refresh(sm: StaggeredMotion, source_knots=None, extra=None, source_poses=None, **fields) -> StaggeredMotion:
    """New StaggeredMotion with ``fields`` replaced, editing knots re-created at ``t_k`` by evaluation
    (Figure 6c; kept equal to the extreme knots where the refinement is 0), timing warnings attached
    as ``metadata["warnings"]`` and the source knot and pose times (:func:`source_knot_times`,
    :func:`source_pose_times`) carried as ``metadata["source_knots"]`` and ``["source_pose_times"]``
    (``source_knots`` / ``source_poses`` override them when the poses change); ``extra``: more metadata entries
    (the timing limits a saturated edit records)."""
    if source_knots is None:
        source_knots = source_knot_times(sm)
    if source_poses is None:
        source_poses = source_pose_times(sm)
    new = sm._with_fields(**fields)          # (arrays the edit did not change are shared, not copied)
    K, J = new.num_poses, new.num_joints
    q = evaluate_samples(new, np.repeat(new.pose_times, J), np.tile(np.arange(J), K)).reshape(K, J, 4)
    editing = np.where((new.refinements != 0)[..., None], q, new.values)
    editing.setflags(write=False)
    meta = {k: v for k, v in dict.items(new.metadata) if k != "warnings"}   # (a lazy entry is not computed)
    sk = np.array(source_knots, dtype=float)
    sk.setflags(write=False)
    meta["source_knots"] = sk
    sp = np.array(source_poses, dtype=float)
    sp.setflags(write=False)
    meta["source_pose_times"] = sp
    meta["source_knots_pose_times"] = new.pose_times        # the rows' poses (a later cull keeps a subset)
    if extra:
        meta.update(extra)
    # the object was created above and is not shared yet: set the two derived fields in place (as
    # __post_init__ does) instead of validating and copying every array a second time
    object.__setattr__(new, "editing_knots", editing)
    fields = (new.pose_times, new.refinements, new.root_refinements, new.values, editing, new.root_values,
              new.frame_time, tuple(new.skeleton.names))
    object.__setattr__(new, "metadata", _LazyWarnings(meta, lambda: timing_report._timing_warnings(*fields)))
    return new


_END_FLOOR = 0.25   # an end segment keeps at least this share of half its pose spacing (x8 squeeze at most)


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
        room = (1.0 - _END_FLOOR) * h
        start = edge - sign * h                                   # U (last segment) or L (first)
        x = sign * (inner - start)                                # depth into the end zone (s), > 0 inside
        eased = start + sign * room * -np.expm1(-np.maximum(x, 0.0) / room)
        inner[...] = np.where(mv & (x > 0), eased, inner)
    return out


_IDENTITY_SHARE = 0.5  # a segment keeping at least this share of its room above its floor keeps its raw length
_NOTICEABLE = 0.1      # a joint's typical offset cut by more than this share (and half a frame): "limited noticeably"


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


def _segment_floors(sm: StaggeredMotion, source: np.ndarray, limit: float) -> np.ndarray:
    """Per-segment floors ``(K - 1, J + 1)`` for :func:`saturate_offsets` (columns: the joints' rotations, then
    the root translation): ``a = clip(v / v_max, 1 / limit, 0.9)`` with ``v`` a segment's mean speed in
    the source's timing (the angle between its knots plus the path of its displacement map, over its source
    length; distances for the root translation) and ``v_max`` the column's fastest segment. A joint may play
    a slow segment up to ``limit`` times faster (never faster than its fastest segment plays in the source),
    its fastest ones at most 1.1 times (its frame-to-frame rotation then grows by at most a tenth where it
    is largest: no pop); static joints up to ``limit`` times."""
    S = np.maximum(np.diff(source, axis=0), 1e-12)                       # (K-1, J+1) source lengths
    v = sm.values
    dots = np.abs(np.einsum("kjc,kjc->kj", v[:-1], v[1:]))
    ang = 2.0 * np.arccos(np.clip(dots, -1.0, 1.0)) + _map_paths(sm.displacements, sm.displacement_counts)
    rp = (np.linalg.norm(np.diff(sm.root_values, axis=0), axis=-1)
          + _map_paths(sm.root_displacements, sm.root_displacement_counts))
    speed = np.concatenate([ang, rp[:, None]], axis=1) / S
    top = speed.max(axis=0)
    rel = np.where(top > 0, speed / np.where(top > 0, top, 1.0), 0.0)
    return np.clip(rel, 1.0 / limit, _FAST_FLOOR)


def _with_timing(sm: StaggeredMotion, dr: np.ndarray, joint_mask: np.ndarray, ease_ends: bool = False,
                 limit: float | None = None, op: str = "", priority=None) -> StaggeredMotion:
    """Add refinement offsets ``dr (K, J)`` (exactly with ``limit=None``; else soft-clipped by
    :func:`saturate_offsets`, the knots noticeably limited recorded in ``metadata["timing_limits"]`` for
    :func:`timing_summary`; with ``ease_ends``, interior knots that would reach the clip's ends are eased,
    :func:`inside_ends`); the root translation follows the root rotation if joint 0 is selected (both are the
    root's timing). ``priority`` (K,): a region's weights, passed to :func:`saturate_offsets`."""
    if not np.any(dr):
        return sm
    t = sm.pose_times
    moved = dr != 0
    ease = _eased if ease_ends else (lambda r, t, moved: r)
    asked = dr
    root_moves = bool(joint_mask[0] and np.any(asked[:, 0]))
    dr0 = asked[:, 0]
    extra = None
    if limit is not None:
        # the joints' rotations and the root translation (column J) in one call
        J = sm.num_joints
        knots = np.concatenate([t[:, None] + sm.refinements, (t + sm.root_refinements)[:, None]], axis=1)
        wanted = np.concatenate([dr, (dr0 if root_moves else np.zeros_like(dr0))[:, None]], axis=1)
        src = source_knot_times(sm)
        ok = src.shape == knots.shape
        kept = saturate_offsets(knots, wanted, limit, source_knots=src if ok else None,
                                floors=_segment_floors(sm, src, limit) if ok else None, priority=priority)
        dr, dr0 = kept[:, :J], kept[:, J]
        # per joint, the typical (mean) offset over the moved knots, asked and kept: a delay that is kept
        # through the clip and eased only over its last segments is not "limited"
        cols = np.flatnonzero(moved.any(axis=0))
        n = moved[:, cols].sum(axis=0)
        want = np.where(moved, np.abs(asked), 0.0)[:, cols].sum(axis=0) / n
        got = np.where(moved, np.abs(dr), 0.0)[:, cols].sum(axis=0) / n
        hit = want - got > np.maximum(_NOTICEABLE * want, 0.5 * sm.frame_time)
        if hit.any():
            names = sm.skeleton.names
            sign = np.sign(asked[np.argmax(moved, axis=0), np.arange(J)]) if op == "succession" else np.ones(J)
            rows = tuple({"op": op, "joint": names[c], "asked": float(sign[c] * w), "applied": float(g)}
                         for c, w, g in zip(cols[hit], want[hit], got[hit]))
            extra = {"timing_limits": tuple(sm.metadata.get("timing_limits") or ()) + rows}
    fields = dict(rotations=sm.rotations.with_arrays(refinements=ease(sm.refinements + dr, t, moved)))
    if root_moves:
        r = sm.translation.refinements
        fields["translation"] = sm.translation.with_arrays(refinements=ease(r + dr0[:, None], t, moved[:, :1]))
    return _refresh(sm, extra=extra, **fields)


def _eased(r: np.ndarray, t: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """Refinements ``r (K, C)`` whose knots :func:`inside_ends` eases, the others exactly as given."""
    T = t[:, None] + r
    E = inside_ends(T, t, moved)
    return np.where(E != T, E - t[:, None], r)


def succession(sm: StaggeredMotion, root="LeftShoulder", s: float = 0.03, l: float = 2.0, *, joints=None,
               poses=None, ease_ends: bool = False, limit: float | None = TIMING_LIMIT,
               weights=None) -> StaggeredMotion:
    """Succession timing (§5.2, after Neff & Fiume 2003): ``r̂[k, i] = r[k, i] + s d(i)^l``.

    By default the offsets ``s d(i)^l`` are saturated smoothly against the neighbouring knots
    (:func:`saturate_offsets` with ``limit``): at any slider value every joint's knots stay in time order
    and no segment plays more than ``limit`` times faster (no collapse, no pop), small offsets are kept
    exactly; the knots that were limited noticeably are recorded for :func:`timing_summary` (one plain
    sentence). ``limit=None`` is the paper's
    formula exactly (a large ``s`` can then bring a knot next to, or past, a neighbour's: the segment plays in
    a frame or two, and :func:`timing_warnings` says so). With ``ease_ends=True`` knots within half a pose
    spacing of the clip's first/last pose are eased (:func:`inside_ends`: the last pose stays the clip's last
    frame, its segment keeps >= 1/8 of the spacing; saturated knots never reach that zone).

    Parameters
    ----------
    root : str or int
        The user-selected joint; ``d(i)`` is the number of bones between it and joint ``i``.
    s : float
        Base timing offset, seconds per unit depth (negative: the extremities lead).
    l : float
        Non-linearity (> 0): 1 is Neff–Fiume's linear succession, larger is looser / cartoony.
    joints : list of joint names, optional
        Joints to stagger; default: ``root`` and its descendants (the limb below the chosen joint).
    poses : list of int, optional
        Poses to stagger; default all interior poses (the first and last poses anchor the clip ends).
    ease_ends : bool
        Ease knots near the clip's ends (:func:`inside_ends`) instead of the exact formula there.
    limit : float > 1 or None
        Largest speed-up of any segment of a joint's curve (default :data:`TIMING_LIMIT`); None: raw offsets.
    weights : array_like (K,), optional
        Scale of each pose's offsets, ``weights[k] s d(i)^l``: a region of the clip, e.g. a magic-wand falloff
        (Dean et al. 2018, §3.3) read at the pose times, so that the poses it selects get the succession and the
        others keep their timing (0). The offsets are scaled before the saturation (``limit``) and the easing;
        where the region's edge squeezes a segment, the saturation gives way on the side of the lower weight
        (``saturate_offsets(priority=weights)``): the poses the region selects keep their offsets.
    """
    _check(sm)
    limit = _check_limit(limit)
    s, l = _finite(s, "s"), _finite(l, "l")
    if l <= 0:
        raise ValueError(f"l must be > 0, got {l}")
    if not isinstance(root, (str, int, np.integer)) or isinstance(root, (bool, np.bool_)):
        raise ValueError(f"root must be a joint name or index, got {root!r}")
    try:
        r = sm.skeleton.index(root) if isinstance(root, str) else int(root)
    except KeyError as e:
        raise ValueError(f"root: {e.args[0]}") from None
    if not 0 <= r < sm.num_joints:
        raise ValueError(f"root: index {root} outside [0, {sm.num_joints})")
    d = sm.skeleton.tree_distance(r).astype(float)
    sub = np.zeros(sm.num_joints, bool)
    sub[r] = True
    for j in range(r + 1, sm.num_joints):   # parents precede children
        sub[j] = sub[sm.skeleton.parents[j]]
    jm = _joint_mask(sm, joints, default=sub)
    pm = _pose_mask(sm, poses, interior_default=True)
    dr = np.where(pm[:, None] & jm[None, :], s * d[None, :] ** l, 0.0)
    w = _pose_weights(sm, weights)
    return _with_timing(sm, _scaled(sm, dr, w), jm, bool(ease_ends), limit, "succession",
                        priority=None if w is None else np.abs(w))


def _scaled(sm: StaggeredMotion, dr: np.ndarray, weights) -> np.ndarray:
    """Refinement offsets ``dr (K, J)`` scaled per pose by ``weights (K,)`` (None: as they are)."""
    w = _pose_weights(sm, weights)
    return dr if w is None else dr * w[:, None]


def random_timing(sm: StaggeredMotion, joints=None, tau: float = 0.05, seed: int = 0, *,
                  poses=None, ease_ends: bool = False, limit: float | None = TIMING_LIMIT,
                  weights=None) -> StaggeredMotion:
    """Random timing offsets (§5.2): ``r̂[k, i] = r[k, i] + U(-τ, τ)`` for the chosen joints (``ease_ends``
    and ``limit``: as in :func:`succession`; by default the offsets are saturated against the neighbouring
    knots, ``limit=None`` adds them exactly).

    The offsets are drawn for the whole ``(K, J)`` table from ``numpy.random.default_rng(seed)`` and then
    masked, so a given seed gives each (pose, joint) the same offset whatever subset is selected.

    Parameters
    ----------
    joints : list of joint names, optional (default all joints)
    tau : float
        Bound of the offsets, seconds, in ``[0, MAX_TAU]`` (:data:`stagger_nb.core.limits.MAX_TAU`, 60 s).
    seed : int
    poses : list of int, optional; default all interior poses.
    ease_ends : bool
        Ease knots near the clip's ends (:func:`inside_ends`) instead of the exact offsets there.
    limit : float > 1 or None
        Largest speed-up of any segment of a joint's curve (default :data:`TIMING_LIMIT`); None: raw offsets.
    weights : array_like (K,), optional
        Scale of each pose's offsets (``weights[k] U(-τ, τ)``) before the saturation, as in :func:`succession`.
    """
    _check(sm)
    limit = _check_limit(limit)
    tau = _finite(tau, "tau")
    if not 0 <= tau <= MAX_TAU:  # core.limits: the one declaration of the bound
        raise ValueError(f"tau must be in [0, {MAX_TAU:g}] seconds, got {tau}")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, (bool, np.bool_)) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")
    jm = _joint_mask(sm, joints)
    pm = _pose_mask(sm, poses, interior_default=True)
    u = np.random.default_rng(int(seed)).uniform(-tau, tau, size=(sm.num_poses, sm.num_joints))
    w = _pose_weights(sm, weights)
    dr = _scaled(sm, np.where(pm[:, None] & jm[None, :], u, 0.0), w)
    return _with_timing(sm, dr, jm, bool(ease_ends), limit, "random_timing", priority=None if w is None else np.abs(w))


def retime(sm: StaggeredMotion, pose_times) -> StaggeredMotion:
    """Retime staggered poses as units (§5.2): new ``t_k``; refinements, splines and displacement maps are
    relative to it and follow.

    Parameters
    ----------
    pose_times : list of K seconds, or dict {pose index: seconds} (JSON keys may be strings)
        New times; must stay strictly increasing.
    """
    _check(sm)
    t = np.array(sm.pose_times)
    if isinstance(pose_times, dict):
        for k, v in pose_times.items():
            t[_pose_index(sm, int(k), "pose_times key")] = _finite(v, f"pose_times[{k}]")
    else:
        new = np.asarray(pose_times, dtype=float).reshape(-1)
        if new.shape != t.shape or not np.all(np.isfinite(new)):
            raise ValueError(f"pose_times must hold {t.size} finite seconds, got {np.shape(pose_times)}")
        t = new
    if not np.all(np.diff(t) > 0):
        raise ValueError("pose_times must be strictly increasing")
    if np.array_equal(t, sm.pose_times):
        return sm
    return _refresh(sm, pose_times=t)


def refine(sm: StaggeredMotion, pose: int, joint, time: float) -> StaggeredMotion:
    """Put joint ``joint``'s knot of pose ``pose`` at the refined time ``time`` seconds: ``r[k, j] = time - t_k``.

    The knot must stay strictly between the same joint's knots of the neighbouring poses (``T[k - 1, j] < time
    < T[k + 1, j]``): a knot past its neighbour would reverse that joint's motion between them. The first and
    last poses are the clip's first and last frames (§4.1) and keep their knots. The root joint's knot moves
    its translation's knot by the same amount (both are the root's timing, as in :func:`succession`), which
    must then stay in order too.

    Parameters
    ----------
    sm : StaggeredMotion
    pose : int, an interior pose index (0 < pose < K - 1; negative indices count from the end)
    joint : str or int, joint name or index
    time : float, seconds, the knot's new refined time ``t_k + r[k, j]``

    Returns
    -------
    StaggeredMotion (``sm`` itself when the knot is already there).

    Raises
    ------
    ValueError naming the parameter: an unknown joint or pose, an end pose, a time that is not finite or
    would leave the knots out of order (the message gives the open interval the knot may move in).
    """
    _check(sm)
    k = _pose_index(sm, pose, "pose")
    mask = _joint_mask(sm, [joint])
    j = int(mask.argmax())
    time = _finite(time, "time")
    K = sm.num_poses
    name = sm.skeleton.names[j]
    if k in (0, K - 1):
        raise ValueError(f"pose: pose {k} is the clip's {'first' if k == 0 else 'last'} frame; its knots stay at "
                         f"{sm.pose_times[k]:.3f} s (retime an interior pose, or the pose as a whole)")
    knots = sm.pose_times + sm.refinements[:, j]
    lo, hi = float(knots[k - 1]), float(knots[k + 1])
    if not lo < time < hi:
        raise ValueError(f"time: {name}'s knot of pose {k} must stay between its knots of poses {k - 1} and {k + 1}, "
                         f"{lo:.3f} s < time < {hi:.3f} s; got {time:.3f} s")
    d = time - float(knots[k])
    if j == 0:
        rk = sm.pose_times + sm.root_refinements
        lo_r, hi_r, at = float(rk[k - 1]), float(rk[k + 1]), float(rk[k]) + d
        if not lo_r < at < hi_r:
            raise ValueError(f"time: the root translation's knot of pose {k} would move to {at:.3f} s, outside "
                             f"its neighbours' {lo_r:.3f} s .. {hi_r:.3f} s")
    dr = np.zeros((K, sm.num_joints))
    dr[k, j] = d
    return _with_timing(sm, dr, mask)
