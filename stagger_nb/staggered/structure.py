"""Structural editing of staggered poses (Coleman et al. 2008, §5.1, last paragraph): inserting and deleting a
pose without changing the motion, written once over the channels (joint rotations, root translation).

The editing tools' conventions and notation: :mod:`stagger_nb.staggered`.
"""
from __future__ import annotations

import numpy as np

from ._checks import _check, _finite, _pose_index
from .channel import Channel
from .displacement import _counts_for, _put_rows, measure
from .evaluation import channel_at_times, evaluate_samples, translation_source_times
from .representation import StaggeredMotion
from .source_times import _refresh, source_knot_times, source_pose_times, warp_times

__all__ = ["insert_pose", "delete_pose"]


def insert_pose(sm: StaggeredMotion, t: float) -> StaggeredMotion:
    """Insert a pose at time ``t`` (seconds, strictly between two poses) without changing the motion.

    Each control variable gets its new knot at ``t`` (zero refinement) when its refined knots of the two
    neighbouring poses straddle ``t``; otherwise (timing edits moved them past ``t``, e.g. a succession down
    a long limb) at the same relative place in its own segment, ``T[k] + u (T[k+1] - T[k])`` with
    ``u = (t - t_k) / (t_{k+1} - t_k)`` (a refinement that follows the neighbours' staggering). The knot takes
    the current value there, the editing knot the current value at ``t``; each segment is split with the de
    Casteljau construction and the two new displacement maps are re-measured so the evaluated motion is
    preserved on their sample grids ("we update the displacement map to preserve the global transition
    values", §5.1). Raises ``ValueError`` where a joint's knots of the two poses are out of order.
    """
    _check(sm)
    t = _finite(t, "t")
    pt = sm.pose_times
    if not pt[0] < t < pt[-1] or np.any(np.isclose(pt, t, rtol=0, atol=1e-9)):
        raise ValueError(f"t must lie strictly between two poses in ({pt[0]}, {pt[-1]}), got {t}")
    k = int(np.searchsorted(pt, t)) - 1      # new pose goes between k and k + 1
    for ch, what in zip(sm.channels, ("refined knots", "root translation knots")):
        T = ch.knots(pt)
        bad = ~(T[k] < T[k + 1])
        if bad.any():
            where = (f" for joints {[sm.skeleton.names[i] for i in np.flatnonzero(bad)]}"
                     if ch is sm.rotations else "")
            raise ValueError(f"cannot insert a pose at t = {t} s: the {what} of poses {k} and {k + 1} are out of "
                             f"order{where}")
    u_pose = (t - pt[k]) / (pt[k + 1] - pt[k])
    pose_times = np.insert(pt, k + 1, t)
    channels, new_knots = [], []
    for ch in sm.channels:
        T = ch.knots(pt)
        C = ch.num_columns
        cols = np.arange(C)
        T_new = np.where((T[k] < t) & (t < T[k + 1]), t, T[k] + u_pose * (T[k + 1] - T[k]))     # (C,)
        v_t = channel_at_times(ch, pt, T_new, cols)              # the new extreme values (at the new knots)
        u = (T_new - T[k]) / (T[k + 1] - T[k])                  # (C,) where each column's spline is split
        tg = ch.tangents[k]
        (l1, l2), (r1, r2) = ch.algebra.split(ch.values[k], tg[:, 0], tg[:, 1], ch.values[k + 1], u)
        values = np.insert(ch.values, k + 1, v_t, axis=0)
        tangents = np.concatenate([ch.tangents[:k], np.stack([l1, l2], 1)[None], np.stack([r1, r2], 1)[None],
                                   ch.tangents[k + 1:]])
        refinements = np.insert(ch.refinements, k + 1, T_new - t, axis=0)
        knots = pose_times[:, None] + refinements
        seg, col = np.repeat([k, k + 1], C), np.tile(cols, 2)
        counts = _counts_for(knots[seg, col], knots[seg + 1, col], sm.frame_time)
        rows = measure(ch.algebra, values, tangents, knots, seg, col, counts,
                       lambda tt, cp, pair, tn, ch=ch: channel_at_times(ch, pt, tt, cp))
        dcounts = np.insert(ch.counts, k + 1, 2, axis=0)
        dcounts[seg, col] = counts
        disp = _put_rows(np.insert(ch.displacements, k + 1, 0.0, axis=0), (seg, col), rows)
        channels.append(Channel(ch.algebra, values, tangents, refinements, disp, dcounts))
        new_knots.append(T_new)
    J = sm.num_joints
    v0_t = evaluate_samples(sm, np.full(J, t), np.arange(J))    # the pose at t (editing knots)
    tt = sm.translation_times
    if tt is not None:           # animated translations keep their source time at the new knot
        tt = np.insert(tt, k + 1, translation_source_times(sm, new_knots[1])[0])
    src = source_knot_times(sm)          # the new knots' source times: through each variable's warp
    new_src = [warp_times(sm, [x], c, inverse=True)[0] for c, x in enumerate(np.concatenate(new_knots))]
    sp = source_pose_times(sm)           # the new pose's source time: linear between its neighbours'
    sp = np.insert(sp, k + 1, np.interp(t, sm.pose_times, sp))
    return _refresh(sm, source_knots=np.insert(src, k + 1, new_src, axis=0), source_poses=sp, translation_times=tt,
                    pose_times=pose_times, rotations=channels[0], translation=channels[1],
                    editing_knots=np.insert(sm.editing_knots, k + 1, v0_t, axis=0),
                    pose_probability=np.insert(sm.pose_probability, k + 1, 0.0))


