"""The staggered-pose motion representation (Coleman et al. 2008, §3); its evaluation is in ``evaluation.py``.

Glossary: F source frames, J joints, K staggered poses (K >= 2), K - 1 segments, M displacement samples.

For joint ``i`` the knot of pose ``k`` sits at the *refined time* ``T[k, i] = t_k + r[k, i]`` with the
extreme value ``v[k, i]`` ("the equivalent knot in a traditional spline representation is
(t_k + r_{k,i}, v_{k,i})", §3). Between two knots a control variable is

    v_i(t) = s_i(t') ⊕ d_i(t'),   t' = (t - T[k, i]) / (T[k+1, i] - T[k, i])        (§3)

with ``s_i`` a cubic spline on the normalised segment time ``t'`` (a quaternion Bézier by recursive slerp,
Appendix A, for rotations; a cubic Bézier for the root translation) and ``d_i`` a displacement map, also a
function of ``t'`` so that it follows the segment when timing changes. For rotations ``a ⊕ b`` is
``quat_mul(a, b)`` (the displacement is applied in the joint's local frame, after the spline rotation) and
``c ⊖ a = quat_mul(quat_conj(a), c)``; for translations they are ``+`` and ``-``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core._arrays import readonly
from ..core.skeleton import Skeleton
from .channel import ROTATION, TRANSLATION, Channel

__all__ = ["StaggeredMotion", "knot_times", "default_times"]

# the former array fields of StaggeredMotion: (channel, channel field); the constructor accepts them
_ARRAYS = {"values": ("rotations", "values"), "tangents": ("rotations", "tangents"),
           "refinements": ("rotations", "refinements"), "displacements": ("rotations", "displacements"),
           "displacement_counts": ("rotations", "counts"), "root_values": ("translation", "values"),
           "root_tangents": ("translation", "tangents"), "root_refinements": ("translation", "refinements"),
           "root_displacements": ("translation", "displacements"),
           "root_displacement_counts": ("translation", "counts")}
_LABELS = {w: {f: n for n, (w2, f) in _ARRAYS.items() if w2 == w} for w in ("rotations", "translation")}


def _legacy_shape(name: str, K: int, J: int) -> tuple:
    return {"values": (K, J, 4), "tangents": (K - 1, J, 2, 4), "refinements": (K, J),
            "displacement_counts": (K - 1, J), "root_values": (K, 3), "root_tangents": (K - 1, 2, 3),
            "root_refinements": (K,), "root_displacement_counts": (K - 1,), "root_displacements": None}[name]


@dataclass(frozen=True, eq=False, init=False)
class StaggeredMotion:
    """A motion as a sequence of staggered poses plus splines and displacement maps (§3).

    Every array is a read-only copy. The control variables are two :class:`~.channel.Channel` objects
    (``rotations``: J joint rotations; ``translation``: the root translation, one column), whose arrays are
    also read as the attributes below (``values``, ``root_values``, ...); the constructor and
    ``dataclasses.replace`` accept those names too (e.g. ``dataclasses.replace(sm, displacements=...)``
    replaces that array of ``sm.rotations``). ``evaluate`` recomputes everything it needs from the fields
    (no hidden caches), so any consistent replacement is valid.

    Attributes
    ----------
    skeleton : Skeleton
        The source skeleton (joint 0 is the root; its rotation is an ordinary rotation control variable).
    frame_time : float
        Seconds between frames of the source, and of ``evaluate(sm)``'s default output.
    pose_times : ndarray, shape (K,), seconds
        Staggered pose times ``t_k``, strictly increasing. ``evaluate`` covers ``[t_0, t_{K-1}]`` by default.
    rotations : Channel (algebra ROTATION, J columns)
        ``values``, ``tangents``, ``refinements``, ``displacements``, ``displacement_counts`` below.
    translation : Channel (algebra TRANSLATION, 1 column)
        ``root_values``, ``root_tangents``, ``root_refinements``, ``root_displacements``,
        ``root_displacement_counts`` below (the channel's arrays without their column axis).
    refinements : ndarray, shape (K, J), seconds
        Timing refinements ``r_{k,i}`` of each joint rotation. Knot times ``T = pose_times[:, None] +
        refinements`` must be strictly increasing down each column for a meaningful motion (extraction
        guarantees it: a refinement is closer to its own pose than to the neighbours and the first and
        last rows are 0). ``evaluate`` tolerates violations by making each column non-decreasing with a
        running maximum (a zero-length segment then contributes nothing).
    values : ndarray, shape (K, J, 4), (x, y, z, w)
        Extreme-value knots ``v_{k,i}``: local rotation of joint ``i`` at time ``T[k, i]``. The spline of
        segment ``k`` interpolates ``values[k]`` at ``t' = 0`` and ``values[k + 1]`` at ``t' = 1``.
    tangents : ndarray, shape (K - 1, J, 2, 4), (x, y, z, w)
        Inner control quaternions ``(q̂2, q̂3)`` of each segment's Bézier ``s(v_k, q̂2, q̂3, v_{k+1}, t')``
        (Appendix A). Unit norm. The default fit is C1: at every interior knot the body angular velocities
        ``3 log(q̂3_{k-1}^-1 v_k) / Δ_{k-1}`` and ``3 log(v_k^-1 q̂2_k) / Δ_k`` (Δ = knot-time spacing) agree.
        An edit ``v_k <- v_k ⊕ δ`` that also applies ``⊕ δ`` to the two adjacent controls ``q̂3_{k-1}`` and
        ``q̂2_k`` keeps that equality (both velocities are conjugated by δ); changing refinements rescales
        Δ and so changes the velocities, not the values.
    displacements : ndarray, shape (K - 1, J, M, 3), rotation vectors (axis * angle, radians)
        Displacement map ``d_i(t')`` of each segment and joint, sampled on the uniform grid
        ``t'_m = m / (n - 1)``, ``m = 0 .. n - 1`` with ``n = displacement_counts[k, i]``; entries
        ``m >= n`` are padding (zeros). Between grid points the rotation vector is interpolated linearly.
        ``d = v ⊖ s`` (§4.1.1), i.e. ``v = quat_mul(s, rotvec_to_quat(d))``. Unwrapped along each grid:
        angles run continuously in [0, 2 pi) (not folded to <= pi), so interpolation never jumps.
    displacement_counts : ndarray, shape (K - 1, J), int >= 2
        Number of valid samples ``n`` of each displacement map (at extraction: source frames spanned + 1,
        so the grid points fall exactly on source frames).
    root_values : ndarray, shape (K, 3), file units
        Root translation knots at the refined times ``pose_times + root_refinements``.
    root_refinements : ndarray, shape (K,), seconds
        Timing refinements of the root *translation* control variable (the root *rotation* uses
        ``refinements[:, 0]``). Temporal tools that stagger the root should shift both.
    root_tangents : ndarray, shape (K - 1, 2, 3), file units
        Inner control points ``(p1, p2)`` of each segment's cubic Bézier for the root translation.
    root_displacements : ndarray, shape (K - 1, Mr, 3), file units
        Root translation displacement map per segment on the same kind of uniform ``t'`` grid
        (``v = s + d``, linear interpolation between samples), padded with zeros.
    root_displacement_counts : ndarray, shape (K - 1,), int >= 2
    editing_knots : ndarray, shape (K, J, 4), (x, y, z, w)
        Editing knots ``v⁰_{k,i}``: the true local rotation at the pose time ``t_k`` (§3, Figure 3b). They
        are meaningful where ``refinements != 0`` (see :attr:`has_editing_knot`); elsewhere they equal
        ``values``. Invariant kept by extraction/fitting: ``editing_knots[k] == evaluate(sm, [t_k])``.
        ``evaluate`` does not read them; editing tools that change timing must refresh them (§5.2).
    pose_probability : ndarray, shape (K,)
        Pose probability ``P(t_k)`` (§4.1), used by :func:`~stagger_nb.staggered.cull` for priorities.
    contacts : tuple of (joint_name, start_frame, stop_frame)
        Contact constraints found at extraction (Appendix B), half-open source-frame ranges.
    local_translations : ndarray, shape (F, J, 3), or None
        The source motion's animated joint translations (frame ``f`` at ``f * frame_time`` seconds; e.g. the
        Bandai clips carry the body's travel in the Hips joint's translation, not in ``root_positions``).
        They are retimed like the root translation: see ``translation_times``.
    translation_times : ndarray, shape (K,), seconds, or None
        Source time of ``local_translations`` at each root-translation knot. ``evaluate`` maps a time in
        segment ``k`` of the knots ``pose_times + root_refinements`` at normalised time ``t'`` to the source
        time ``translation_times[k] + t' (translation_times[k+1] - translation_times[k])`` (linear
        interpolation of frames, clamped), so temporal edits retime animated translations with the root
        translation. Extraction sets it to the knots themselves (identity); ``None`` reads
        ``local_translations`` at the absolute evaluation time.
    """

    skeleton: Skeleton
    frame_time: float
    pose_times: np.ndarray
    rotations: Channel
    translation: Channel
    editing_knots: np.ndarray
    pose_probability: np.ndarray
    contacts: tuple = ()
    local_translations: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)
    translation_times: np.ndarray | None = None

    def __init__(self, skeleton, frame_time, pose_times, rotations=None, translation=None, editing_knots=None,
                 pose_probability=None, contacts=(), local_translations=None, metadata=None, translation_times=None,
                 **arrays):
        unknown = set(arrays) - set(_ARRAYS)
        if unknown:
            raise TypeError(f"StaggeredMotion: unexpected keyword arguments {sorted(unknown)}")
        J = skeleton.num_joints
        ft = float(frame_time)
        if not np.isfinite(ft) or ft <= 0:
            raise ValueError(f"StaggeredMotion: frame_time must be > 0 seconds, got {frame_time!r}")
        pt = readonly(pose_times).reshape(-1)
        K = pt.size
        if K < 2:
            raise ValueError(f"StaggeredMotion: pose_times needs at least 2 poses, got {K}")
        if not np.all(np.diff(pt) > 0):
            raise ValueError("StaggeredMotion: pose_times must be strictly increasing")
        channels = {"rotations": rotations, "translation": translation}
        for which, algebra, C in (("rotations", ROTATION, J), ("translation", TRANSLATION, 1)):
            given = {f: a for name, a in arrays.items() for w, f in [_ARRAYS[name]] if w == which}
            for name, a in arrays.items():                 # the former field names, checked by those names
                w, f = _ARRAYS[name]
                if w == which and f != "displacements":
                    shape = _legacy_shape(name, K, J)
                    if np.shape(a) != shape:
                        raise ValueError(f"StaggeredMotion: {name} must have shape {shape}, got {np.shape(a)}")
            if which == "translation":
                given = {f: np.expand_dims(np.asarray(a), 1) for f, a in given.items()}   # the column axis
            ch = channels[which]
            if ch is None:
                missing = [n for n, (w, f) in _ARRAYS.items() if w == which and f not in given]
                if missing:
                    raise TypeError(f"StaggeredMotion: give {which}= or every one of {missing}")
                ch = Channel(algebra, **given)
            elif not isinstance(ch, Channel) or ch.algebra is not algebra:
                raise ValueError(f"StaggeredMotion: {which} must be a Channel of the {algebra.name} algebra")
            elif given:
                ch = ch.with_arrays(**given)
            ch.check(lambda f, w=which: _LABELS[w][f])
            if ch.values.shape[:2] != (K, C):
                raise ValueError(f"StaggeredMotion: {which} must hold {K} knots of {C} columns, got "
                                 f"{ch.values.shape[:2]}")
            channels[which] = ch
        sets = {"skeleton": skeleton, "frame_time": ft, "pose_times": pt, **channels,
                "contacts": tuple((str(n), int(a), int(b)) for n, a, b in contacts),
                "metadata": {} if metadata is None else metadata}
        for name, shape, value in (("editing_knots", (K, J, 4), editing_knots),
                                   ("pose_probability", (K,), pose_probability)):
            v = readonly(value)
            if v.shape != shape:
                raise ValueError(f"StaggeredMotion: {name} must have shape {shape}, got {v.shape}")
            sets[name] = v
        if local_translations is not None:
            local_translations = readonly(local_translations)
            if local_translations.ndim != 3 or local_translations.shape[1:] != (J, 3):
                raise ValueError(f"StaggeredMotion: local_translations must have shape (F, {J}, 3), got "
                                 f"{local_translations.shape}")
        sets["local_translations"] = local_translations
        if translation_times is not None:
            translation_times = readonly(translation_times).reshape(-1)
            if translation_times.shape != (K,) or not np.all(np.isfinite(translation_times)):
                raise ValueError(f"StaggeredMotion: translation_times must hold {K} finite seconds, got "
                                 f"{translation_times.shape}")
        sets["translation_times"] = translation_times
        for name, v in sets.items():
            object.__setattr__(self, name, v)

    def _with_fields(self, **fields) -> StaggeredMotion:
        """``dataclasses.replace(self, **fields)`` for the package's editing tools (``timing._refresh``), without
        validating and copying every array again: given channels and arrays of this motion's shapes are taken
        (a given array copied read-only), the others are this motion's own (already checked and read-only; e.g.
        a succession changes the refinements only: the displacement tables, most of the bytes, are shared).
        Fields that change the pose count go through ``dataclasses.replace``. The same values either way."""
        import dataclasses
        K = self.num_poses
        for name, v in fields.items():
            if isinstance(v, Channel):
                old = getattr(self, name)
                if v.algebra is not old.algebra or v.values.shape[:2] != old.values.shape[:2]:
                    return dataclasses.replace(self, **fields)
            elif name in ("editing_knots", "pose_probability", "pose_times"):
                if np.shape(v) != getattr(self, name).shape:
                    return dataclasses.replace(self, **fields)
            elif name != "metadata" and name != "translation_times":
                return dataclasses.replace(self, **fields)
        if "translation_times" in fields and fields["translation_times"] is not None \
                and np.shape(fields["translation_times"]) != (K,):
            return dataclasses.replace(self, **fields)
        new = object.__new__(type(self))
        for f in dataclasses.fields(self):
            v = fields.get(f.name, getattr(self, f.name))
            if f.name in fields and isinstance(v, np.ndarray | list | tuple) and f.name != "contacts":
                v = readonly(v)
            object.__setattr__(new, f.name, v)
        return new

    # -- the channels' arrays under their former names (read-only views) -------------------------------
    values = property(lambda self: self.rotations.values, doc="``rotations.values``, (K, J, 4).")
    tangents = property(lambda self: self.rotations.tangents, doc="``rotations.tangents``, (K - 1, J, 2, 4).")
    refinements = property(lambda self: self.rotations.refinements, doc="``rotations.refinements``, (K, J) s.")
    displacements = property(lambda self: self.rotations.displacements,
                             doc="``rotations.displacements``, (K - 1, J, M, 3).")
    displacement_counts = property(lambda self: self.rotations.counts, doc="``rotations.counts``, (K - 1, J).")
    root_values = property(lambda self: self.translation.values[:, 0], doc="``translation.values[:, 0]``, (K, 3).")
    root_tangents = property(lambda self: self.translation.tangents[:, 0],
                             doc="``translation.tangents[:, 0]``, (K - 1, 2, 3).")
    root_refinements = property(lambda self: self.translation.refinements[:, 0],
                                doc="``translation.refinements[:, 0]``, (K,) s.")
    root_displacements = property(lambda self: self.translation.displacements[:, 0],
                                  doc="``translation.displacements[:, 0]``, (K - 1, M, 3).")
    root_displacement_counts = property(lambda self: self.translation.counts[:, 0],
                                        doc="``translation.counts[:, 0]``, (K - 1,).")

    @property
    def channels(self) -> tuple[Channel, Channel]:
        """``(rotations, translation)``: every control variable, J + 1 columns in this order (the column
        layout of :func:`~.timing.source_knot_times`)."""
        return self.rotations, self.translation

    # -- derived, cheap -----------------------------------------------------------------------------
    @property
    def num_poses(self) -> int:
        return int(self.pose_times.size)

    @property
    def num_joints(self) -> int:
        return self.skeleton.num_joints

    @property
    def duration(self) -> float:
        return float(self.pose_times[-1] - self.pose_times[0])

    @property
    def has_editing_knot(self) -> np.ndarray:
        """Boolean (K, J): knots with a non-zero refinement, which carry an editing knot (§3)."""
        return self.refinements != 0

    def knot_times(self) -> np.ndarray:
        """Refined knot times ``t_k + r_{k,i}``, shape (K, J), seconds."""
        return knot_times(self)

    def __repr__(self) -> str:
        return (f"StaggeredMotion({self.num_poses} poses over {self.duration:.3f} s, {self.num_joints} joints, "
                f"|r| <= {np.abs(self.refinements).max():.3f} s)")


def knot_times(sm: StaggeredMotion) -> np.ndarray:
    """Refined knot times ``t_k + r_{k,i}`` of every joint rotation, shape (K, J), seconds."""
    return sm.pose_times[:, None] + sm.refinements


def default_times(sm: StaggeredMotion) -> np.ndarray:
    """The times ``evaluate(sm)`` samples: ``t_0 + n * frame_time`` up to ``t_{K-1}``, shape (N,), seconds."""
    n = int(np.floor((sm.pose_times[-1] - sm.pose_times[0]) / sm.frame_time + 1e-6)) + 1
    return sm.pose_times[0] + np.arange(n) * sm.frame_time
