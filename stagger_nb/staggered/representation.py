"""The staggered-pose motion representation and its evaluation (Coleman et al. 2008, §3).

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
from ..core.motion import Motion
from ..core.skeleton import Skeleton
from . import _kernels as K

__all__ = ["StaggeredMotion", "evaluate", "knot_times", "default_times", "segment_coordinates",
           "rotation_spline", "translation_spline", "displacement_at", "bezier_cubic", "evaluate_reference",
           "evaluate_samples", "root_positions_at", "evaluate_arrays", "translation_source_times",
           "static_rotations"]


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


# -- spline helpers ---------------------------------------------------------------------------------

def bezier_cubic(p0, p1, p2, p3, t) -> np.ndarray:
    """Euclidean cubic Bézier (Bernstein form); points ``(..., D)``, parameter ``t (...,)``."""
    t = np.asarray(t, dtype=float)[..., None]
    u = 1.0 - t
    return (u * u * u) * p0 + (3.0 * u * u * t) * p1 + (3.0 * u * t * t) * p2 + (t * t * t) * p3


def rotation_spline(c0, c1, c2, c3, t) -> np.ndarray:
    """Quaternion Bézier ``s(c0, c1, c2, c3, t)`` by recursive slerp (Appendix A, [Sho85]).

    Same curve as :func:`stagger_nb.core.rotations.quat_bezier` (up to sign), computed component-first.
    Control quaternions ``(N, 4)`` (x, y, z, w), ``t (N,)`` in [0, 1]; returns unit ``(N, 4)``.
    """
    c = [np.ascontiguousarray(np.asarray(x, dtype=float).reshape(-1, 4).T) for x in (c0, c1, c2, c3)]
    t = np.broadcast_to(np.asarray(t, dtype=float).reshape(-1), c[0].shape[1:])
    return K.bezier(*c, t).T


def translation_spline(p0, p1, p2, p3, t) -> np.ndarray:
    """Cubic Bézier of the root translation (alias of :func:`bezier_cubic`)."""
    return bezier_cubic(p0, p1, p2, p3, t)


def displacement_at(table: np.ndarray, counts: np.ndarray, t: np.ndarray, rows: np.ndarray | None = None
                    ) -> np.ndarray:
    """Linear interpolation of displacement maps on their uniform ``t'`` grids.

    Parameters
    ----------
    table : (R, M, D) samples (rows padded past their counts)
    counts : (N,) valid samples of each sample's row (>= 2)
    t : (N,) normalised times in [0, 1]
    rows : (N,) int, optional
        Row of ``table`` of each sample; default ``arange(N)`` (``table`` holds one row per sample). Passing
        the rows gathers only the two table entries each sample reads, instead of a copy ``table[rows]`` of
        whole rows (N x M x D: megabytes on a long segment).

    Returns
    -------
    (N, D) displacement values.
    """
    u = np.clip(t, 0.0, 1.0) * (counts - 1)
    m0 = np.minimum(np.floor(u).astype(np.int64), counts - 2)
    a = (u - m0)[:, None]
    if rows is None:
        rows = np.arange(table.shape[0])
    return table[rows, m0] * (1.0 - a) + table[rows, m0 + 1] * a


# -- evaluation -------------------------------------------------------------------------------------

def knot_times(sm: StaggeredMotion) -> np.ndarray:
    """Refined knot times ``t_k + r_{k,i}`` of every joint rotation, shape (K, J), seconds."""
    return sm.pose_times[:, None] + sm.refinements


def default_times(sm: StaggeredMotion) -> np.ndarray:
    """The times ``evaluate(sm)`` samples: ``t_0 + n * frame_time`` up to ``t_{K-1}``, shape (N,), seconds."""
    n = int(np.floor((sm.pose_times[-1] - sm.pose_times[0]) / sm.frame_time + 1e-6)) + 1
    return sm.pose_times[0] + np.arange(n) * sm.frame_time


#: Knot intervals shorter than this (seconds) are treated as zero-length by :func:`segment_coordinates`:
#: far below any frame time (>= 1e-4 s), far above where 1 / length overflows.
_MIN_SEGMENT = 1e-12


def segment_coordinates(knots: np.ndarray, times: np.ndarray):
    """Segment index and normalised time ``t'`` of each time for each column of knot times.

    Parameters
    ----------
    knots : (K, C) knot times per control variable (made non-decreasing by a running maximum)
    times : (N,) seconds

    Returns
    -------
    seg : (N, C) int in [0, K - 2]
    tn : (N, C) float in [0, 1] (clamped outside the first/last knot)
    """
    knots = np.maximum.accumulate(knots, axis=0)
    K, C = knots.shape
    seg = np.empty((C, times.size), dtype=np.int64)                 # one contiguous row per column
    for c in range(C):
        np.subtract(np.searchsorted(knots[:, c], times, side="right"), 1, out=seg[c])
    np.clip(seg, 0, K - 2, out=seg)
    seg = np.ascontiguousarray(seg.T)
    # per segment (K - 1, C): 1 / length, and t' = 1 on zero-length segments; gathered by flat index
    length = knots[1:] - knots[:-1]
    # segments shorter than _MIN_SEGMENT count as zero-length (1 / 1e-320 overflows to inf, then NaN)
    inv = np.divide(1.0, length, out=np.zeros_like(length), where=length > _MIN_SEGMENT)
    flat = seg * C + np.arange(C)
    tn = times[:, None] - np.take(knots.reshape(-1), flat)
    tn *= np.take(inv.reshape(-1), flat)
    tn += np.take((length <= _MIN_SEGMENT).astype(float).reshape(-1), flat)
    return seg, np.clip(tn, 0.0, 1.0, out=tn)


def _sample_translations(lt: np.ndarray, frame_time: float, times: np.ndarray) -> np.ndarray:
    f = np.clip(times / frame_time, 0.0, lt.shape[0] - 1)
    r = np.rint(f)
    f = np.where(np.abs(f - r) < 1e-9, r, f)          # frame times read their frame bit-for-bit
    i0 = np.minimum(np.floor(f).astype(np.int64), lt.shape[0] - 1)
    i1 = np.minimum(i0 + 1, lt.shape[0] - 1)
    a = (f - i0)[:, None, None]
    return lt[i0] * (1.0 - a) + lt[i1] * a


def translation_source_times(sm: StaggeredMotion, times) -> np.ndarray:
    """Source times ``(N,)`` at which ``sm.local_translations`` are read for evaluation ``times (N,)``
    seconds: piecewise linear from the root-translation knots ``pose_times + root_refinements`` to
    ``sm.translation_times`` (identity when that is None)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    if sm.translation_times is None:
        return times
    seg, tn = segment_coordinates((sm.pose_times + sm.root_refinements)[:, None], times)
    tt = sm.translation_times
    a, b = tt[seg[:, 0]], tt[seg[:, 0] + 1]
    return a + tn[:, 0] * (b - a)


