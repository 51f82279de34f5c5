"""Temporal editing of staggered poses (Coleman et al. 2008, §5.2): succession, random timing, retiming poses
as units and one knot at a time (:func:`refine`, the dope sheet's drag).

The editing tools' conventions and notation: :mod:`stagger_nb.staggered`.

Temporal edits only change ``t_k`` / ``r[k, i]``: splines and displacement maps live on normalised segment time,
so they follow; editing knots are re-created at ``t_k`` by evaluation (:func:`~.source_times._refresh`, the common
tail of every edit, which also carries the source knot times: the time warp these edits apply,
:func:`~.source_times.warp_times`). By default succession and random timing saturate their offsets
(:func:`~.saturation.saturate_offsets`, ``limit``): every joint's knots stay in order and no segment plays more
than ``limit`` times faster; what was limited noticeably is said in one sentence
(:func:`~.timing_report.timing_summary`). Refined times that come closer to a neighbouring pose than to
their own are reported as :class:`~.timing_report.TimingWarning` objects in ``sm.metadata["warnings"]`` (also
available from :func:`~.timing_report.timing_warnings`), never printed.
"""
from __future__ import annotations

import numpy as np

from ..core.limits import MAX_TAU, TIMING_LIMIT
from ._checks import _check, _finite, _joint_mask, _pose_index, _pose_mask, _pose_weights
from .representation import StaggeredMotion
from .saturation import _check_limit, _eased, _segment_floors, inside_ends, saturate_offsets
from .source_times import _refresh, source_knot_times, source_pose_times, warp_times

# the time warp's tables, read by the contact layer (plants_carry) and quality.detail from this module
from .source_times import _warp_column as _warp_column
from .source_times import _warp_tables as _warp_tables

__all__ = ["succession", "random_timing", "retime", "refine", "source_knot_times", "source_pose_times", "warp_times",
           "inside_ends", "MAX_TAU", "TIMING_LIMIT", "saturate_offsets"]

_NOTICEABLE = 0.1      # a joint's typical offset cut by more than this share (and half a frame): "limited noticeably"


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
