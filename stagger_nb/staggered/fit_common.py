"""What the full fit (:func:`~.fitting.fit_staggered`) and the local refit of a cull
(:func:`~.refit.refit_merged`) share (Coleman et al. 2008, §4.1.1): which samples a pair is fitted to, static
joints pinned to their quaternion, the fit's statistics, and the source's samples when the source is itself a
:class:`~.representation.StaggeredMotion`."""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from .evaluation import evaluate_samples, static_rotations
from .representation import StaggeredMotion


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

