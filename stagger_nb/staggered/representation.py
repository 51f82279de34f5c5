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

__all__ = ["StaggeredMotion", "knot_times", "default_times"]


@dataclass(frozen=True, eq=False)
class StaggeredMotion:
    """A motion as a sequence of staggered poses plus splines and displacement maps (§3).

    Every array is a read-only copy. Editing tools build new objects with ``dataclasses.replace``;
    ``evaluate`` recomputes everything it needs from the fields below (no hidden caches), so any
    consistent replacement is valid.

    Attributes
    ----------
    skeleton : Skeleton
        The source skeleton (joint 0 is the root; its rotation is an ordinary rotation control variable).
    frame_time : float
        Seconds between frames of the source, and of ``evaluate(sm)``'s default output.
    pose_times : ndarray, shape (K,), seconds
        Staggered pose times ``t_k``, strictly increasing. ``evaluate`` covers ``[t_0, t_{K-1}]`` by default.
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
    refinements: np.ndarray
    values: np.ndarray
    tangents: np.ndarray
    displacements: np.ndarray
    displacement_counts: np.ndarray
    root_values: np.ndarray
    root_refinements: np.ndarray
    root_tangents: np.ndarray
    root_displacements: np.ndarray
    root_displacement_counts: np.ndarray
    editing_knots: np.ndarray
    pose_probability: np.ndarray
    contacts: tuple = ()
    local_translations: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)
    translation_times: np.ndarray | None = None

    def __post_init__(self):
        J = self.skeleton.num_joints
        ft = float(self.frame_time)
        if not np.isfinite(ft) or ft <= 0:
            raise ValueError(f"StaggeredMotion: frame_time must be > 0 seconds, got {self.frame_time!r}")
        pt = readonly(self.pose_times).reshape(-1)
        K = pt.size
        if K < 2:
            raise ValueError(f"StaggeredMotion: pose_times needs at least 2 poses, got {K}")
        if not np.all(np.diff(pt) > 0):
            raise ValueError("StaggeredMotion: pose_times must be strictly increasing")
        expect = {
            "refinements": (K, J), "values": (K, J, 4), "tangents": (K - 1, J, 2, 4),
            "displacement_counts": (K - 1, J), "root_values": (K, 3), "root_refinements": (K,),
            "root_tangents": (K - 1, 2, 3), "root_displacement_counts": (K - 1,),
            "editing_knots": (K, J, 4), "pose_probability": (K,),
        }
        object.__setattr__(self, "frame_time", ft)
        object.__setattr__(self, "pose_times", pt)
        for name, shape in expect.items():
            dtype = int if name.endswith("counts") else float
            a = readonly(getattr(self, name), dtype)
            if a.shape != shape:
                raise ValueError(f"StaggeredMotion: {name} must have shape {shape}, got {a.shape}")
            object.__setattr__(self, name, a)
        d = readonly(self.displacements)
        if d.ndim != 4 or d.shape[:2] != (K - 1, J) or d.shape[3] != 3:
            raise ValueError(f"StaggeredMotion: displacements must have shape ({K - 1}, {J}, M, 3), got {d.shape}")
        rd = readonly(self.root_displacements)
        if rd.ndim != 3 or rd.shape[0] != K - 1 or rd.shape[2] != 3:
            raise ValueError(f"StaggeredMotion: root_displacements must have shape ({K - 1}, M, 3), got {rd.shape}")
        if np.any(self.displacement_counts < 2) or np.any(self.displacement_counts > d.shape[2]):
            raise ValueError("StaggeredMotion: displacement_counts must lie in [2, displacements.shape[2]]")
        if np.any(self.root_displacement_counts < 2) or np.any(self.root_displacement_counts > rd.shape[1]):
            raise ValueError("StaggeredMotion: root_displacement_counts must lie in [2, root_displacements.shape[1]]")
        object.__setattr__(self, "displacements", d)
        object.__setattr__(self, "root_displacements", rd)
        if self.local_translations is not None:
            lt = readonly(self.local_translations)
            if lt.ndim != 3 or lt.shape[1:] != (J, 3):
                raise ValueError(f"StaggeredMotion: local_translations must have shape (F, {J}, 3), got {lt.shape}")
            object.__setattr__(self, "local_translations", lt)
        if self.translation_times is not None:
            tt = readonly(self.translation_times).reshape(-1)
            if tt.shape != (K,) or not np.all(np.isfinite(tt)):
                raise ValueError(f"StaggeredMotion: translation_times must hold {K} finite seconds, got {tt.shape}")
            object.__setattr__(self, "translation_times", tt)
        object.__setattr__(self, "contacts", tuple((str(n), int(a), int(b)) for n, a, b in self.contacts))

    def _with_fields(self, **fields) -> "StaggeredMotion":
        """``dataclasses.replace(self, **fields)`` for the package's editing tools (``editing._refresh``),
        without validating and copying every array again: a given array field is copied read-only (as
        :meth:`__post_init__` does) after a shape check against this motion's (the sample axis of the
        displacement tables may differ), the others are this motion's own arrays, already checked and
        read-only (e.g. a succession changes the refinements only: the displacement tables, most of the
        bytes, are shared, not copied). Fields that change the pose count (or non-array fields) go
        through ``dataclasses.replace``. The same values as ``dataclasses.replace``."""
        import dataclasses
        for name, v in fields.items():
            old = getattr(self, name, None)
            if not isinstance(old, np.ndarray) or np.ndim(v) != old.ndim:
                return dataclasses.replace(self, **fields)
            shape = np.shape(v)
            if name in ("displacements", "root_displacements"):
                shape, want = shape[:-2] + shape[-1:], old.shape[:-2] + old.shape[-1:]
            else:
                want = old.shape
            if shape != want:
                return dataclasses.replace(self, **fields)
        new = object.__new__(type(self))
        for f in dataclasses.fields(self):
            if f.name in fields:
                v = readonly(fields[f.name], int if f.name.endswith("counts") else float)
            else:
                v = getattr(self, f.name)
            object.__setattr__(new, f.name, v)
        return new

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
