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
:mod:`.displacement`. This module assembles them: :func:`fit_staggered` and the local refit of a cull,
:func:`refit_merged`.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from .channel import ROTATION, Channel
from .displacement import displacement_table, displacements_of
from .evaluation import evaluate_samples, root_positions_at, static_rotations, translation_source_times
from .representation import StaggeredMotion
from .rotation_fit import _rotvec_between, fit_rotation_tangents
from .rotation_fit_c1 import fit_rotation_tangents_c1, velocities_from_tangents
from .sampling import _continuous_per_joint, _continuous_per_pair, _read, fit_subset, sample_segments
from .translation_fit import _fit_root

__all__ = ["fit_staggered", "refit_merged"]

_LOCAL_MAX_SHARE = 0.6   # refit_merged declines when the segments it would refit span more of the clip


def _fit_mask(sub, first, last, moving):
    """The samples (N,) bool the splines are fitted to: ``sub`` (:func:`fit_subset`) without the samples
    that cannot inform a fit. The end samples of a pair are its knot values, which every spline of that pair
    meets (the Bernstein weights of the inner controls vanish there: no residual, no Jacobian); samples of
    static joints (``moving`` False, :func:`_static_joints`) fit exactly with a zero velocity, their start.
    Leaving them out keeps the fit (to rounding) and saves their share of every spline evaluation."""
    return sub & ~first & ~last & moving


def _pin_static(tangents, static, const):
    """``tangents (P, 2, 4)`` (pairs segment-major over J joints) with the controls of static joints set to
    their quaternion bit for bit (the fit gives it up to the last bit of a normalisation), so the result is
    recognised as static by :func:`_static_joints` when it is refitted (culls)."""
    if not static.any():
        return tangents
    J = static.size
    jp = np.arange(tangents.shape[0]) % J
    sel = static[jp]
    tangents = np.array(tangents)
    tangents[sel] = const[jp[sel]][:, None, :]
    return tangents


def _static_joints(source):
    """``(J,) bool, (J, 4)``: the joints whose rotation is one quaternion over the whole ``source``, and
    each joint's first rotation. A Motion: every frame equal bit for bit. A StaggeredMotion: every knot and
    control equal to the first knot and the displacement map zero (its ``evaluate`` is then that
    quaternion up to rounding)."""
    if isinstance(source, StaggeredMotion):
        return static_rotations(source)
    q = source.local_quats
    return np.all(q == q[0], axis=(0, 2)), q[0]


def _fit_stats(angles, inner, iterations, continuity):
    """``metadata["fit"]`` of :func:`fit_staggered` from the residual angles (rad) of every sample."""
    return {"mean_residual_rad": float(angles[inner].mean()) if inner.any() else 0.0,
            "max_residual_rad": float(angles.max()) if angles.size else 0.0,
            "iterations": iterations, "continuity": continuity}


def check_evaluated(name: str, sm: StaggeredMotion, evaluated):
    """Validate ``evaluated`` (None or ``evaluate(sm)``: a Motion of ``sm``'s joints and frame time whose
    frame f is at ``pose_times[0] + f * frame_time``); returns it."""
    if evaluated is None:
        return None
    F = int(np.floor(sm.duration / sm.frame_time + 1e-6)) + 1
    if (not isinstance(evaluated, Motion) or evaluated.num_joints != sm.num_joints
            or evaluated.num_frames != F or evaluated.frame_time != sm.frame_time):
        raise ValueError(f"{name}: evaluated must be evaluate(sm) (a Motion of {F} frames x {sm.num_joints} "
                         f"joints at frame_time {sm.frame_time}), got {evaluated!r}")
    return evaluated


