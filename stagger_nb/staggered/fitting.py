"""Fitting splines and displacement maps to dense motion (Coleman et al. 2008, §4.1.1, Appendix A).

Given pose times and refinements, every (segment, joint) pair gets a quaternion Bézier whose end points are
the knot values and whose two inner control quaternions ("tangents") minimise the squared angular distance
to the source samples on SO(3); the root translation gets a cubic Bézier fitted by linear least squares.
The displacement map is what is left: ``d(t') = s(t') ⊖ v(t')`` (§4.1.1), stored on the normalised segment
time, so ``evaluate`` reproduces the source exactly at the sample times.

The paper minimises ``w_f f_f + w_c f_c`` with Nelder–Mead per joint and segment (Appendix A). Here all
pairs are fitted at once: by default C1 splines (:mod:`.rotation_fit_c1`: one angular velocity per knot,
shared by both segments), or per segment (C0, :mod:`.rotation_fit`); the root translation by linear least
squares (:mod:`.translation_fit`) on the sample grids of :mod:`.sampling`; the displacement maps by
:mod:`.displacement`. This module assembles them (:func:`fit_staggered`); the local refit of a cull,
:func:`~.refit.refit_merged`, is in :mod:`.refit` (re-exported here), what both use in :mod:`.fit_common`.
"""
from __future__ import annotations

import numpy as np

from .channel import ROTATION, Channel
from .displacement import displacement_table, displacements_of
from .evaluation import root_positions_at, translation_source_times
from .fit_common import _fit_mask, _fit_stats, _pin_static, _samples_of, _static_joints, check_evaluated
from .refit import refit_merged
from .representation import StaggeredMotion
from .rotation_fit import fit_rotation_tangents
from .rotation_fit_c1 import fit_rotation_tangents_c1, velocities_from_tangents
from .sampling import _continuous_per_joint, _read, fit_subset, sample_segments
from .translation_fit import _fit_root

__all__ = ["fit_staggered", "refit_merged"]


