"""Locating staggered poses in dense motion (Coleman et al. 2008, §4.1) and culling them.

Pipeline: local evidence ``p_i(t)`` and weights ``w_i`` (:mod:`.features`), contact start/end events as
global evidence (Appendix B), the pose probability signal ``P(t) = f(Σ w_i p_i(t) / Σ w_i)`` with a tent
low-pass filter ``f`` (0.15 s), candidate poses at every local maximum of ``P`` plus the first and last
frame, priorities ``w_k = P(t_k)(t_{k+1} − t_{k−1})``, and timing refinements from the nearest local maximum of
each joint's own evidence (within ±0.25 s and closer to its pose than to the neighbours). Then
:func:`~.fitting.fit_staggered` builds the representation.
"""
from __future__ import annotations

import inspect
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import convolve1d
from scipy.signal import find_peaks

from ..core.motion import Motion
from . import _checks
from .contacts import contact_events, detect_contacts
from .features import local_evidence
from .fitting import check_evaluated, fit_staggered, refit_merged
from .representation import StaggeredMotion

__all__ = ["extract", "cull", "cull_keep", "locate_poses", "PoseEvidence", "tent_filter", "pose_probability",
           "candidate_poses", "pose_priorities", "timing_refinements", "local_maxima"]

_DIRECT_TAPS = 255   # tent kernels up to this many taps convolve directly, longer ones by FFT
_ROUND = 12   # decimals kept before peak picking, so plateaus of the tent filter stay exactly flat


def tent_filter(signal: np.ndarray, frame_time: float, width: float = 0.15) -> np.ndarray:
    """Low-pass tent filter along axis 0 (§4.1, ``f``).

    The kernel is ``max(0, 1 - |τ| / width)`` (τ in seconds; ``width`` is the half-width at which it reaches
    zero), normalised to sum 1, with ``nearest`` edges. Two unit impulses closer than ``width`` become one
    flat-topped peak (a single local maximum); farther apart they stay two peaks.
    """
    if not width > 0:
        raise ValueError(f"tent_filter: width must be > 0 seconds, got {width}")
    R = width / frame_time
    n = int(np.floor(R))
    tau = np.arange(-n, n + 1)
    k = np.maximum(0.0, 1.0 - np.abs(tau) / R)
    k /= k.sum()
    x = np.asarray(signal, dtype=float)
    if k.size <= _DIRECT_TAPS:
        return convolve1d(x, k, axis=0, mode="nearest")
    # long kernels (high frame rates, wide filters): the same "nearest"-edged convolution by FFT, O(F log F)
    from scipy.signal import oaconvolve
    pad = np.concatenate([np.repeat(x[:1], n, axis=0), x, np.repeat(x[-1:], n, axis=0)])
    return oaconvolve(pad, k.reshape((-1,) + (1,) * (x.ndim - 1)), mode="valid", axes=0)


def local_maxima(x: np.ndarray, prominence: float = 0.0) -> np.ndarray:
    """Frame indices of the interior local maxima of ``x (F,)`` (the middle frame of a flat top), optionally
    only those with at least ``prominence`` (scipy.signal.find_peaks' topographic prominence)."""
    x = np.round(np.asarray(x, dtype=float), _ROUND)
    return find_peaks(x, prominence=prominence if prominence > 0 else None)[0]


def pose_probability(evidence: np.ndarray, weights: np.ndarray, frame_time: float,
                     filter_width: float = 0.15) -> np.ndarray:
    """Pose probability signal ``P(t) = f(Σ_i w_i p_i(t) / Σ_i w_i)``, shape (F,) (§4.1, "Aggregating").

    ``evidence (F, C)`` in [0, 1], ``weights (C,)`` >= 0. A motion with all weights 0 has ``P = 0``.
    """
    w = np.asarray(weights, dtype=float)
    if np.any(w < 0):
        raise ValueError("pose_probability: weights must be >= 0")
    tot = w.sum()
    if tot <= 0:
        return np.zeros(evidence.shape[0])
    return tent_filter(evidence @ (w / tot), frame_time, filter_width)


def candidate_poses(P: np.ndarray, min_prominence: float = 0.01) -> np.ndarray:
    """Candidate pose frames (K,): the local maxima of ``P`` plus the first and last frame (§4.1).

    ``min_prominence`` (a fraction of ``max P``) drops ripples: maxima whose prominence is below it. 0 keeps
    every local maximum, as in the paper; the default 1 % removes the sub-0.1 % wiggles that nearby contact
    events leave on a flat-topped peak.
    """
    F = P.shape[0]
    if F < 2:
        raise ValueError(f"candidate_poses: need at least 2 frames, got {F}")
    if not min_prominence >= 0:
        raise ValueError(f"candidate_poses: min_prominence must be >= 0, got {min_prominence}")
    peaks = local_maxima(P, min_prominence * float(np.max(P)))
    return np.unique(np.concatenate([[0], peaks, [F - 1]]))


