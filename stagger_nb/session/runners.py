"""Op runners: each op type -> a function ``(state, op, run) -> state`` over the replay state (:data:`RUNNERS`).

The state is a :class:`~stagger_nb.core.Motion` or a ``staggered.StaggeredMotion``; the replay converts it to
what the op ``needs`` before calling the runner (:func:`~.run.convert`). Runners call the technique packages'
pure functions; the expensive heads they need come from ``run.heads`` (:class:`~.heads.Heads`, the session's
one cache). A runner may leave plain notes for the user (``run.note(text)``) and the warp curve it computed
(``run.warp``). This module holds the staggered ops' runners (Coleman et al. 2008, with the magic wand's falloff
on the poses, issue 24); :mod:`.motion_runners` the motion ops' and the warps'.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..core.motion import Motion
from . import ops as O
from .heads import Heads
from .motion_runners import (
    MAX_WARP_RATIO,
    _edit_frame,
    _edit_frames,
    _guide_poses,
    _guided_warp,
    _linear_warp,
    _propagate,
    _resample,
    even_upsample,
    warp_k,
    warp_search,
    warp_size,
    warp_table_key,
)
from .run import Run, _joint, _list, _needs, _pose, _staggered, apply_pose_deltas, convert

__all__ = ["RUNNERS", "BATCHED", "Heads", "Run", "convert", "apply_pose_deltas", "warp_size", "warp_search",
           "warp_k", "warp_table_key", "pose_spread", "falloff_at_poses", "even_upsample", "MAX_WARP_RATIO"]


def _extract(st, op, run):
    if isinstance(st, Motion):
        return convert(st, "staggered", run)
    return st


def _cull(sm, op: O.Cull, run):
    if op.keep is None:
        return run.heads.cull(sm, op.percent, op.count, run.progress)
    K = sm.num_poses
    for i, k in enumerate(op.keep):
        _pose(sm, k, f"keep[{i}]")
    drop = sorted(set(range(1, K - 1)) - set(op.keep), reverse=True)  # the first and last pose stay
    delete = _staggered().delete_pose
    for k in drop:  # from the end: lower indices stay valid
        sm = delete(sm, k)
    return sm


# -- the magic wand's falloff on the staggered poses (issue 24) ---------------------------------------
def _pose_source_frames(sm, origin: Motion) -> np.ndarray:
    """Source frame (fractional) of every pose of ``sm``: its time in ``origin`` (the motion it was extracted
    from, frame f at ``f * frame_time``), before any retiming (``staggered.source_pose_times``)."""
    st = _staggered()
    times = st.source_pose_times(sm) if hasattr(st, "source_pose_times") else np.asarray(sm.pose_times)
    return np.asarray(times, dtype=float) / origin.frame_time


def falloff_at_poses(sm, run, frame: int, sigma, frame_range, field: str) -> np.ndarray:
    """The falloff of ``run.origin`` around source ``frame`` read at every pose's source time (linear between
    frames; 0 outside ``frame_range``), shape (K,)."""
    origin = run.origin
    F = origin.num_frames
    if frame_range is not None and frame_range[1] > F:
        raise ValueError(f"{field}frame_range: [{frame_range[0]}, {frame_range[1]}) runs past the "
                         f"{F} frames of the motion the poses were extracted from")
    if not 0 <= frame < F:
        raise ValueError(f"{field}frame: {frame} is outside the {F} frames of the motion the poses were "
                         "extracted from")
    if frame_range is not None and not frame_range[0] <= frame < frame_range[1]:
        raise ValueError(f"{field}frame_range: the edited pose's source frame {frame} is outside "
                         f"[{frame_range[0]}, {frame_range[1]})")
    w = run.heads.falloff(origin, frame, sigma, frame_range)
    return np.interp(_pose_source_frames(sm, origin), np.arange(F), w, left=0.0, right=0.0)


def pose_spread(sm, poses, run, sigma, frame_range) -> np.ndarray:
    """Weights ``(E, K)`` spreading the edits of ``poses`` (E pose indices) to every pose: each edited pose's
    falloff (Dean et al. 2018, §3.3) at the poses' source times, combined as the wand combines several edits
    (``wand.propagate_logs``, ``combine="interpolate"``): each edited pose gets exactly its own change (1 on its
    own column, 0 on the other edited poses'), the others the falloff-weighted sum (Eq. 5 in the log map)."""
    poses = [int(k) for k in poses]
    frames = np.rint(_pose_source_frames(sm, run.origin)[poses]).astype(int)
    F = run.origin.num_frames
    frames = np.clip(frames, 0, F - 1)
    W = np.stack([falloff_at_poses(sm, run, int(f), sigma, frame_range, "") for f in frames])
    W[np.arange(len(poses)), poses] = 1.0          # the edited pose itself (its own frame: 1, §3.3)
    if len(poses) > 1:
        M = W[:, poses].T                          # M[a, e] = w_e(pose a)
        W = np.linalg.lstsq(M, np.eye(len(poses)), rcond=1e-10)[0].T @ W
        W[:, poses] = np.eye(len(poses))           # exactly (rounding of the solve)
    return W


def _timing_weights(sm, op, run):
    """``op.falloff``'s weights at the poses, (K,), or None without a region."""
    if op.falloff is None:
        return None
    r = dict(op.falloff)
    return falloff_at_poses(sm, run, r["frame"], r["sigma"], r["frame_range"], "falloff.")


def _weights_kw(weights) -> dict:
    return {} if weights is None else {"weights": weights}


def _succession(sm, op: O.Succession, run):
    return _staggered().succession(sm, root=op.root, s=op.s, l=op.l, joints=_list(op.joints), limit=op.limit,
                                   **_weights_kw(_timing_weights(sm, op, run)))


def _random_timing(sm, op: O.RandomTiming, run):
    return _staggered().random_timing(sm, joints=_list(op.joints), tau=op.tau, seed=op.seed, limit=op.limit,
                                      **_weights_kw(_timing_weights(sm, op, run)))


def _exaggerate(sm, op: O.Exaggerate, run):
    poses = list(range(sm.num_poses)) if op.poses is None else [_pose(sm, k, "poses") for k in op.poses]
    if isinstance(op.reference, int):
        _pose(sm, op.reference, "reference")
    basis = run.heads.offset_basis(sm, run.origin)
    spread = pose_spread(sm, poses, run, op.sigma, op.frame_range) if op.propagate else None
    return _staggered().exaggerate(sm, poses, op.w_r, reference=op.reference, mode=op.mode,
                                   joints=_list(op.joints), **({} if basis is None else {"basis": basis}),
                                   **_weights_kw(spread))


def _radians(deltas) -> dict:
    return {name: np.radians(np.asarray(rv, dtype=float)) for name, rv in deltas}


def _edit_pose(sm, op: O.EditPose, run):
    k = _pose(sm, op.pose)
    kw = _weights_kw(pose_spread(sm, [k], run, op.sigma, op.frame_range)[0] if op.propagate else None)
    if op.targets is not None:
        for name, _ in op.targets:
            _joint(sm.skeleton, name, f"targets.{name}")
        return _staggered().edit_pose(sm, k, target={n: np.asarray(q, dtype=float) for n, q in op.targets},
                                      mode=op.mode, **kw)
    return _staggered().edit_pose(sm, k, deltas=_radians(op.deltas), mode=op.mode, **kw)


def _retime(sm, op: O.Retime, run):
    return _staggered().retime(sm, {_pose(sm, op.pose): op.time})


def _refine(sm, op: O.Refine, run):
    _joint(sm.skeleton, op.joint, "joint")
    return _needs("refine")(sm, _pose(sm, op.pose), op.joint, op.time)


def _insert_pose(sm, op: O.InsertPose, run):
    return _staggered().insert_pose(sm, op.time)


def _delete_pose(sm, op: O.DeletePose, run):
    return _staggered().delete_pose(sm, _pose(sm, op.pose))


def _keep_contacts(state, op: O.KeepContacts, run):
    origin = run.origin
    hold = getattr(_staggered(), "hold_plants", None)
    if hold is None:              # a staggered without the plants layer's result form
        return _needs("keep_contacts")(state, origin, source_positions=run.heads.positions(origin))
    res = hold(state, origin, source_positions=run.heads.positions(origin))
    for note in res.notes:        # no legs found, plants out of reach: Session.messages() shows them
        run.note(note)
    return res.motion


def _ik_pose(sm, op: O.IKPose, run):
    k = _pose(sm, op.pose)
    kw = _weights_kw(pose_spread(sm, [k], run, op.sigma, op.frame_range)[0] if op.propagate else None)
    res = _needs("ik_pose")(sm, k, op.joint, np.asarray(op.target, dtype=float), **kw)
    run.note(getattr(res, "message", ""))
    return res.staggered


#: Runner of each op type. A new op is an :class:`~.ops.Op` subclass plus an entry here.
RUNNERS: dict[type, Callable] = {
    O.Extract: _extract, O.Cull: _cull, O.Succession: _succession, O.RandomTiming: _random_timing,
    O.Exaggerate: _exaggerate, O.EditPose: _edit_pose, O.Retime: _retime, O.Refine: _refine,
    O.InsertPose: _insert_pose, O.DeletePose: _delete_pose, O.KeepContacts: _keep_contacts, O.IKPose: _ik_pose,
    O.GuidePoses: _guide_poses,
    O.EditFrame: _edit_frame, O.Propagate: _propagate, O.GuidedWarp: _guided_warp,
    O.LinearWarp: _linear_warp, O.Resample: _resample,
}

#: Runners over a run of consecutive ops of one kind on a Motion, ``(motion, ops) -> motion``: the replay uses
#: them for runs of two or more (a session of 10^5 ``edit_frame`` ops replays in seconds, not a minute).
BATCHED: dict[type, Callable] = {O.EditFrame: _edit_frames}