def _samples_of(sm: StaggeredMotion, evaluated, times: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """``evaluate_samples(sm, times, joints)`` (N, 4), read from ``evaluated = evaluate(sm)`` (or None) at
    the samples that fall on its frames."""
    if evaluated is None:
        return evaluate_samples(sm, times, joints)
    lq = evaluated.local_quats
    f = (times - sm.pose_times[0]) / sm.frame_time
    r = np.rint(f)
    on = (np.abs(f - r) < 1e-9) & (r >= 0) & (r <= lq.shape[0] - 1)
    if on.all():
        return lq[r.astype(np.int64), joints]
    out = np.empty((times.size, 4))
    out[on] = lq[r[on].astype(np.int64), joints[on]]
    off = ~on
    out[off] = evaluate_samples(sm, times[off], joints[off])
    return out


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


def refit_merged(sm: StaggeredMotion, keep, *, iterations: int = 2, continuity: str = "C1",
                 fit_samples: int | None = 12, metadata: dict | None = None, progress=None, evaluated=None):
    """The refit of :func:`~.extraction.cull` done locally: only segments that merge removed poses change.

    ``keep (K',)`` sorted pose indices of ``sm`` (first and last included). A kept segment between two
    consecutive poses of ``sm`` keeps its spline controls and displacement map verbatim. The merged
    segments (``keep[i + 1] - keep[i] > 1``) are fitted to ``sm`` itself (samples at the frames, as
    :func:`fit_staggered` with a StaggeredMotion source), with their displacement maps re-measured.

    Continuity: "C0" fits are per segment, so the result equals a full refit up to rounding. "C1" couples
    all knots of a joint through one angular velocity per knot (:func:`fit_rotation_tangents_c1`); here each
    run of consecutive merged segments is refitted with the velocities at its end knots fixed to those of
    the adjacent kept segments (so the splines stay C1 across the joins), its inner knots free. The full refit
    instead also moves the velocities of knots away from the removed poses (its Levenberg–Marquardt step is
    global per joint); the two differ by what those steps move, which the displacement maps absorb:
    both reproduce ``sm`` exactly at the frames.

    The root translation is refitted whole (cheap, and then identical to the full refit).
    ``evaluated``: ``evaluate(sm)`` if the caller has it (see :func:`fit_staggered`; validated by the caller).

    Returns the new StaggeredMotion, or None when the local refit does not apply or does not pay (the
    refitted segments span more than 60 % of the clip: measured as fast as the full refit there; knots off the
    frame grid,
    ``sm`` fitted with other options or other displacement sampling, a knot value of opposite sign to the
    samples beside it); the caller then refits fully.
    """
    keep = np.asarray(keep, dtype=np.int64)
    fit = sm.metadata.get("fit") or {}
    if fit.get("continuity") != continuity or fit.get("iterations") != iterations or keep.size < 2:
        return None
    J, ft, Kc = sm.num_joints, sm.frame_time, keep.size
    report = progress if progress is not None else (lambda f: None)
    old_knots = sm.pose_times[:, None] + sm.refinements
    merged = np.diff(keep) > 1                                          # (Kc - 1,) merged segments
    # refitted: the merged segments and one kept segment on each side, so the velocities at the merged
    # segments' ends are free (a velocity fitted over a short segment does not suit a long one) and the
    # fixed ones sit at the far ends of short kept segments
    changed = merged.copy()
    changed[1:] |= merged[:-1]
    changed[:-1] |= merged[1:]
    unch = np.flatnonzero(~changed)
    span = np.diff(sm.pose_times[keep])
    if span[changed].sum() > _LOCAL_MAX_SHARE * span.sum():
        return None                                    # most of the clip changes: the full refit is as fast
    if np.any(sm.displacement_counts[keep[unch]]
              != np.maximum(np.rint(np.diff(old_knots, axis=0)[keep[unch]] / ft).astype(np.int64) + 1, 2)):
        return None                                    # kept segments sampled otherwise (oversampled fits)
    tk = sm.pose_times[keep]
    knots = tk[:, None] + sm.refinements[keep]
    values = sm.values[keep]
    tangents = np.array(sm.tangents[keep[:-1]])
    counts = np.array(sm.displacement_counts[keep[:-1]])
    ci = np.flatnonzero(changed)
    sel = np.unique(np.concatenate([ci, ci + 1]))                       # knots touching a merged segment
    Ks = sel.size
    real = (np.diff(sel) == 1) & changed[sel[:-1]]                      # sub-segments that are merged ones
    # a knot bordering a kept segment keeps that segment's velocity (C1); others are free
    out_kept = (sel < Kc - 1) & ~changed[np.minimum(sel, Kc - 2)]
    in_kept = (sel > 0) & ~changed[np.maximum(sel - 1, 0)]
    fixed = out_kept | in_kept
    ks, vs = knots[sel], values[sel]
    P = (Ks - 1) * J
    pair, m, cnt, tn, frames = sample_segments(ks, ft, 0.0, 1)
    seg = pair // J
    last = m == cnt[pair] - 1
    use = real[seg] | (m == 0) | last              # sub-segments between two fixed knots: ends only
    pair, m, tn, frames, last = pair[use], m[use], tn[use], frames[use], last[use]
    seg = pair // J
    m = np.where(real[seg] | (m == 0), m, 1)
    cnt = np.where(np.repeat(real, J), cnt, 2)
    v0, v3 = vs[:-1].reshape(P, 4), vs[1:].reshape(P, 4)
    first = m == 0
    inner = real[seg] & ~first & ~last
    targets = np.empty((pair.size, 4))
    targets[inner] = _samples_of(sm, evaluated, frames[inner] * ft, pair[inner] % J)
    targets[first] = v0[pair[first]]
    targets[last] = v3[pair[last]]
    cont = _continuous_per_pair(targets, first)
    if np.any((np.sum(cont[last] * targets[last], axis=1) < 0) & real[seg[last]]):
        return None                                    # a knot value on the other sign of its samples
    targets = np.where(real[seg][:, None], cont, targets)
    report(0.2)
    sub = _fit_mask(fit_subset(m, cnt, pair, fit_samples), first, last, ~_static_joints(sm)[0][pair % J])
    tn_f, targets_f, pair_f = tn[sub], targets[sub], pair[sub]
    if continuity == "C1":
        start, _ = fit_rotation_tangents(tn_f, targets_f, pair_f, v0, v3, P, 0)
        omega = velocities_from_tangents(vs, start.reshape(Ks - 1, J, 2, 4), ks)
        d_old = np.diff(old_knots, axis=0)[..., None]
        ko, ki = keep[sel[out_kept]], keep[sel[in_kept]] - 1            # the kept segments of sm beside them
        omega[out_kept] = 3.0 * _rotvec_between(sm.values[ko].reshape(-1, 4), sm.tangents[ko, :, 0].reshape(-1, 4)
                                                ).reshape(-1, J, 3) / d_old[ko]
        omega[in_kept & ~out_kept] = (3.0 * _rotvec_between(sm.tangents[ki, :, 1].reshape(-1, 4),
                                                            sm.values[ki + 1].reshape(-1, 4)).reshape(-1, J, 3)
                                      / d_old[ki])[~out_kept[in_kept]]
        _, tg, _ = fit_rotation_tangents_c1(tn_f, targets_f, pair_f, vs, ks, omega, iterations, fixed=fixed)
    else:
        tg, _ = fit_rotation_tangents(tn_f, targets_f, pair_f, v0, v3, P, iterations)
    report(0.7)
    # merged segments: new controls and displacement maps
    rs = np.repeat(real, J)[pair]
    rp = pair[rs]
    disp = displacements_of(ROTATION, v0[rp], tg[rp, 0], tg[rp, 1], v3[rp], np.arange(rp.size), tn[rs], targets[rs],
                            rp)
    dest = sel[:-1][real]                                               # culled segment of each real one
    tangents[dest] = _pin_static(tg, *_static_joints(sm)).reshape(Ks - 1, J, 2, 4)[real]
    counts[dest] = cnt.reshape(Ks - 1, J)[real]
    M = int(counts.max())
    table = np.zeros((Kc - 1, J, M, 3))
    Mo = min(M, sm.displacements.shape[2])
    table[unch, :, :Mo] = sm.displacements[keep[unch], :, :Mo]
    seg_c = sel[rp // J]
    table[seg_c, rp % J, m[rs]] = disp
    # residual statistics over every sample (kept segments from their stored maps)
    idx = np.arange(M)
    valid = idx < counts[..., None]
    ang = np.linalg.norm(table, axis=-1)
    ang = np.minimum(ang, 2.0 * np.pi - ang)
    inner_t = valid & (idx > 0) & (idx < counts[..., None] - 1)
    meta = dict(metadata or {})
    meta["fit"] = _fit_stats(ang[valid], inner_t[valid], iterations, continuity)
    rr = sm.root_refinements[keep]
    rk = tk + rr
    translation = _fit_root(lambda f: root_positions_at(sm, f * ft), rk, rr, ft, 0.0, 1, continuity)
    lt = sm.local_translations
    out = StaggeredMotion(
        skeleton=sm.skeleton, frame_time=ft, pose_times=tk,
        rotations=Channel(ROTATION, values, tangents, sm.refinements[keep], table, counts), translation=translation,
        editing_knots=sm.editing_knots[keep], pose_probability=sm.pose_probability[keep],
        contacts=tuple(sm.contacts), local_translations=lt,
        translation_times=None if lt is None else translation_source_times(sm, rk), metadata=meta)
    report(1.0)
    return out