def pose_priorities(pose_times: np.ndarray, probability: np.ndarray) -> np.ndarray:
    """Priorities ``w_k = P(t_k)(t_{k+1} − t_{k−1})`` (§4.1), shape (K,); first and last are ``inf``."""
    t = np.asarray(pose_times, dtype=float)
    w = np.full(t.size, np.inf)
    if t.size > 2:
        w[1:-1] = np.asarray(probability, dtype=float)[1:-1] * (t[2:] - t[:-2])
    return w


def timing_refinements(evidence: np.ndarray, pose_frames: np.ndarray, frame_time: float,
                       window: float = 0.25) -> np.ndarray:
    """Refinements in frames (K, C): nearest local maximum of each column of ``evidence`` (F, C).

    For pose ``k`` at frame ``f_k`` a maximum ``e`` qualifies if ``|e - f_k| <= window`` (seconds) and it is
    strictly closer to ``f_k`` than to ``f_{k-1}`` and ``f_{k+1}``; the nearest qualifying maximum wins (the
    earlier on a tie); none gives 0 (§4.1, "Timing refinements"). First and last poses get 0.
    """
    f = np.asarray(pose_frames, dtype=np.int64)
    K = f.size
    C = evidence.shape[1]
    W = window / frame_time + 1e-9
    out = np.zeros((K, C), dtype=np.int64)
    if K < 3:
        return out
    fk, fp, fn = f[1:-1], f[:-2], f[2:]
    for c in range(C):
        e = local_maxima(evidence[:, c])
        if e.size == 0:
            continue
        i = np.searchsorted(e, fk, side="right")              # e[i-1] <= f_k < e[i]
        left = e[np.maximum(i - 1, 0)]
        right = e[np.minimum(i, e.size - 1)]
        okl = (i > 0) & (fk - left <= W) & (fk - left < left - fp)
        okr = (i < e.size) & (right - fk <= W) & (right - fk < fn - right)
        dl = np.where(okl, fk - left, np.iinfo(np.int64).max)
        dr = np.where(okr, right - fk, np.iinfo(np.int64).max)
        r = np.where(dl <= dr, left - fk, right - fk)
        out[1:-1, c] = np.where(okl | okr, r, 0)
    return out


_MAX_SMOOTHING_PASSES = 10 ** 12   # passes cost O(F log F) whatever their number (see laplacian_smooth)
_MAX_ITERATIONS = 100             # Levenberg-Marquardt steps of the fit (each costs ~7 spline evaluations)


def _check_contacts(where: str, contacts, motion: Motion):
    if contacts is None:
        return None
    try:
        items = list(contacts)
    except TypeError:
        raise ValueError(f"{where}: contacts must be a list of (joint_name, start_frame, stop_frame), "
                         f"got {contacts!r}") from None
    names = set(motion.skeleton.names)
    out = []
    for c in items:
        ok = isinstance(c, (tuple, list)) and len(c) == 3 and isinstance(c[0], str) and c[0] in names
        if ok:
            try:
                a = _checks.integer(where, "contacts[].start_frame", c[1], 0, motion.num_frames - 1)
                b = _checks.integer(where, "contacts[].stop_frame", c[2], a + 1, motion.num_frames)
            except ValueError:
                ok = False
        if not ok:
            raise ValueError(f"{where}: contacts must hold (joint_name, start_frame, stop_frame) with a joint of "
                             f"the skeleton and 0 <= start < stop <= {motion.num_frames}, got {c!r}")
        out.append((c[0], a, b))
    return out