def evaluate_arrays(sm: StaggeredMotion, times: np.ndarray):
    """Local rotations ``(N, J, 4)`` and root positions ``(N, 3)`` of ``sm`` at ``times (N,)`` seconds.

    Vectorised over all (time, joint) samples; scratch memory is reused between calls (see ``_kernels``).
    """
    q, p = _evaluate_arrays(sm, times)
    return np.array(q), p


def _rotations_at(sm: StaggeredMotion, idx: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Rotations ``s(t') ⊕ d(t')`` of (segment, joint) pairs ``idx (n,)`` (segment-major ``k * J + i``) at
    normalised times ``t (n,)``, as a (4, n) view of workspace memory (valid until the next call)."""
    W = K.WORK
    J = sm.num_joints
    n = t.size
    P = sm.tangents.shape[0] * J
    # per-pair control polygons (4 controls x 4 components, P) and their three fixed first-level arcs
    ctrl = W.get("ev_ctrl", (16, P))
    ctrl[0:4] = sm.values[:-1].reshape(P, 4).T
    ctrl[4:8] = sm.tangents[:, :, 0].reshape(P, 4).T
    ctrl[8:12] = sm.tangents[:, :, 1].reshape(P, 4).T
    ctrl[12:16] = sm.values[1:].reshape(P, 4).T
    arcp = W.get("ev_arcp", (9, P))
    for j in range(3):
        K.arc_into(ctrl[4 * j:4 * j + 4], ctrl[4 * j + 4:4 * j + 8], arcp[3 * j:3 * j + 3],
                   W.get("ev_ptmp", P), W.get("ev_ptmp2", P))
    M = sm.displacements.shape[2]
    table = W.get("ev_table", (3, P * M))
    table[...] = sm.displacements.reshape(P * M, 3).T
    counts = np.ascontiguousarray(sm.displacement_counts.reshape(-1), dtype=np.int64)
    out = W.get("ev_q", (4, n))
    idx = np.ascontiguousarray(idx, dtype=np.int64)
    t = np.ascontiguousarray(t, dtype=float)
    block = 4 * K.CHUNK                          # blocks bound the scratch; larger ones make fewer numpy calls
    for s0 in range(0, n, block):
        s1 = min(n, s0 + block)
        # the C kernel where built (same bits, ~?x faster), else (or for a wide-angle displacement) numpy
        if not K.rotations_block_c(ctrl, arcp, table, counts, M, idx[s0:s1], t[s0:s1], out, s0, W):
            _rotations_block(ctrl, arcp, table, counts, M, idx[s0:s1], t[s0:s1], out[:, s0:s1])
    return out


def _rotations_block(ctrl, arcp, table, counts, M, idx, t, out):
    """One block of :func:`_rotations_at` into ``out (4, n)``."""
    W = K.WORK
    n = t.size
    c = K.take_cols_into(ctrl, idx, W.get("ev_c", (16, n)))
    arc = K.take_cols_into(arcp, idx, W.get("ev_arc", (9, n)))
    s = K.bezier_into(c[0:4], c[4:8], c[8:12], c[12:16], t, (arc[0:3], arc[3:6], arc[6:9]), tag="ev_",
                      normalize=False)   # unit to ~1e-15; Motion() renormalises what is not unit
    # displacement: linear interpolation of rotation vectors on each pair's uniform t' grid
    cnt = counts[idx]
    u = np.multiply(t, cnt - 1, out=W.get("ev_u", n))
    m0 = np.minimum(u.astype(np.int64), cnt - 2)
    a = u
    a -= m0                                                         # fractional position
    row = m0
    row += idx * M
    d0 = K.take_cols_into(table, row, W.get("ev_d0", (3, n)))
    row += 1
    d1 = K.take_cols_into(table, row, W.get("ev_d1", (3, n)))
    d1 -= d0
    d1 *= a
    d0 += d1
    d0 *= 0.5                                                       # half rotation vectors for exp
    e = K.qexp_into(d0, W.get("ev_e", (4, n)), W.get("ev_h", n), W.get("ev_tmp", n))
    return K.qmul_into(s, e, out, W.get("ev_tmp", n))


def root_positions_at(sm: StaggeredMotion, times) -> np.ndarray:
    """Root translation ``s(t') + d(t')`` at ``times (N,)`` seconds, shape (N, 3)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    rk = (sm.pose_times + sm.root_refinements)[:, None]
    rseg, rtn = segment_coordinates(rk, times)
    rseg, rtn = rseg[:, 0], rtn[:, 0]
    rt = sm.root_tangents[rseg]
    p = translation_spline(sm.root_values[rseg], rt[:, 0], rt[:, 1], sm.root_values[rseg + 1], rtn)
    return p + displacement_at(sm.root_displacements, sm.root_displacement_counts[rseg], rtn, rows=rseg)


def _segments_of_pairs(T: np.ndarray, times: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """``searchsorted(T[:, joints[n]], times[n], side="right") - 1`` for every sample n, in one search.

    ``T (K, J)`` non-decreasing down each column. Complex numbers order lexicographically in numpy's sort
    and search, so the joint-major keys ``joint + 1j * time`` of all knots form one sorted array and each
    query ``joints[n] + 1j * times[n]`` lands in its own joint's run, compared by time exactly (no
    floating offsets that could move a sample lying on a knot)."""
    Kp, J = T.shape
    keys = np.empty((J, Kp), dtype=complex)
    keys.real = np.arange(J)[:, None]
    keys.imag = T.T
    q = np.empty(times.size, dtype=complex)
    q.real = joints
    q.imag = times
    seg = np.searchsorted(keys.reshape(-1), q, side="right")
    seg -= joints * Kp + 1
    return seg


def evaluate_samples(sm: StaggeredMotion, times, joints) -> np.ndarray:
    """Local rotation of joint ``joints[n]`` at ``times[n]`` seconds for every n: ``(N, 4)`` (x, y, z, w).

    The same formula as :func:`evaluate`, for scattered (time, joint) samples (used to refit after edits)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    joints = np.asarray(joints, dtype=np.int64).reshape(-1)
    J, Kp = sm.num_joints, sm.num_poses
    T = np.maximum.accumulate(knot_times(sm), axis=0)
    seg = _segments_of_pairs(T, times, joints)
    np.clip(seg, 0, Kp - 2, out=seg)
    a, b = T[seg, joints], T[seg + 1, joints]
    tn = np.clip(np.where(b > a, (times - a) / np.where(b > a, b - a, 1.0), 1.0), 0.0, 1.0)
    return np.array(_rotations_at(sm, seg * J + joints, tn).T)


def static_rotations(sm: StaggeredMotion):
    """``(J,) bool, (J, 4)``: joints whose rotation is one quaternion throughout (every knot and control
    equal to the first knot, the displacement map zero: the spline of equal controls is that quaternion),
    and each joint's first knot ``values[0]``."""
    c = sm.values[0]
    static = (np.all(sm.values == c, axis=(0, 2))
              & np.all(sm.tangents == c[None, :, None, :], axis=(0, 2, 3)))
    if static.any():
        static[static] = ~np.any(sm.displacements[:, static], axis=(0, 2, 3))
    return static, c


def _evaluate_arrays(sm: StaggeredMotion, times: np.ndarray):
    """:func:`evaluate_arrays` returning, for ``q``, a view of workspace memory (valid until the next call)
    or a new array. Static joints (:func:`static_rotations`, e.g. 6 of CMU's 31) are their quaternion
    exactly, without evaluating the spline (which returns it to ~1e-16)."""
    times = np.asarray(times, dtype=float).reshape(-1)
    J, N = sm.num_joints, times.size
    static, c = static_rotations(sm)
    if not static.any():
        seg, tn = segment_coordinates(knot_times(sm), times)          # (N, J)
        idx = seg.reshape(-1) * J + np.tile(np.arange(J), N)         # pair index (segment-major)
        return _rotations_at(sm, idx, tn.reshape(-1)).T.reshape(N, J, 4), root_positions_at(sm, times)
    mov = np.flatnonzero(~static)
    q = np.empty((N, J, 4))
    q[:, static] = c[static]
    if mov.size:
        seg, tn = segment_coordinates(knot_times(sm)[:, mov], times)  # (N, moving joints)
        idx = seg.reshape(-1) * J + np.tile(mov, N)
        q[:, mov] = _rotations_at(sm, idx, tn.reshape(-1)).T.reshape(N, mov.size, 4)
    return q, root_positions_at(sm, times)


def evaluate_reference(sm: StaggeredMotion, times) -> np.ndarray:
    """:func:`evaluate_arrays`' rotations computed in the most straightforward manner (per joint: segment by
    searchsorted, :func:`~stagger_nb.core.rotations.quat_bezier`, linear rotation-vector displacement,
    ``quat_mul``). Slow; a reference for tests and benchmarks. Returns ``(N, J, 4)``."""
    from ..core.rotations import quat_bezier, quat_mul, rotvec_to_quat
    times = np.asarray(times, dtype=float).reshape(-1)
    J = sm.num_joints
    T = np.maximum.accumulate(knot_times(sm), axis=0)
    out = np.empty((times.size, J, 4))
    for i in range(J):
        seg = np.clip(np.searchsorted(T[:, i], times, side="right") - 1, 0, sm.num_poses - 2)
        a, b = T[seg, i], T[seg + 1, i]
        tn = np.clip((times - a) / np.where(b > a, b - a, 1.0), 0, 1)
        s = quat_bezier(sm.values[seg, i], sm.tangents[seg, i, 0], sm.tangents[seg, i, 1], sm.values[seg + 1, i], tn)
        n = sm.displacement_counts[seg, i]
        u = tn * (n - 1)
        m0 = np.minimum(np.floor(u).astype(int), n - 2)
        f = (u - m0)[:, None]
        d = sm.displacements[seg, i, m0] * (1 - f) + sm.displacements[seg, i, m0 + 1] * f
        out[:, i] = quat_mul(s, rotvec_to_quat(d))
    return out


_MAX_SAMPLES = 20_000_000    # (time, joint) samples evaluate() accepts (~155 B each while evaluating: ~3 GB)


def _check_size(n: int, sm: StaggeredMotion):
    if n * sm.num_joints > _MAX_SAMPLES:
        raise ValueError(f"evaluate: {n} times x {sm.num_joints} joints exceed {_MAX_SAMPLES} samples (~3 GB "
                         f"while evaluating; frame_time {sm.frame_time!r} s): evaluate slices of the time range "
                         f"(times=...) one at a time")


def evaluate(sm: StaggeredMotion, times=None) -> Motion:
    """Evaluate a staggered-pose motion: ``v_i(t) = s_i(t') ⊕ d_i(t')`` for every joint (§3).

    Parameters
    ----------
    sm : StaggeredMotion
    times : array_like, shape (N,), seconds, optional
        Absolute times to sample. Default :func:`default_times` (``t_0, t_0 + frame_time, ... <= t_{K-1}``),
        which for an unedited extraction are exactly the source frames.

    Returns
    -------
    Motion with N frames, ``frame_time = sm.frame_time`` (or the spacing of uniform ``times``); the source's
    ``local_translations`` (if any) are sampled at :func:`translation_source_times` (retimed with the root
    translation; the same absolute times for an unedited extraction).
    """
    if not isinstance(sm, StaggeredMotion):
        raise ValueError(f"evaluate: sm must be a StaggeredMotion, got {type(sm).__name__}")
    if times is None:
        _check_size(int(np.floor(sm.duration / sm.frame_time + 1e-6)) + 1, sm)
        times = default_times(sm)
        ft = sm.frame_time
    else:
        times = np.asarray(times, dtype=float).reshape(-1)
        _check_size(times.size, sm)
        if times.size == 0 or not np.all(np.isfinite(times)):
            raise ValueError("evaluate: times must be a non-empty array of finite seconds")
        dt = np.diff(times)
        ft = float(dt[0]) if dt.size and dt[0] > 0 and np.allclose(dt, dt[0]) else sm.frame_time
    q, p = _evaluate_arrays(sm, times)
    lt = None
    if sm.local_translations is not None:
        lt = _sample_translations(sm.local_translations, sm.frame_time, translation_source_times(sm, times))
    # arrays computed here from a valid representation: the trusted constructor (no re-validation); q may
    # be workspace memory, so the Motion gets its own copy
    return Motion._trusted(sm.skeleton, ft, p, np.array(q), lt)
