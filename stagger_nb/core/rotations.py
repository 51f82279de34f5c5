"""Vectorised unit-quaternion helpers.

Convention (the one convention of the whole package, stated here once): quaternions are
numpy arrays of shape ``(..., 4)`` in **scalar-last order (x, y, z, w)**, as in
``scipy.spatial.transform.Rotation`` and three.js.  ``q`` and ``-q`` are the same rotation.
Products compose right-to-left like matrices: ``quat_mul(a, b)`` rotates by ``b`` first, then ``a``.
A child's world rotation is ``quat_mul(parent_world, child_local)``.

Angles are radians, Euler angles at the I/O boundary are degrees.
"""
from __future__ import annotations

import numpy as np


def _rotation_class():
    """``scipy.spatial.transform.Rotation``, imported on first use: it takes ~0.4 s to import, more than
    the rest of ``import stagger_nb`` together, and only the Euler / matrix converters need it."""
    from scipy.spatial.transform import Rotation
    return Rotation

__all__ = [
    "IDENTITY", "quat_identity", "quat_normalize", "quat_mul", "quat_conj", "quat_inv",
    "quat_rotate", "quat_log", "quat_exp", "quat_to_rotvec", "rotvec_to_quat", "quat_angle",
    "quat_dot", "quat_hemisphere", "quat_continuous", "slerp", "quat_bezier",
    "euler_to_quat", "quat_to_euler", "quat_to_matrix", "matrix_to_quat", "quat_between_vectors",
]

IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])
_SMALL = 1e-12  # below this |v| the log/exp maps use their Taylor branches


def quat_identity(shape=()) -> np.ndarray:
    """Identity quaternions of shape ``shape + (4,)``."""
    q = np.zeros(tuple(np.atleast_1d(shape)) + (4,) if shape != () else (4,))
    q[..., 3] = 1.0
    return q


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(..., 4)``; a zero quaternion becomes the identity.

    Each quaternion is first divided by its largest absolute component, so the squared norm neither
    overflows (``|q| > 1e154`` would give ``inf`` and then zeros) nor underflows (``|q| < 1e-154``)."""
    q = np.asarray(q, dtype=float)
    m = np.max(np.abs(q), axis=-1, keepdims=True)
    if np.all((m > 1e-100) & (m < 1e100)):  # the usual case: no rescaling needed
        n = np.sqrt(np.einsum("...i,...i->...", q, q))[..., None]
        return q / n
    ok = m > 0
    s = q / np.where(ok, m, 1.0)
    n = np.sqrt(np.einsum("...i,...i->...", s, s))[..., None]
    return np.where(ok, s / np.where(ok, n, 1.0), IDENTITY)


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of ``(..., 4)`` arrays (broadcasting)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ], axis=-1)


def quat_conj(q: np.ndarray) -> np.ndarray:
    """Conjugate ``(-x, -y, -z, w)``; the inverse of a unit quaternion."""
    q = np.asarray(q, dtype=float)
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


quat_inv = quat_conj


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors ``v (..., 3)`` by unit quaternions ``q (..., 4)`` (broadcasting)."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    u = q[..., :3]
    w = q[..., 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Component dot product ``(...,)``."""
    return np.sum(np.asarray(a) * np.asarray(b), axis=-1)


def quat_hemisphere(q: np.ndarray) -> np.ndarray:
    """Canonical sign: ``w >= 0`` (so ``q`` and ``-q`` map to the same array)."""
    q = np.asarray(q, dtype=float)
    return np.where(q[..., 3:4] < 0, -q, q)


def quat_continuous(q: np.ndarray, axis: int = 0) -> np.ndarray:
    """Flip signs along ``axis`` (time) so consecutive quaternions have a non-negative dot product.

    Returns a new array (the input is never modified)."""
    q = np.moveaxis(np.array(q, dtype=float), axis, 0)
    if q.shape[0] > 1:
        neg = np.einsum("t...i,t...i->t...", q[1:], q[:-1]) < 0
        if neg.any():
            flips = np.cumsum(neg, axis=0) % 2 == 1
            q[1:][flips] *= -1.0
    return np.moveaxis(q, 0, axis)


def quat_log(q: np.ndarray) -> np.ndarray:
    """Quaternion logarithm ``(..., 3)``: ``axis * angle / 2`` of unit quaternions.

    Not hemisphere-canonicalised: apply :func:`quat_hemisphere` first when ``q``/``-q`` must agree.
    """
    q = np.asarray(q, dtype=float)
    v = q[..., :3]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    half = np.arctan2(s, q[..., 3:4])
    # Taylor: half/s -> 1/w for s -> 0
    scale = np.where(s > _SMALL, half / np.where(s > _SMALL, s, 1.0), 1.0 / np.where(np.abs(q[..., 3:4]) > 0, q[..., 3:4], 1.0))
    return v * scale


def quat_exp(v: np.ndarray) -> np.ndarray:
    """Inverse of :func:`quat_log`: ``v (..., 3)`` (``axis * angle / 2``) -> unit quaternion."""
    v = np.asarray(v, dtype=float)
    h = np.linalg.norm(v, axis=-1, keepdims=True)
    # sin(h)/h with Taylor branch 1 - h^2/6
    sinc = np.where(h > 1e-6, np.sin(h) / np.where(h > 1e-6, h, 1.0), 1.0 - h * h / 6.0)
    return np.concatenate([v * sinc, np.cos(h)], axis=-1)