def _check_locate_options(where: str, motion: Motion, o: dict) -> dict:
    """The options of :func:`locate_poses`, checked (type and range; ValueError naming the option)."""
    R, I = _checks.real, _checks.integer
    return dict(
        filter_width=R(where, "filter_width", o["filter_width"], 0.0, 10.0, lo_open=True),
        refinement_window=R(where, "refinement_window", o["refinement_window"], 0.0, 10.0),
        smoothing_iterations=I(where, "smoothing_iterations", o["smoothing_iterations"], 0, _MAX_SMOOTHING_PASSES,
                               none_ok=True),
        smoothing_lambda=R(where, "smoothing_lambda", o["smoothing_lambda"], 0.0, 1.0, lo_open=True),
        root_translation_weight=R(where, "root_translation_weight", o["root_translation_weight"], 0.0, 1e6),
        contacts=_check_contacts(where, o["contacts"], motion),
        contact_weight=R(where, "contact_weight", o["contact_weight"], 0.0, 1e6),
        contact_tolerance=R(where, "contact_tolerance", o["contact_tolerance"], 0.0, None, lo_open=True,
                            none_ok=True),
        contact_min_duration=R(where, "contact_min_duration", o["contact_min_duration"], 0.0,
                               max(motion.duration, 1.0), lo_open=True),
        min_prominence=R(where, "min_prominence", o["min_prominence"], 0.0, 1.0))


@dataclass(frozen=True, eq=False)
class PoseEvidence:
    """Everything §4.1 computes before fitting.

    Attributes
    ----------
    frames : (K,) int, candidate pose frames (first and last included)
    probability : (F,) the pose probability signal P(t)
    evidence : (F, J + 2) columns: joint rotations p_i (J), root translation, contact events
    weights : (J + 2,) the matching weights w_i
    refinement_frames : (K, J + 1) int, refinements of the joint rotations and the root translation
    contacts : list of (joint_name, start_frame, stop_frame)
    """

    frames: np.ndarray
    probability: np.ndarray
    evidence: np.ndarray
    weights: np.ndarray
    refinement_frames: np.ndarray
    contacts: tuple


def locate_poses(motion: Motion, *, filter_width: float = 0.15, refinement_window: float = 0.25,
                 smoothing_iterations: int | None = None, smoothing_lambda: float = 0.5,
                 root_translation_weight: float = 1.0, contacts=None, contact_weight: float = 0.25,
                 contact_tolerance: float | None = None, contact_min_duration: float = 0.25,
                 min_prominence: float = 0.01) -> PoseEvidence:
    """Candidate pose frames, the pose probability signal and refinements of ``motion`` (§4.1).

    Parameters
    ----------
    filter_width : seconds, tent filter half-width (paper: 0.15 s)
    refinement_window : seconds, bound on refinements (paper: 0.25 s)
    smoothing_iterations, smoothing_lambda : Laplacian smoothing of the local evidence
    root_translation_weight : scales the root-translation weight (its trail's arc length)
    contacts : list of (joint_name, start, stop), optional; default :func:`detect_contacts`; ``[]`` disables
    contact_weight : weight of the contact-event signal as a fraction of the summed local weights
    contact_tolerance, contact_min_duration : passed to :func:`detect_contacts`
    min_prominence : fraction of max P below which a local maximum of P is a ripple, not a candidate
    """
    if not isinstance(motion, Motion):
        raise ValueError(f"locate_poses: motion must be a Motion, got {type(motion).__name__}")
    F = motion.num_frames
    if F < 2:
        raise ValueError(f"locate_poses: motion needs at least 2 frames, got {F}")
    _checks.frame_time("locate_poses", motion.frame_time)
    opts = _check_locate_options("locate_poses", motion, dict(
        filter_width=filter_width, refinement_window=refinement_window, smoothing_iterations=smoothing_iterations,
        smoothing_lambda=smoothing_lambda, root_translation_weight=root_translation_weight, contacts=contacts,
        contact_weight=contact_weight, contact_tolerance=contact_tolerance,
        contact_min_duration=contact_min_duration, min_prominence=min_prominence))
    (filter_width, refinement_window, smoothing_iterations, smoothing_lambda, root_translation_weight, contacts,
     contact_weight, contact_tolerance, contact_min_duration, min_prominence) = opts.values()
    p, w = local_evidence(motion, smoothing_iterations, smoothing_lambda, root_translation_weight)
    if contacts is None:
        contacts = detect_contacts(motion, contact_tolerance, contact_min_duration)
    ev = contact_events(contacts, F)
    evidence = np.concatenate([p, ev[:, None]], axis=1)
    weights = np.concatenate([w, [contact_weight * w.sum() if len(contacts) else 0.0]])
    P = pose_probability(evidence, weights, motion.frame_time, filter_width)
    frames = candidate_poses(P, min_prominence)
    ref = timing_refinements(p, frames, motion.frame_time, refinement_window)
    return PoseEvidence(frames, P, evidence, weights, ref, tuple(contacts))


