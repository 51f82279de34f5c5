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
    "IDENTITY", "quat_identity", "quat_normalize", "quat_mul", "quat_mul_components", "quat_conj", "quat_inv",
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


def quat_mul_components(a, b, out, tmp):
    """The Hamilton product ``a * b``, component by component: the package's one definition of it.

    ``a``, ``b``: sequences of the four components (x, y, z, w), arrays broadcasting to one shape ``S``
    (e.g. the rows of component-first ``(4, N)`` arrays, or the ``q[..., k]`` views of ``(..., 4)`` ones);
    ``out``: four writable arrays of shape ``S`` (views included), aliasing neither input; ``tmp``: scratch of
    shape ``S``. Every component is one multiply and three in-place adds/subtracts, no temporaries: the hot
    loops reuse their buffers (``staggered._kernels``), :func:`quat_mul` wraps it for ``(..., 4)`` arrays.
    Returns ``out``."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    for o, terms in zip(out, (((aw, bx, 1), (ax, bw, 1), (ay, bz, 1), (az, by, -1)),
                              ((aw, by, 1), (ax, bz, -1), (ay, bw, 1), (az, bx, 1)),
                              ((aw, bz, 1), (ax, by, 1), (ay, bx, -1), (az, bw, 1)),
                              ((aw, bw, 1), (ax, bx, -1), (ay, by, -1), (az, bz, -1)))):
        np.multiply(terms[0][0], terms[0][1], out=o)
        for x, y, sign in terms[1:]:
            np.multiply(x, y, out=tmp)
            if sign > 0:
                np.add(o, tmp, out=o)
            else:
                np.subtract(o, tmp, out=o)
    return out


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of ``(..., 4)`` arrays (broadcasting): :func:`quat_mul_components` on the
    last axis."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    quat_mul_components([a[..., k] for k in range(4)], [b[..., k] for k in range(4)],
                        [out[..., k] for k in range(4)], np.empty(out.shape[:-1]))
    return out


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
    w = q[..., 3:4]
    scale = np.where(s > _SMALL, half / np.where(s > _SMALL, s, 1.0), 1.0 / np.where(np.abs(w) > 0, w, 1.0))
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


_EULER_BLOCK = 16384  # rotations per block in euler_components (128 KB per temporary)


def quarter_tan(angles_deg: np.ndarray, tmp: np.ndarray) -> np.ndarray:
    """``tan(a/4)`` of angles ``a`` in degrees, in place (returns ``angles_deg``), after wrapping them to
    [-180, 180] when any lies outside (``tmp``: scratch of the same shape; an angle already inside keeps
    every bit, the sign of zero included, so no angle's result depends on its neighbours): the first step of
    :func:`_half_sin_cos`, shared with the BVH reader's C accelerator, which does the rest."""
    a = angles_deg
    if a.size and (a.max() > 180.0 or a.min() < -180.0):  # two reductions instead of four passes
        np.divide(a, 360.0, out=tmp)
        np.rint(tmp, out=tmp)
        tmp *= 360.0
        tmp += 0.0  # -0 -> +0: an angle in [-180, 180] is then unchanged to the bit, -0 included (-0 - -0 is +0),
        a -= tmp    # so whether a block was wrapped (it depends on how the block was cut) changes no bit
    a *= np.pi / 720.0  # a/4 in radians
    return np.tan(a, out=a)


def _half_sin_cos(angles_deg: np.ndarray, tmp: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``sin`` and ``cos`` of half of each angle (degrees), through one tangent: with ``t = tan(a/4)``,
    ``sin(a/2) = 2t / (1 + t^2)`` and ``cos(a/2) = (1 - t^2) / (1 + t^2)``. numpy vectorises ``tan`` but
    evaluates float64 ``sin``/``cos`` one value at a time (~15x slower here). Angles are first wrapped
    to [-180, 180] so ``|t| <= 1``; wrapping by 360 degrees negates the half-angle pair, i.e. the
    quaternion, which is the same rotation. Works in place: ``angles_deg`` is overwritten (it returns the
    sines) and ``tmp``, a float64 array of its shape (allocated when not given), receives the cosines."""
    # in place on two buffers: every fresh large temporary costs page faults, which are expensive in VMs
    if tmp is None:
        tmp = np.empty_like(angles_deg)
    t = quarter_tan(angles_deg, tmp)
    den = np.multiply(t, t, out=tmp)
    den += 1.0  # 1 + t^2
    np.divide(t, den, out=t)
    t *= 2.0  # sin(a/2) = 2t / (1 + t^2)
    np.divide(2.0, den, out=den)
    den -= 1.0  # cos(a/2) = (1 - t^2) / (1 + t^2) = 2 / (1 + t^2) - 1
    return t, den


def euler_components(angles: np.ndarray, axes: str, out: np.ndarray | None = None,
                     overwrite: bool = False) -> np.ndarray:
    """Component-major form of :func:`euler_to_quat` for three distinct axes: ``angles (3, ...)``
    degrees (first index: the angle about ``axes[k]``) -> ``(4, ...)`` quaternion components x, y, z, w.
    Every step is one contiguous numpy operation on a block of ``_EULER_BLOCK`` rotations (the
    temporaries stay in cache and are reused: fresh pages are expensive in VMs). With ``out``, an
    ``(N, 4)`` float64 array (N rotations: ``angles`` holds ``(3, N)`` values), the components are written
    into its rows block by block (no transpose of the whole table afterwards) and ``out.T`` is returned.
    ``overwrite=True`` lets it use ``angles`` (a float64 array) as scratch, sparing a copy."""
    i, j, k = ("XYZ".index(ax) for ax in axes.upper())
    eps = 1.0 if (j - i) % 3 == 1 else -1.0  # +1 when e_i x e_j = e_k
    flat = np.asarray(angles, dtype=float).reshape(3, -1)
    N = flat.shape[1]
    # with ``out``, each block is computed contiguously (ufuncs writing strided columns are ~4x slower)
    # and copied into the block's rows of ``out`` with one 2-D transpose
    q = np.empty((4, N)) if out is None else None
    plus, minus = (np.add, np.subtract) if eps > 0 else (np.subtract, np.add)
    # one workspace for every temporary of every block: the cosines (3 rows), the four products, a copy of
    # the angles unless they may be overwritten, the block of components when written to ``out``. Many
    # separate 128 KB temporaries cost ~30 % more here (each a fresh allocation and its page faults)
    B = min(N, _EULER_BLOCK)
    work = np.empty((7 + (0 if overwrite else 3) + (0 if out is None else 4), B))
    for r0 in range(0, N, _EULER_BLOCK):
        r1 = min(N, r0 + _EULER_BLOCK)
        n = r1 - r0
        if overwrite:
            ang = flat[:, r0:r1]
        else:
            ang = work[7:10, :n]
            np.copyto(ang, flat[:, r0:r1])
        qb = q[:, r0:r1] if out is None else work[-4:, :n]
        (s1, s2, s3), (c1, c2, c3) = _half_sin_cos(ang, work[0:3, :n])
        c1c2 = np.multiply(c1, c2, out=work[3, :n])
        s1s2 = np.multiply(s1, s2, out=work[4, :n])
        s1c2 = np.multiply(s1, c2, out=work[5, :n])
        c1s2 = np.multiply(c1, s2, out=work[6, :n])
        tmp = np.multiply(c1s2, s3, out=s1)  # s1 is no longer needed: its buffer holds each second term
        plus(np.multiply(s1c2, c3, out=qb[i]), tmp, out=qb[i])  # s1 c2 c3 + eps c1 s2 s3
        np.multiply(s1c2, s3, out=tmp)
        minus(np.multiply(c1s2, c3, out=qb[j]), tmp, out=qb[j])  # c1 s2 c3 - eps s1 c2 s3
        np.multiply(s1s2, c3, out=tmp)
        plus(np.multiply(c1c2, s3, out=qb[k]), tmp, out=qb[k])  # c1 c2 s3 + eps s1 s2 c3
        np.multiply(s1s2, s3, out=tmp)
        minus(np.multiply(c1c2, c3, out=qb[3]), tmp, out=qb[3])  # c1 c2 c3 - eps s1 s2 s3
        if out is not None:
            out[r0:r1] = qb.T
    return q.reshape((4,) + np.shape(angles)[1:]) if out is None else out.T


def euler_to_quat(angles_deg: np.ndarray, order: str) -> np.ndarray:
    """Intrinsic rotations about the axes of ``order`` (e.g. ``"ZXY"``: the BVH channel order, first axis
    outermost, ``R = Rz Rx Ry``; 1 to 3 axes, case ignored) by ``angles_deg (..., len(order))`` degrees -> unit
    quaternions ``(..., 4)`` (x, y, z, w): the package's one Euler -> quaternion conversion (the readers use it).
    Three distinct axes use the closed-form product of the elementary quaternions (:func:`euler_components`;
    scipy's ``from_euler`` is ~20x slower here); agrees with ``Rotation.from_euler(order.upper(), ...)``
    (checked in tests/test_io_bvh.py and tests/test_core_rotations.py)."""
    axes = order.upper()
    idx = ["XYZ".index(ax) for ax in axes]
    if len(axes) == 3 and len(set(axes)) == 3:
        ang = np.asarray(angles_deg, dtype=float)
        comps = euler_components(ang.reshape(-1, 3).T, axes)
        q = np.empty((comps.shape[1], 4))
        for c in range(4):
            q[:, c] = comps[c]
        return q.reshape(ang.shape[:-1] + (4,))
    a = np.radians(np.asarray(angles_deg, dtype=float))
    a *= 0.5
    s, c = np.sin(a), np.cos(a)
    q = np.zeros(a.shape[:-1] + (4,))
    q[..., 3] = 1.0
    for n, k in enumerate(idx):
        e = np.zeros(q.shape)
        e[..., k] = s[..., n]
        e[..., 3] = c[..., n]
        q = quat_mul(q, e)
    return q


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