def fit_staggered(source, pose_times, refinements, root_refinements=None, *,
                  pose_probability=None, contacts=(), start_time: float = 0.0, iterations: int = 2,
                  continuity: str = "C1", oversample: int = 1, fit_samples: int | None = 12,
                  metadata: dict | None = None, progress=None, evaluated=None) -> StaggeredMotion:
    """Fit splines and displacement maps for given staggered poses (§4.1.1).

    Parameters
    ----------
    source : Motion or StaggeredMotion
        Dense motion whose frame 0 is at ``start_time`` seconds, or a staggered-pose motion (possibly
        edited) that is resampled exactly at the new segments' sample times (absolute times; used by
        :func:`~.extraction.cull` to re-measure splines and displacements over merged segments, §5.1).
    pose_times : (K,) seconds, strictly increasing, inside the source's time span
    refinements : (K, J) seconds; knot times ``pose_times[:, None] + refinements`` strictly increasing
    root_refinements : (K,) seconds for the root translation (default zeros)
    pose_probability : (K,) P(t_k), default ones
    contacts : tuple of (joint_name, start_frame, stop_frame)
    iterations : Levenberg–Marquardt steps of the rotation fit
    continuity : "C1" (default) fits one angular velocity per knot shared by both adjacent segments
        (:func:`fit_rotation_tangents_c1`; the root translation is made C1 by :func:`match_translation_tangents`);
        "C0" fits every segment independently (:func:`fit_rotation_tangents`: smaller residual, velocity
        jumps at joins). Values are continuous either way, and the displacement map absorbs the residual,
        so the reconstruction is exact in both cases.
    oversample : int >= 1, displacement samples per source frame (1: grid points on source frames)
    fit_samples : int >= 4 or None
        Samples per (segment, joint) pair the splines are fitted to (evenly spaced, ends included; see
        :func:`fit_subset`); None fits all. The displacement maps are measured at every sample either way,
        so the reconstruction stays exact; the spline is a least-squares fit to 12 points of a smooth
        segment instead of to all (the residual it leaves is in ``metadata["fit"]``). Pairs with at most
        ``fit_samples`` samples are fitted exactly as with None. Keeps the fit's cost at
        O(K J fit_samples) whatever the frame rate and segment lengths (long takes, culls).
    progress : callable(fraction in [0, 1]) or None, called as the fit advances
    evaluated : Motion, optional
        ``evaluate(source)`` for a StaggeredMotion ``source`` when the caller already has it (the editor
        does): samples on its frames are read from it instead of evaluated again; other samples still are.
        The result is the same up to rounding (~1e-15) and the sign of quaternions (q ≡ -q).

    Returns
    -------
    StaggeredMotion reproducing ``source`` at every sample time (displacements absorb the fit residual).
    Fit statistics are in ``metadata["fit"]``: mean and max residual angle of the spline before
    displacement over interior samples (rad), the iterations and the continuity used.
    """
    J = source.num_joints
    pose_times = np.asarray(pose_times, dtype=float).reshape(-1)
    K = pose_times.size
    refinements = np.asarray(refinements, dtype=float)
    if K < 2 or not np.all(np.diff(pose_times) > 0):
        raise ValueError("fit_staggered: pose_times must hold >= 2 strictly increasing times")
    if refinements.shape != (K, J):
        raise ValueError(f"fit_staggered: refinements must have shape ({K}, {J}), got {refinements.shape}")
    rr = np.zeros(K) if root_refinements is None else np.asarray(root_refinements, dtype=float).reshape(K)
    knots = pose_times[:, None] + refinements
    if not np.all(np.diff(knots, axis=0) > 0) or not np.all(np.diff(pose_times + rr) > 0):
        raise ValueError("fit_staggered: refined knot times must be strictly increasing for every joint")
    ft = source.frame_time
    from_sm = isinstance(source, StaggeredMotion)
    if evaluated is not None and not from_sm:
        raise ValueError("fit_staggered: evaluated applies to a StaggeredMotion source only")
    if from_sm:
        # resample the representation itself (exact after any edit), §5.1
        evaluated = check_evaluated("fit_staggered", source, evaluated)
        start_time = 0.0

        def rot_at(frames, joints):
            return _samples_of(source, evaluated, frames * ft, joints)

        def root_at(frames):
            return root_positions_at(source, frames * ft)
    else:
        lq, rp = source.local_quats, source.root_positions

        def rot_at(frames, joints):
            return _read(lq, frames, joints, quat=True)

        def root_at(frames):
            return _read(rp, frames, None, quat=False)

    # static joints (one quaternion throughout) are that quaternion at every sample: not evaluated, not
    # fitted (the zero velocity is exact), their displacement maps zero
    static, const = _static_joints(source)
    if static.any():
        sample_at = rot_at

        def rot_at(frames, joints):
            mov = ~static[joints]
            out = np.empty((joints.size, 4))
            out[~mov] = const[joints[~mov]]
            if mov.any():
                out[mov] = sample_at(frames[mov], joints[mov])
            return out

    # rotations: every (segment, joint) pair at once
    pair, m, counts, tn, frames = sample_segments(knots, ft, start_time, oversample)
    P = counts.size
    joint = pair % J
    N = pair.size
    edit_frames, edit_joints = np.repeat((pose_times - start_time) / ft, J), np.tile(np.arange(J), K)
    if from_sm:                     # one evaluation for the samples and the editing knots
        both = rot_at(np.concatenate([frames, edit_frames]), np.concatenate([joint, edit_joints]))
        targets, editing = both[:N], both[N:].reshape(K, J, 4)
        del both
        targets = _continuous_per_joint(targets, joint, pair // J, m)
        ends = np.concatenate([np.flatnonzero(m == 0), np.cumsum(counts)[P - J:] - 1])
        values = targets[ends].reshape(K, J, 4)
    else:
        targets = rot_at(frames, joint)
        kf = (knots - start_time) / ft
        values = rot_at(kf.reshape(-1), np.tile(np.arange(J), K)).reshape(K, J, 4)
    v0 = values[:-1].reshape(P, 4)
    v3 = values[1:].reshape(P, 4)
    # the first and last sample of each pair are the knots themselves: use them bit-for-bit
    first = m == 0
    last = m == counts[pair] - 1
    targets[first] = v0[pair[first]]
    targets[last] = v3[pair[last]]
    if int(oversample) < 1:
        raise ValueError(f"fit_staggered: oversample must be an integer >= 1, got {oversample!r}")
    if continuity not in ("C0", "C1"):
        raise ValueError(f"fit_staggered: continuity must be 'C0' or 'C1', got {continuity!r}")
    if fit_samples is not None and not (isinstance(fit_samples, (int, np.integer)) and fit_samples >= 4):
        raise ValueError(f"fit_staggered: fit_samples must be an integer >= 4 or None, got {fit_samples!r}")
    report = progress if progress is not None else (lambda f: None)
    report(0.1)
    sub = _fit_mask(fit_subset(m, counts, pair, fit_samples), first, last, ~static[joint])
    tn_f, targets_f, pair_f = tn[sub], targets[sub], pair[sub]
    if continuity == "C1":
        start, _ = fit_rotation_tangents(tn_f, targets_f, pair_f, v0, v3, P, 0)
        report(0.3)
        omega = velocities_from_tangents(values, start.reshape(K - 1, J, 2, 4), knots)
        omega, tangents, cost = fit_rotation_tangents_c1(tn_f, targets_f, pair_f, values, knots, omega, iterations)
    else:
        tangents, cost = fit_rotation_tangents(tn_f, targets_f, pair_f, v0, v3, P, iterations)
    report(0.7)
    del tn_f, targets_f, pair_f
    tangents = _pin_static(tangents, static, const)
    mov = ~static[joint] if static.any() else slice(None)
    pm = pair[mov]
    moving = displacements_of(ROTATION, v0, tangents[:, 0], tangents[:, 1], v3, pm, tn[mov], targets[mov], pm)
    if static.any():
        disp = np.zeros((N, 3))
        disp[mov] = moving
    else:
        disp = moving
    del moving, pm
    report(0.9)
    M = int(counts.max())
    table = displacement_table(pair, m, disp, (P, M, 3))

    rk = (pose_times + rr)[:, None]
    translation = _fit_root(root_at, rk[:, 0], rr, ft, start_time, oversample, continuity)

    if not from_sm:
        editing = rot_at(edit_frames, edit_joints).reshape(K, J, 4)
    editing = np.where((refinements != 0)[..., None], editing, values)

    # passed through on absolute time (a source not starting at 0 s: the caller passes its own)
    lt = source.local_translations if (from_sm or start_time == 0.0) else None
    tt = None
    if lt is not None:           # source times of the animated translations at the root-translation knots
        tt = translation_source_times(source, rk[:, 0]) if from_sm else rk[:, 0]
    angles = np.linalg.norm(disp, axis=1)
    angles = np.minimum(angles, 2.0 * np.pi - angles)             # unwrapped rotvecs: the rotation's angle
    inner_mask = ~(first | last)
    meta = dict(metadata or {})
    meta["fit"] = _fit_stats(angles, inner_mask, iterations, continuity)
    rotations = Channel(ROTATION, values, tangents.reshape(K - 1, J, 2, 4), refinements,
                        table.reshape(K - 1, J, M, 3), counts.reshape(K - 1, J))
    out = StaggeredMotion(
        skeleton=source.skeleton, frame_time=ft, pose_times=pose_times, rotations=rotations, translation=translation,
        editing_knots=editing, pose_probability=np.ones(K) if pose_probability is None else pose_probability,
        contacts=tuple(contacts), local_translations=lt, translation_times=tt, metadata=meta)
    report(1.0)
    return out