def extract(motion: Motion, *, iterations: int = 2, continuity: str = "C1", fit_samples: int | None = 12,
            progress=None, **options) -> StaggeredMotion:
    """Staggered-pose representation of dense ``motion`` with all candidate poses (§4).

    ``options`` go to :func:`locate_poses`; ``iterations``, ``continuity`` ("C1" or "C0") and ``fit_samples``
    to :func:`~.fitting.fit_staggered`. ``progress``: callable(fraction in [0, 1]) or None, called as the
    work advances (the notebook/session layer draws the bar). Every option is checked (ValueError naming
    it); frame times below 0.1 ms are refused (resample first). The result reproduces the
    input exactly at its frames (displacement maps, §4.1.1); ``sm.metadata`` holds ``"probability"``
    (F,), ``"evidence"`` (F, J + 2), ``"weights"`` (J + 2,) and the fit statistics ``"fit"``.
    """
    if not isinstance(motion, Motion):
        raise ValueError(f"extract: motion must be a Motion, got {type(motion).__name__}")
    iterations = _checks.integer("extract", "iterations", iterations, 0, _MAX_ITERATIONS)
    if not isinstance(continuity, str) or continuity not in ("C0", "C1"):
        raise ValueError(f"extract: continuity must be 'C0' or 'C1', got {continuity!r}")
    known = inspect.signature(locate_poses).parameters
    for k in options:
        if k not in known or known[k].kind is not inspect.Parameter.KEYWORD_ONLY:
            raise ValueError(f"extract: unknown option {k!r}; options are iterations, continuity, "
                             f"{', '.join(n for n, p in known.items() if p.kind is p.KEYWORD_ONLY)}")
    fit_samples = _checks.integer("extract", "fit_samples", fit_samples, 4, 2 ** 31, none_ok=True)
    _checks.frame_time("extract", motion.frame_time)
    report = progress if progress is not None else (lambda f: None)
    report(0.0)
    loc = locate_poses(motion, **options)
    report(0.3)
    ft = motion.frame_time
    J = motion.num_joints
    meta = {"probability": loc.probability, "evidence": loc.evidence, "weights": loc.weights,
            "candidate_frames": loc.frames}
    return fit_staggered(motion, loc.frames * ft, loc.refinement_frames[:, :J] * ft,
                         loc.refinement_frames[:, J] * ft, pose_probability=loc.probability[loc.frames],
                         contacts=loc.contacts, iterations=iterations, continuity=continuity,
                         fit_samples=fit_samples, metadata=meta, progress=lambda f: report(0.3 + 0.7 * f))


def cull_keep(sm: StaggeredMotion, percent: float | None = None, *, count: int | None = None,
              interval=None) -> np.ndarray:
    """Indices (sorted, first and last included) of the poses :func:`cull` keeps for these arguments (the
    same meaning as there), without refitting: priorities ``w_k`` (:func:`pose_priorities`) are ranked once.
    Callers caching culls can key them by this (many percents keep the same poses)."""
    if not isinstance(sm, StaggeredMotion):
        raise ValueError(f"cull: sm must be a StaggeredMotion, got {type(sm).__name__}")
    percent = _checks.real("cull", "percent", percent, 0.0, 100.0, lo_open=True, none_ok=True)
    count = _checks.integer("cull", "count", count, 2, 2 ** 62, none_ok=True)
    K = sm.num_poses
    t = sm.pose_times
    eligible = np.ones(K, dtype=bool)
    if interval is not None:
        a, b = (float(x) for x in interval)
        if not b >= a:
            raise ValueError(f"cull: interval must be (start, stop) with stop >= start, got {interval!r}")
        eligible = (t >= a) & (t <= b)
    if count is not None:
        n = count
    elif percent is not None or interval is None:
        pc = 50.0 if percent is None else percent
        n = max(int(np.ceil(pc / 100.0 * K - 1e-9)), 2)
    else:
        n = K
    prio = pose_priorities(t, sm.pose_probability)
    interior = np.flatnonzero(eligible[1:-1]) + 1
    order = interior[np.argsort(-prio[interior], kind="stable")]
    return np.sort(np.concatenate([[0, K - 1], order[: max(n - 2, 0)]]))


