"""The refit of a cull done locally (Coleman et al. 2008, §4.1.1): :func:`refit_merged` refits only the segments
that merge removed poses, keeping every other segment's spline controls and displacement map verbatim."""
from __future__ import annotations

import numpy as np

from .channel import ROTATION, Channel
from .displacement import displacements_of
from .evaluation import root_positions_at, translation_source_times
from .fit_common import _fit_mask, _fit_stats, _pin_static, _samples_of, _static_joints
from .representation import StaggeredMotion
from .rotation_fit import _rotvec_between, fit_rotation_tangents
from .rotation_fit_c1 import fit_rotation_tangents_c1, velocities_from_tangents
from .sampling import _continuous_per_pair, fit_subset, sample_segments
from .translation_fit import _fit_root

__all__ = ["refit_merged"]

_LOCAL_MAX_SHARE = 0.6   # refit_merged declines when the segments it would refit span more of the clip


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
