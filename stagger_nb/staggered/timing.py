"""Temporal editing of staggered poses (Coleman et al. 2008, §5.2): succession, random timing, retiming poses
as units, and the per-control-variable time warp these edits apply.

The editing tools' conventions and notation: :mod:`stagger_nb.staggered`.

Temporal edits only change ``t_k`` / ``r[k, i]``: splines and displacement maps live on normalised segment time,
so they follow; editing knots are re-created at ``t_k`` by evaluation (Figure 6c, :func:`_refresh`, the common
tail of every edit, geometric and structural too). Refined times that come closer to a neighbouring pose than to
their own are reported as :class:`~.timing_report.TimingWarning` objects in ``sm.metadata["warnings"]`` (also
available from :func:`~.timing_report.timing_warnings`), never printed.
"""
from __future__ import annotations

import numpy as np

from ..core.limits import MAX_TAU
from ._checks import _check, _finite, _joint_mask, _pose_index, _pose_mask
from .evaluation import _eval_rotations
from .representation import StaggeredMotion, knot_times
from . import timing_report
from .timing_report import _LazyWarnings

__all__ = ["succession", "random_timing", "retime", "source_knot_times", "warp_times", "inside_ends", "MAX_TAU"]


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
    return np.concatenate([knot_times(sm), (sm.pose_times + sm.root_refinements)[:, None]], axis=1)


def _current_knots(sm: StaggeredMotion) -> np.ndarray:
    """Knot times (K, J + 1) in the column layout of :func:`source_knot_times`."""
    return np.concatenate([knot_times(sm), (sm.pose_times + sm.root_refinements)[:, None]], axis=1)


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


def _refresh(sm: StaggeredMotion, source_knots=None, **fields) -> StaggeredMotion:
    """New StaggeredMotion with ``fields`` replaced, editing knots re-created at ``t_k`` by evaluation
    (Figure 6c; kept equal to the extreme knots where the refinement is 0), timing warnings attached
    as ``metadata["warnings"]`` and the source knot times (:func:`source_knot_times`) carried as
    ``metadata["source_knots"]`` (``source_knots`` overrides them when the poses change)."""
    if source_knots is None:
        source_knots = source_knot_times(sm)
    new = sm._with_fields(**fields)          # (arrays the edit did not change are shared, not copied)
    K, J = new.num_poses, new.num_joints
    # K x J samples through this module's small evaluator (evaluate_arrays keeps scratch buffers sized
    # for whole clips; alternating tiny calls with full evaluations would make it re-allocate them)
    q = _eval_rotations(new, np.repeat(new.pose_times, J), np.tile(np.arange(J), K)).reshape(K, J, 4)
    editing = np.where((new.refinements != 0)[..., None], q, new.values)
    editing.setflags(write=False)
    meta = {k: v for k, v in dict.items(new.metadata) if k != "warnings"}   # (a lazy entry is not computed)
    sk = np.array(source_knots, dtype=float)
    sk.setflags(write=False)
    meta["source_knots"] = sk
    meta["source_knots_pose_times"] = new.pose_times        # the rows' poses (a later cull keeps a subset)
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


def _with_timing(sm: StaggeredMotion, dr: np.ndarray, joint_mask: np.ndarray, ease_ends: bool = False
                 ) -> StaggeredMotion:
    """Add refinement offsets ``dr (K, J)`` (exactly; with ``ease_ends``, interior knots that would reach the
    clip's ends are eased, :func:`inside_ends`); the root translation follows the root rotation if joint 0 is
    selected (both are the root's timing)."""
    if not np.any(dr):
        return sm
    t = sm.pose_times
    moved = dr != 0
    ease = _eased if ease_ends else (lambda r, t, moved: r)
    fields = dict(refinements=ease(sm.refinements + dr, t, moved))
    if joint_mask[0] and np.any(dr[:, 0]):
        fields["root_refinements"] = ease((sm.root_refinements + dr[:, 0])[:, None], t, moved[:, :1])[:, 0]
    return _refresh(sm, **fields)


def _eased(r: np.ndarray, t: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """Refinements ``r (K, C)`` whose knots :func:`inside_ends` eases, the others exactly as given."""
    T = t[:, None] + r
    E = inside_ends(T, t, moved)
    return np.where(E != T, E - t[:, None], r)


def succession(sm: StaggeredMotion, root="LeftShoulder", s: float = 0.03, l: float = 2.0, *, joints=None,
               poses=None, ease_ends: bool = False) -> StaggeredMotion:
    """Succession timing (§5.2, after Neff & Fiume 2003): ``r̂[k, i] = r[k, i] + s d(i)^l``.

    The formula is applied exactly (a large ``s`` can bring a knot of the second-to-last pose next to, or past,
    the last pose: the last segment then plays in a frame or two, and :func:`timing_warnings` says so). With
    ``ease_ends=True`` knots within half a pose spacing of the clip's first/last pose are eased instead
    (:func:`inside_ends`: the last pose stays the clip's last frame, its segment keeps >= 1/8 of the spacing).

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
    """
    _check(sm)
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
    return _with_timing(sm, dr, jm, bool(ease_ends))




def random_timing(sm: StaggeredMotion, joints=None, tau: float = 0.05, seed: int = 0, *,
                  poses=None, ease_ends: bool = False) -> StaggeredMotion:
    """Random timing offsets (§5.2): ``r̂[k, i] = r[k, i] + U(-τ, τ)`` for the chosen joints (``ease_ends``:
    as in :func:`succession`).

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
    """
    _check(sm)
    tau = _finite(tau, "tau")
    if not 0 <= tau <= MAX_TAU:  # core.limits: the one declaration of the bound
        raise ValueError(f"tau must be in [0, {MAX_TAU:g}] seconds, got {tau}")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, (bool, np.bool_)) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}")
    jm = _joint_mask(sm, joints)
    pm = _pose_mask(sm, poses, interior_default=True)
    u = np.random.default_rng(int(seed)).uniform(-tau, tau, size=(sm.num_poses, sm.num_joints))
    return _with_timing(sm, np.where(pm[:, None] & jm[None, :], u, 0.0), jm, bool(ease_ends))


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