def cull(sm: StaggeredMotion, percent: float | None = None, *, count: int | None = None,
         interval=None, iterations: int = 2, continuity: str = "C1", fit_samples: int | None = 12,
         progress=None, local: bool = True, evaluated=None) -> StaggeredMotion:
    """Keep the highest-priority poses (§4.1, "Prioritized pose extraction"); first and last always stay.

    Parameters
    ----------
    sm : StaggeredMotion
    percent : float in (0, 100], optional
        Keep ``ceil(percent / 100 * K)`` poses (at least 2). Default 50 when neither ``count`` nor
        ``interval`` is given.
    count : int >= 2, optional
        Keep this many poses (overrides ``percent``).
    interval : (start, stop) seconds, optional
        Choose poses only from this time interval (plus the first and last); without ``percent``/``count``
        every pose inside is kept.
    iterations, continuity, fit_samples : passed to the refit (:func:`~.fitting.fit_staggered`)
    progress : callable(fraction in [0, 1]) or None, called as the refit advances
    local : bool
        True (default): refit only the merged segments (:func:`~.fitting.refit_merged`); segments between
        two kept consecutive poses keep their controls and displacement maps, and C1 velocities at knots
        beside them stay fixed. Applies to an on-grid ``sm`` fitted with the same ``iterations`` and
        ``continuity``, else falls back to the full refit. False: refit every segment (:func:`fit_staggered`).
        Both reproduce ``sm`` exactly at the frames; their splines differ by what the full refit's global
        C1 steps move away from the removed poses (tests/test_staggered_cull_local.py bounds it).
    evaluated : Motion, optional
        ``evaluate(sm)`` when the caller already has it: the refit reads ``sm``'s samples on frames from it
        instead of evaluating them again (same result up to rounding ~1e-15 and quaternion sign).

    Returns
    -------
    A new StaggeredMotion on the kept poses whose splines and displacement maps are re-measured over the
    merged segments from ``sm`` itself (§5.1: "we update the displacement map to preserve the global
    transition values"). Exact at the frame grid while knots sit on frames (unedited timing); after
    off-grid retiming the merged displacement maps are resampled at 4 samples per frame, which leaves
    errors of order 1e-3 rad at the frames (the retimed motion has velocity kinks at its old knots).
    """
    iterations = _checks.integer("cull", "iterations", iterations, 0, _MAX_ITERATIONS)
    if not isinstance(continuity, str) or continuity not in ("C0", "C1"):
        raise ValueError(f"cull: continuity must be 'C0' or 'C1', got {continuity!r}")
    fit_samples = _checks.integer("cull", "fit_samples", fit_samples, 4, 2 ** 31, none_ok=True)
    keep = cull_keep(sm, percent, count=count, interval=interval)
    _checks.frame_time("cull", sm.frame_time)
    evaluated = check_evaluated("cull", sm, evaluated)
    K = sm.num_poses
    t = sm.pose_times
    if keep.size == K:
        return sm
    # knots of the kept poses, made strictly increasing if edits pushed knots past each other (evaluate
    # reads such columns through a running maximum; the refit needs positive segment lengths)
    tk = t[keep]
    ref, rref = sm.refinements[keep], sm.root_refinements[keep]
    kt, rk = tk[:, None] + ref, tk + rref
    kt2 = _strictly_increasing(kt, sm.frame_time)
    rk2 = _strictly_increasing(rk[:, None], sm.frame_time)[:, 0]
    ref = np.where(kt2 != kt, kt2 - tk[:, None], ref)            # untouched knots keep their refinement
    rref = np.where(rk2 != rk, rk2 - tk, rref)
    all_k = np.concatenate([(tk[:, None] + ref).ravel(), tk + rref]) / sm.frame_time
    on_grid = np.all(np.abs(all_k - np.rint(all_k)) < 1e-6)
    meta = {k: v for k, v in sm.metadata.items() if k != "fit"}
    if local and on_grid and np.array_equal(kt2, kt) and np.array_equal(rk2, rk):
        out = refit_merged(sm, keep, iterations=iterations, continuity=continuity, fit_samples=fit_samples,
                           metadata=meta, progress=progress, evaluated=evaluated)
        if out is not None:
            return out
    return fit_staggered(sm, tk, ref, rref,
                         pose_probability=sm.pose_probability[keep], contacts=sm.contacts,
                         iterations=iterations, continuity=continuity, oversample=1 if on_grid else 4,
                         fit_samples=fit_samples, metadata=meta, progress=progress, evaluated=evaluated)


def _strictly_increasing(knots: np.ndarray, frame_time: float) -> np.ndarray:
    """Running maximum down each column, then at least ``1e-3 frame_time`` between consecutive knots."""
    out = np.maximum.accumulate(np.array(knots, dtype=float), axis=0)
    gap = 1e-3 * frame_time
    for k in range(1, out.shape[0]):
        out[k] = np.maximum(out[k], out[k - 1] + gap)
    return out
