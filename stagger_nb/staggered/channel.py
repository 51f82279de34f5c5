"""One kind of control variable of a staggered motion, and its algebra (Coleman et al. 2008, §3).

Rotations and the root translation are the same thing twice: per column ``c`` (a joint's rotation, or the root
translation) knot values ``v[k, c]`` at the refined times ``t_k + r[k, c]``, two inner Bézier controls per
segment, and a displacement map per segment sampled on its normalised time ``t'``. Between two knots

    v_c(t) = s_c(t') ⊕ d_c(t')

A :class:`Channel` holds those arrays for ``C`` columns; an :class:`Algebra` says what ``⊕``/``⊖`` and the spline
are. Two instances: :data:`ROTATION` (unit quaternions (x, y, z, w); ``a ⊕ d = a exp(d / 2)`` with ``d`` a rotation
vector applied in the joint's local frame, ``v ⊖ s = 2 log(s⁻¹ v)`` unwrapped along each grid; the spline a
quaternion Bézier by recursive slerp, Appendix A) and :data:`TRANSLATION` (points; ``+``/``-``; a cubic Bézier).
Everything written over channels (evaluation, re-measuring the maps, pose offsets, insert/delete) then exists
once: a :class:`~.representation.StaggeredMotion` holds ``rotations`` (J columns) and ``translation`` (1 column).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..core._arrays import readonly
from ..core.rotations import quat_exp, quat_hemisphere, quat_log, quat_mul, slerp
from . import _kernels as K

__all__ = ["Algebra", "ROTATION", "TRANSLATION", "Channel", "bezier_cubic"]

_TINY_ANGLE = 1e-15  # an offset with |log δ| below this (radians/2) is the identity: nothing to re-measure


def bezier_cubic(p0, p1, p2, p3, t) -> np.ndarray:
    """Euclidean cubic Bézier (Bernstein form); points ``(..., D)``, parameter ``t (...,)``."""
    t = np.asarray(t, dtype=float)[..., None]
    u = 1.0 - t
    return (u * u * u) * p0 + (3.0 * u * u * t) * p1 + (3.0 * u * t * t) * p2 + (t * t * t) * p3


class Algebra:
    """``⊕``, ``⊖``, the spline and its split for one kind of control variable (the two instances below)."""

    name = ""
    dim = 0                       # components of a value: 4 (x, y, z, w) or 3

    def spline(self, c0, c1, c2, c3, t) -> np.ndarray:
        """The segment spline at ``t (N,)`` for per-sample controls ``(N, D)``."""
        raise NotImplementedError

    def spline_pairs(self, c0, c1, c2, c3, pair, t, out=None) -> np.ndarray:
        """The spline of per-pair controls ``(P, D)`` at the samples ``t (N,)`` of pairs ``pair (N,)``
        (``out``: a ``(D, N)`` buffer for the result, returned transposed, where the algebra can use one)."""
        raise NotImplementedError

    def compose(self, s, d) -> np.ndarray:
        """``s ⊕ d``: values ``(N, D)`` displaced by displacement samples ``d (N, 3)``."""
        raise NotImplementedError

    def difference(self, s, v, pair) -> np.ndarray:
        """``d = v ⊖ s``: displacement samples ``(N, 3)`` taking ``s`` to ``v`` (``(N, D)`` each), along pairs."""
        raise NotImplementedError

    def offset(self, v, delta) -> np.ndarray:
        """``v ⊕ δ`` for a knot offset ``δ`` in the value's own form (a quaternion, or a translation)."""
        raise NotImplementedError

    def generator(self, delta) -> np.ndarray:
        """``(..., 3)`` generator of knot offsets ``δ``: ``w δ`` (a partial offset) is ``exp(w g)`` / ``w g``."""
        raise NotImplementedError

    def moves(self, g) -> np.ndarray:
        """Offsets (generators ``g``) that change a value."""
        raise NotImplementedError

    def step_rows(self, x, g, out) -> np.ndarray:
        """``x ⊕ exp(g)`` component-first: ``x (D, N)``, generators ``g (3, N)`` (overwritten), into
        ``out (D, N)`` (workspace rows)."""
        raise NotImplementedError

    def split(self, c0, c1, c2, c3, u):
        """de Casteljau split of the splines ``(c0..c3)`` ``(C, D)`` at ``u (C,)``: ``((a, d), (e, c))``, the
        inner controls of the left and right parts (the split point is the curve's value there)."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<{self.name} algebra>"

    def __reduce__(self):
        return self.name.upper()      # pickled and copied as the module's instance: ``algebra is ROTATION`` holds


class _Rotation(Algebra):
    name, dim = "rotation", 4

    def spline(self, c0, c1, c2, c3, t):
        c = [np.ascontiguousarray(np.asarray(x, dtype=float).reshape(-1, 4).T) for x in (c0, c1, c2, c3)]
        t = np.broadcast_to(np.asarray(t, dtype=float).reshape(-1), c[0].shape[1:])
        return K.bezier(*c, t).T

    def spline_pairs(self, c0, c1, c2, c3, pair, t, out=None):
        # the control arcs once per pair (not per sample: the same values)
        ctrl = [np.ascontiguousarray(x.T) for x in (c0, c1, c2, c3)]
        t = np.ascontiguousarray(t, dtype=float)
        return K.spline_into(*ctrl, pair, t, np.empty((4, t.size)) if out is None else out).T

    def compose(self, s, d):
        return quat_mul(s, quat_exp(0.5 * d))

    def difference(self, s, v, pair):
        from .displacement import displacement_rotvecs
        return displacement_rotvecs(s, v, pair)

    def offset(self, v, delta):
        return quat_mul(v, delta)

    def generator(self, delta):
        return quat_log(quat_hemisphere(delta))          # half-angle axis: exp(w g) is w times the rotation

    def moves(self, g):
        return np.linalg.norm(g, axis=-1) > _TINY_ANGLE

    def step_rows(self, x, g, out):
        W, N = K.WORK, g.shape[1]
        e = K.qexp_into(g, W.get("ex_e", (4, N)), W.get("ex_h", N), W.get("ex_tmp", N))
        return K.qmul_into(x, e, out, W.get("ex_tmp", N))

    def split(self, c0, c1, c2, c3, u):
        a, b, c = slerp(c0, c1, u), slerp(c1, c2, u), slerp(c2, c3, u)
        d, e = slerp(a, b, u), slerp(b, c, u)
        return (a, d), (e, c)


class _Translation(Algebra):
    name, dim = "translation", 3

    def spline(self, c0, c1, c2, c3, t):
        return bezier_cubic(c0, c1, c2, c3, t)

    def spline_pairs(self, c0, c1, c2, c3, pair, t, out=None):
        return bezier_cubic(c0[pair], c1[pair], c2[pair], c3[pair], t)

    def compose(self, s, d):
        return s + d

    def difference(self, s, v, pair):
        return v - s

    def offset(self, v, delta):
        return v + delta

    def generator(self, delta):
        return np.asarray(delta, dtype=float)

    def moves(self, g):
        return np.any(g != 0, axis=-1)

    def step_rows(self, x, g, out):
        return np.add(x, g, out=out)

    def split(self, c0, c1, c2, c3, u):
        u = np.asarray(u, dtype=float)[..., None]
        a, b, c = c0 + u * (c1 - c0), c1 + u * (c2 - c1), c2 + u * (c3 - c2)
        d, e = a + u * (b - a), b + u * (c - b)
        return (a, d), (e, c)


ROTATION = _Rotation()
TRANSLATION = _Translation()

_FIELDS = ("values", "tangents", "refinements", "displacements", "counts")


@dataclass(frozen=True, eq=False)
class Channel:
    """The knots, tangents, refinements and displacement maps of ``C`` control variables of one algebra.

    Attributes
    ----------
    algebra : Algebra
        :data:`ROTATION` or :data:`TRANSLATION`.
    values : ndarray, shape (K, C, D)
        Extreme-value knots ``v[k, c]`` (D = ``algebra.dim``) at the knot times ``t_k + refinements[k, c]``.
    tangents : ndarray, shape (K - 1, C, 2, D)
        Inner controls of each segment's spline (quaternion Bézier: unit quaternions; cubic Bézier: points).
    refinements : ndarray, shape (K, C), seconds
        Timing refinements ``r[k, c]``.
    displacements : ndarray, shape (K - 1, C, M, 3)
        Displacement map of each segment on the uniform grid ``t'_m = m / (n - 1)``, ``n = counts[k, c]``
        (rotation vectors, radians, unwrapped along each grid; or translations, file units); zero padding past n.
    counts : ndarray, shape (K - 1, C), int >= 2
        Valid samples of each displacement map.

    Every array is a read-only copy; :meth:`with_arrays` builds a changed channel sharing the others.
    """

    algebra: Algebra
    values: np.ndarray
    tangents: np.ndarray
    refinements: np.ndarray
    displacements: np.ndarray
    counts: np.ndarray

    def __post_init__(self):
        for name in _FIELDS:
            object.__setattr__(self, name, readonly(getattr(self, name), int if name == "counts" else float))
        self.check()

    def check(self, label=None) -> None:
        """Raise ValueError when the arrays' shapes disagree (``label(field)`` names a field in the message)."""
        label = label or (lambda f: f)
        a = self.algebra
        if a not in (ROTATION, TRANSLATION):
            raise ValueError(f"Channel: algebra must be ROTATION or TRANSLATION, got {a!r}")
        v = self.values
        if v.ndim != 3 or v.shape[2] != a.dim or v.shape[0] < 2:
            raise ValueError(f"StaggeredMotion: {label('values')} must have shape (K >= 2, C, {a.dim}), got {v.shape}")
        Kp, C = v.shape[:2]
        expect = {"tangents": (Kp - 1, C, 2, a.dim), "refinements": (Kp, C), "counts": (Kp - 1, C)}
        for name, shape in expect.items():
            if getattr(self, name).shape != shape:
                raise ValueError(f"StaggeredMotion: {label(name)} must have shape {shape}, got "
                                 f"{getattr(self, name).shape}")
        d = self.displacements
        if d.ndim != 4 or d.shape[:2] != (Kp - 1, C) or d.shape[3] != 3:
            raise ValueError(f"StaggeredMotion: {label('displacements')} must have shape ({Kp - 1}, {C}, M, 3), "
                             f"got {d.shape}")
        if np.any(self.counts < 2) or np.any(self.counts > d.shape[2]):
            raise ValueError(f"StaggeredMotion: {label('counts')} must lie in [2, {label('displacements')}"
                             f".shape[-2]]")

    @property
    def num_columns(self) -> int:
        return int(self.values.shape[1])

    def knots(self, pose_times) -> np.ndarray:
        """Refined knot times ``t_k + r[k, c]``, shape (K, C), seconds."""
        return np.asarray(pose_times)[:, None] + self.refinements

    def with_arrays(self, **arrays) -> Channel:
        """This channel with some arrays replaced: each given one copied read-only after a shape check (the
        sample axis of the displacement table may change), the others shared (already checked, read-only)."""
        for name, a in arrays.items():
            old = getattr(self, name)
            shape, want = np.shape(a), old.shape
            if name == "displacements":
                shape, want = shape[:2] + shape[3:], want[:2] + want[3:]
            if shape != want:
                return dataclasses.replace(self, **arrays)
        new = object.__new__(Channel)
        object.__setattr__(new, "algebra", self.algebra)
        for name in _FIELDS:
            v = arrays[name] if name in arrays else getattr(self, name)
            object.__setattr__(new, name, readonly(v, int if name == "counts" else float) if name in arrays else v)
        return new

    def static_columns(self) -> tuple[np.ndarray, np.ndarray]:
        """``(C,) bool, (C, D)``: columns that are one value throughout (every knot and control equal to the
        first knot, the displacement map zero: the spline of equal controls is that value), and each column's
        first knot ``values[0]``."""
        c = self.values[0]
        static = (np.all(self.values == c, axis=(0, 2))
                  & np.all(self.tangents == c[None, :, None, :], axis=(0, 2, 3)))
        if static.any():
            static[static] = ~np.any(self.displacements[:, static], axis=(0, 2, 3))
        return static, c