def quat_to_rotvec(q: np.ndarray) -> np.ndarray:
    """Rotation vector ``axis * angle`` ``(..., 3)`` with angle in [0, pi]."""
    return 2.0 * quat_log(quat_hemisphere(q))


def rotvec_to_quat(r: np.ndarray) -> np.ndarray:
    """Rotation vector ``(..., 3)`` -> unit quaternion ``(..., 4)``."""
    return quat_exp(0.5 * np.asarray(r, dtype=float))


def quat_angle(a: np.ndarray, b: np.ndarray | None = None) -> np.ndarray:
    """Rotation angle in [0, pi] of ``a`` (or of ``a^-1 b`` when ``b`` is given), shape ``(...,)``."""
    if b is None:
        d = np.abs(np.asarray(a, dtype=float)[..., 3])
        v = np.linalg.norm(np.asarray(a, dtype=float)[..., :3], axis=-1)
        return 2.0 * np.arctan2(v, d)
    r = quat_mul(quat_conj(a), b)
    return 2.0 * np.arctan2(np.linalg.norm(r[..., :3], axis=-1), np.abs(r[..., 3]))


def slerp(q0: np.ndarray, q1: np.ndarray, t) -> np.ndarray:
    """Spherical linear interpolation along the shorter arc (broadcasting ``t`` over ``(...,)``).

    ``slerp(q0, q1, 0) == q0`` and ``slerp(q0, q1, 1) == ±q1`` (sign chosen so the arc is short).
    """
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    t = np.asarray(t, dtype=float)[..., None]
    d = np.sum(q0 * q1, axis=-1, keepdims=True)
    q1 = np.where(d < 0, -q1, q1)
    d = np.abs(d)
    theta = np.arccos(np.clip(d, -1.0, 1.0))
    sin_t = np.sin(theta)
    small = sin_t < 1e-9
    safe = np.where(small, 1.0, sin_t)
    w0 = np.where(small, 1.0 - t, np.sin((1.0 - t) * theta) / safe)
    w1 = np.where(small, t, np.sin(t * theta) / safe)
    out = w0 * q0 + w1 * q1
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def quat_bezier(q0, q1, q2, q3, t) -> np.ndarray:
    """Cubic quaternion Bézier by recursive slerp (de Casteljau on S^3, Shoemake 1985).

    Control quaternions ``(..., 4)``, parameter ``t`` broadcasting over ``(...,)``; interpolates
    ``q0`` at ``t = 0`` and ``q3`` at ``t = 1``. This is the ``s(q1, q2, q3, q4, t)`` of the
    staggered-poses paper, Appendix A.
    """
    a = slerp(q0, q1, t)
    b = slerp(q1, q2, t)
    c = slerp(q2, q3, t)
    d = slerp(a, b, t)
    e = slerp(b, c, t)
    return slerp(d, e, t)


def euler_to_quat(angles_deg: np.ndarray, order: str) -> np.ndarray:
    """Intrinsic Euler angles in degrees ``(..., 3)``, applied in ``order`` (e.g. ``"ZXY"``: the BVH
    channel order, first channel outermost) -> quaternions ``(..., 4)``."""
    a = np.asarray(angles_deg, dtype=float)
    shape = a.shape[:-1]
    q = _rotation_class().from_euler(order.upper(), a.reshape(-1, 3), degrees=True).as_quat()
    return q.reshape(shape + (4,))


def quat_to_euler(q: np.ndarray, order: str) -> np.ndarray:
    """Inverse of :func:`euler_to_quat`: degrees ``(..., 3)`` in the intrinsic ``order``."""
    q = np.asarray(q, dtype=float)
    shape = q.shape[:-1]
    import warnings
    with warnings.catch_warnings():  # gimbal lock is fine for I/O: any valid triple is returned
        warnings.simplefilter("ignore", UserWarning)
        e = _rotation_class().from_quat(q.reshape(-1, 4)).as_euler(order.upper(), degrees=True)
    return e.reshape(shape + (3,))


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)``."""
    q = np.asarray(q, dtype=float)
    return _rotation_class().from_quat(q.reshape(-1, 4)).as_matrix().reshape(q.shape[:-1] + (3, 3))


def matrix_to_quat(m: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` -> quaternions ``(..., 4)``."""
    m = np.asarray(m, dtype=float)
    return _rotation_class().from_matrix(m.reshape(-1, 3, 3)).as_quat().reshape(m.shape[:-2] + (4,))


def quat_between_vectors(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Shortest-arc rotation taking direction ``u (..., 3)`` to direction ``v (..., 3)``."""
    u = np.asarray(u, dtype=float)
    v = np.asarray(v, dtype=float)
    u = u / np.maximum(np.linalg.norm(u, axis=-1, keepdims=True), 1e-300)
    v = v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)
    c = np.cross(u, v)
    d = np.sum(u * v, axis=-1, keepdims=True)
    q = np.concatenate([c, 1.0 + d], axis=-1)
    # antipodal: rotate by pi about any axis orthogonal to u
    anti = (1.0 + d[..., 0]) < 1e-12
    if np.any(anti):
        alt = np.cross(u, np.array([1.0, 0.0, 0.0]))
        alt2 = np.cross(u, np.array([0.0, 1.0, 0.0]))
        alt = np.where(np.linalg.norm(alt, axis=-1, keepdims=True) < 1e-6, alt2, alt)
        q = np.where(anti[..., None], np.concatenate([alt, np.zeros_like(d)], axis=-1), q)
    return quat_normalize(q)