def delete_pose(sm: StaggeredMotion, k: int) -> StaggeredMotion:
    """Delete interior pose ``k`` without changing the motion: the two segments around it merge into one
    whose Bézier keeps the outer handles, and whose displacement map is re-measured from the current motion
    (§5.1, last paragraph). The first and last poses cannot be deleted (they bound the clip)."""
    _check(sm)
    k = _pose_index(sm, k)
    K = sm.num_poses
    if k in (0, K - 1):
        raise ValueError(f"k: the first and last poses bound the motion and cannot be deleted (got {k})")
    if K <= 2:
        raise ValueError("cannot delete a pose of a 2-pose motion")
    pose_times = np.delete(sm.pose_times, k)
    channels = []
    for ch in sm.channels:
        C = ch.num_columns
        cols = np.arange(C)
        values = np.delete(ch.values, k, axis=0)
        tangents = np.delete(ch.tangents, k, axis=0)
        tangents[k - 1, :, 0] = ch.tangents[k - 1, :, 0]
        tangents[k - 1, :, 1] = ch.tangents[k, :, 1]
        refinements = np.delete(ch.refinements, k, axis=0)
        knots = np.maximum.accumulate(pose_times[:, None] + refinements, axis=0)
        seg = np.full(C, k - 1)
        counts = _counts_for(knots[seg, cols], knots[seg + 1, cols], sm.frame_time)
        rows = measure(ch.algebra, values, tangents, knots, seg, cols, counts,
                       lambda tt, cp, pair, tn, ch=ch: channel_at_times(ch, sm.pose_times, tt, cp))
        dcounts = np.delete(ch.counts, k, axis=0)
        dcounts[k - 1] = counts
        disp = _put_rows(np.delete(ch.displacements, k, axis=0), (seg, cols), rows)
        channels.append(Channel(ch.algebra, values, tangents, refinements, disp, dcounts))
    tt = None if sm.translation_times is None else np.delete(sm.translation_times, k)
    return _refresh(sm, source_knots=np.delete(source_knot_times(sm), k, axis=0),
                    source_poses=np.delete(source_pose_times(sm), k), pose_times=pose_times,
                    rotations=channels[0], translation=channels[1],
                    editing_knots=np.delete(sm.editing_knots, k, axis=0), translation_times=tt,
                    pose_probability=np.delete(sm.pose_probability, k))
