"""The source and current knot times of a staggered motion and the per-control-variable time warp between them
(Coleman et al. 2008, §5.2), and :func:`_refresh`, the common tail of every edit that records them.

Temporal edits only change ``t_k`` / ``r[k, i]``: splines and displacement maps live on normalised segment time,
so between two knots the edited motion replays the source segment linearly in time. The editing tools record
the source knot and pose times at their first edit (``metadata["source_knots"]``, ``["source_pose_times"]``)
and :func:`_refresh` carries them through every geometric, temporal and structural edit, re-creating the editing
knots at ``t_k`` by evaluation (Figure 6c) and attaching the timing warnings lazily
(:mod:`~.timing_report`). The edits themselves: :mod:`~.timing`, :mod:`~.geometry`, :mod:`~.structure`.
"""
from __future__ import annotations

import numpy as np

from . import timing_report
from ._checks import _joint_mask
from .evaluation import evaluate_samples
from .representation import StaggeredMotion
from .timing_report import _LazyWarnings

__all__ = ["source_knot_times", "source_pose_times", "warp_times"]


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
