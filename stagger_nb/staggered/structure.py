"""Structural editing of staggered poses (Coleman et al. 2008, §5.1, last paragraph): inserting and deleting a
pose without changing the motion.

The editing tools' conventions and notation: :mod:`stagger_nb.staggered`.
"""
from __future__ import annotations

import numpy as np

from ..core.rotations import slerp
from ._checks import _check, _finite, _pose_index
from .displacement import _counts_for, _measure_root, _measure_rotations, _put_rows
from .evaluation import _eval_root, _eval_rotations, translation_source_times
from .representation import StaggeredMotion, knot_times
from .timing import _refresh, source_knot_times, warp_times

__all__ = ["insert_pose", "delete_pose"]


def _split_rotation_bezier(c0, c1, c2, c3, u):
    """de Casteljau split by slerp at ``u``: control polygons of the left and right parts."""
    a, b, c = slerp(c0, c1, u), slerp(c1, c2, u), slerp(c2, c3, u)
    d, e = slerp(a, b, u), slerp(b, c, u)
    return (a, d), (e, c)


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
    K, J = sm.num_poses, sm.num_joints
    T = knot_times(sm)
    bad = ~(T[k] < T[k + 1])
    if bad.any():
        raise ValueError(f"cannot insert a pose at t = {t} s: the refined knots of poses {k} and {k + 1} are out of "
                         f"order for joints {[sm.skeleton.names[i] for i in np.flatnonzero(bad)]}")
    rk = sm.pose_times + sm.root_refinements
    if not rk[k] < rk[k + 1]:
        raise ValueError(f"cannot insert a pose at t = {t} s: the root translation knots of poses {k} and {k + 1} "
                         "are out of order")
    u_pose = (t - pt[k]) / (pt[k + 1] - pt[k])
    T_new = np.where((T[k] < t) & (t < T[k + 1]), t, T[k] + u_pose * (T[k + 1] - T[k]))     # (J,)
    rk_new = t if rk[k] < t < rk[k + 1] else rk[k] + u_pose * (rk[k + 1] - rk[k])
    cols = np.arange(J)
    v_t = _eval_rotations(sm, T_new, cols)                  # the new extreme values (at the new knots)
    v0_t = _eval_rotations(sm, np.full(J, t), cols)         # the pose at t (editing knots)
    p_t = _eval_root(sm, np.array([rk_new]))[0]
    u = (T_new - T[k]) / (T[k + 1] - T[k])                  # (J,) where each joint's spline is split
    tg = sm.tangents[k]
    (l1, l2), (r1, r2) = _split_rotation_bezier(sm.values[k], tg[:, 0], tg[:, 1], sm.values[k + 1], u)
    values = np.insert(sm.values, k + 1, v_t, axis=0)
    tangents = np.concatenate([sm.tangents[:k], np.stack([l1, l2], 1)[None], np.stack([r1, r2], 1)[None],
                               sm.tangents[k + 1:]])
    refinements = np.insert(sm.refinements, k + 1, T_new - t, axis=0)
    pose_times = np.insert(sm.pose_times, k + 1, t)
    knots = pose_times[:, None] + refinements
    seg = np.repeat([k, k + 1], J)
    joint = np.tile(cols, 2)
    counts = _counts_for(knots[seg, joint], knots[seg + 1, joint], sm.frame_time)
    rows = _measure_rotations(values, tangents, knots, seg, joint, counts,
                              lambda tt, jp, pair, tn: _eval_rotations(sm, tt, jp))
    disp = np.insert(sm.displacements, k + 1, 0.0, axis=0)
    dcounts = np.insert(sm.displacement_counts, k + 1, 2, axis=0)
    dcounts[seg, joint] = counts
    disp = _put_rows(disp, (seg, joint), rows)

    ua = (rk_new - rk[k]) / (rk[k + 1] - rk[k])
    p0, (p1, p2), p3 = sm.root_values[k], sm.root_tangents[k], sm.root_values[k + 1]
    a, b, c = p0 + ua * (p1 - p0), p1 + ua * (p2 - p1), p2 + ua * (p3 - p2)
    d, e = a + ua * (b - a), b + ua * (c - b)
    root_values = np.insert(sm.root_values, k + 1, p_t, axis=0)
    root_tangents = np.concatenate([sm.root_tangents[:k], [[a, d]], [[e, c]], sm.root_tangents[k + 1:]])
    root_ref = np.insert(sm.root_refinements, k + 1, rk_new - t)
    rknots = pose_times + root_ref
    rseg = np.array([k, k + 1])
    rcounts = _counts_for(rknots[rseg], rknots[rseg + 1], sm.frame_time)
    rrows = _measure_root(root_values, root_tangents, rknots, rseg, rcounts,
                          lambda tt, pair, tn: _eval_root(sm, tt))
    rd = _put_rows(np.insert(sm.root_displacements, k + 1, 0.0, axis=0), (rseg,), rrows)
    rdc = np.insert(sm.root_displacement_counts, k + 1, 2)
    rdc[rseg] = rcounts
    prob = np.insert(sm.pose_probability, k + 1, 0.0)
    tt = sm.translation_times
    if tt is not None:           # animated translations keep their source time at the new knot
        tt = np.insert(tt, k + 1, translation_source_times(sm, [rk_new])[0])
    src = source_knot_times(sm)          # the new knots' source times: through each variable's warp
    new_src = [warp_times(sm, [x], c, inverse=True)[0] for c, x in enumerate(np.append(T_new, rk_new))]
    return _refresh(sm, source_knots=np.insert(src, k + 1, new_src, axis=0), translation_times=tt, pose_times=pose_times, refinements=refinements, values=values, tangents=tangents,
                    displacements=disp, displacement_counts=dcounts, root_values=root_values,
                    root_refinements=root_ref, root_tangents=root_tangents, root_displacements=rd,
                    root_displacement_counts=rdc, editing_knots=np.insert(sm.editing_knots, k + 1, v0_t, axis=0),
                    pose_probability=prob)


def delete_pose(sm: StaggeredMotion, k: int) -> StaggeredMotion:
    """Delete interior pose ``k`` without changing the motion: the two segments around it merge into one
    whose Bézier keeps the outer handles, and whose displacement map is re-measured from the current motion
    (§5.1, last paragraph). The first and last poses cannot be deleted (they bound the clip)."""
    _check(sm)
    k = _pose_index(sm, k)
    K, J = sm.num_poses, sm.num_joints
    if k in (0, K - 1):
        raise ValueError(f"k: the first and last poses bound the motion and cannot be deleted (got {k})")
    if K <= 2:
        raise ValueError("cannot delete a pose of a 2-pose motion")
    cols = np.arange(J)
    values = np.delete(sm.values, k, axis=0)
    tangents = np.delete(sm.tangents, k, axis=0)
    tangents[k - 1, :, 0] = sm.tangents[k - 1, :, 0]
    tangents[k - 1, :, 1] = sm.tangents[k, :, 1]
    refinements = np.delete(sm.refinements, k, axis=0)
    pose_times = np.delete(sm.pose_times, k)
    knots = np.maximum.accumulate(pose_times[:, None] + refinements, axis=0)
    seg = np.full(J, k - 1)
    counts = _counts_for(knots[seg, cols], knots[seg + 1, cols], sm.frame_time)
    rows = _measure_rotations(values, tangents, knots, seg, cols, counts,
                              lambda tt, jp, pair, tn: _eval_rotations(sm, tt, jp))
    disp = _put_rows(np.delete(sm.displacements, k, axis=0), (seg, cols), rows)
    dcounts = np.delete(sm.displacement_counts, k, axis=0)
    dcounts[k - 1] = counts

    root_values = np.delete(sm.root_values, k, axis=0)
    root_tangents = np.delete(sm.root_tangents, k, axis=0)
    root_tangents[k - 1] = [sm.root_tangents[k - 1, 0], sm.root_tangents[k, 1]]
    root_ref = np.delete(sm.root_refinements, k)
    rknots = np.maximum.accumulate(pose_times + root_ref)
    rseg = np.array([k - 1])
    rcounts = _counts_for(rknots[rseg], rknots[rseg + 1], sm.frame_time)
    rrows = _measure_root(root_values, root_tangents, rknots, rseg, rcounts,
                          lambda tt, pair, tn: _eval_root(sm, tt))
    rd = _put_rows(np.delete(sm.root_displacements, k, axis=0), (rseg,), rrows)
    rdc = np.delete(sm.root_displacement_counts, k)
    rdc[rseg] = rcounts
    tt = None if sm.translation_times is None else np.delete(sm.translation_times, k)
    return _refresh(sm, source_knots=np.delete(source_knot_times(sm), k, axis=0), pose_times=pose_times, refinements=refinements, values=values, tangents=tangents,
                    displacements=disp, displacement_counts=dcounts, root_values=root_values,
                    root_refinements=root_ref, root_tangents=root_tangents, root_displacements=rd,
                    root_displacement_counts=rdc, editing_knots=np.delete(sm.editing_knots, k, axis=0),
                    translation_times=tt,
                    pose_probability=np.delete(sm.pose_probability, k))
