"""The vectorised array steps of :mod:`stagger_nb.quality` on component-major arrays (positions ``(3, J, F)``,
quaternions ``(4, J, F)``): heights, forward kinematics of a subset of joints, angles, slerp, rotation
vectors, the detail's band-pass, contact segments and their travel."""
from __future__ import annotations

import numpy as np

from ..core.kinematics import _fk_component_major, _to_component_major
from ..core.motion import Motion
from ..core.rotations import _SMALL, quat_angle, quat_mul_components
from .constants import DETAIL_FINE, DETAIL_RATE, DETAIL_SIGMA


def _height_rows(P: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Heights along the coordinate axis ``up`` (±X/±Y/±Z) of component-major positions ``P (3, ...)``."""
    a = int(np.argmax(np.abs(up)))
    return P[a] if up[a] > 0 else -P[a]


def _fk_cm(motion: Motion, joints=None) -> tuple[np.ndarray, np.ndarray | None]:
    """``(P, Q)``: world positions ``P (3, J, F)`` (component-major ``forward_kinematics(motion)[0]``, the
    same products: equal bit for bit) and the local rotations ``Q (4, J, F)``; with ``joints`` only those
    and their ancestors are computed (``P (3, n, F)`` for ``sub``, see :func:`_fk_rows`; Q is None)."""
    sk = motion.skeleton
    if joints is None:
        Q = _to_component_major(motion.local_quats)
        T = (sk.offsets.T[:, :, None] if motion.local_translations is None
             else _to_component_major(motion.local_translations))
        return _fk_component_major(Q, T, motion.root_positions.T, sk.parents)[1], Q
    from ..staggered.contacts import chain_subset
    sub, sub_par, _ = chain_subset(sk.parents, joints)
    Q = np.empty((4, sub.size, motion.num_frames))
    for c in range(4):
        Q[c] = motion.local_quats[:, sub, c].T
    if motion.local_translations is None:
        T = sk.offsets[sub].T[:, :, None]
    else:
        T = np.empty((3, sub.size, motion.num_frames))
        for c in range(3):
            T[c] = motion.local_translations[:, sub, c].T
    return _fk_component_major(Q, T, np.ascontiguousarray(motion.root_positions.T), sub_par)[1], None


def _fk_rows(motion: Motion, joints) -> np.ndarray:
    """World positions ``(3, J, F)`` of ``joints`` (their chains' FK; the other rows NaN)."""
    from ..staggered.contacts import chain_subset
    sub, _, _ = chain_subset(motion.skeleton.parents, joints)
    P = np.full((3, motion.num_joints, motion.num_frames), np.nan)
    P[:, sub] = _fk_cm(motion, joints)[0]
    return P


def _dot(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Component dot product of component-first quaternions ``(4, ...)`` -> ``(...)``."""
    d = A[0] * B[0]
    for c in (1, 2, 3):
        d += A[c] * B[c]
    return d


def _largest_angles(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Largest rotation angle (degrees) between ``A`` and ``B`` (4, J, n) over ``n``, per joint ``(J,)``.

    The angle grows with the chord ``|a - s b|`` (``s`` the sign of ``a·b``: the shorter arc), which has no
    cancellation for small angles (``1 - |a·b|`` has, and unit quaternions are unit to ~1e-12 only): the
    frame of the longest chord is found for all joints at once, and
    :func:`~stagger_nb.core.rotations.quat_angle` evaluated there only (one pair per joint)."""
    J, n = A.shape[1], A.shape[2]
    if n == 0:
        return np.zeros(J)
    sign = np.copysign(1.0, _dot(A, B))
    chord = np.zeros(A.shape[1:])
    for c in range(4):
        d = A[c] - sign * B[c]
        d *= d
        chord += d
    k = np.argmax(chord, axis=1)
    cols = np.arange(J)
    a, b = A[:, cols, k].T, B[:, cols, k].T                                   # (J, 4)
    out = np.degrees(quat_angle(a, b))
    out[np.all(a == b, axis=1)] = 0.0
    return out


def _step_angles(Q: np.ndarray) -> np.ndarray:
    """Largest frame-to-frame rotation angle (degrees) of each joint of ``Q (4, J, F)`` -> ``(J,)``."""
    if Q.shape[2] < 2:
        return np.zeros(Q.shape[1])
    return _largest_angles(Q[:, :, :-1], Q[:, :, 1:])


def _norms2(D: np.ndarray) -> np.ndarray:
    """Squared lengths of component-first vectors ``D (3, ...)``."""
    return D[0] * D[0] + D[1] * D[1] + D[2] * D[2]


def _step_lengths(P: np.ndarray) -> np.ndarray:
    """Largest frame-to-frame displacement of each joint of ``P (3, J, F)`` -> ``(J,)`` (file units)."""
    if P.shape[2] < 2:
        return np.zeros(P.shape[1])
    return np.sqrt(_norms2(np.diff(P, axis=2)).max(axis=1))


def _relative_rotvecs(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Rotation vectors ``rotvec(a⁻¹ b)`` (angle in [0, π], as :func:`~stagger_nb.core.rotations.quat_to_rotvec`:
    ``2 atan2(|v|, |w|) v / |v|`` on the hemisphere ``w >= 0``, ``2 v / w`` below ``|v| = 1e-12``) of
    component-first quaternions ``A, B (4, ...)`` -> ``(3, ...)``."""
    R = np.empty(np.broadcast_shapes(A.shape, B.shape))
    tmp = np.empty(R.shape[1:])
    quat_mul_components((-A[0], -A[1], -A[2], A[3]), B, R, tmp)
    V, w = R[:3], R[3]
    s = np.sqrt(_norms2(V))
    aw = np.abs(w)
    big = s > _SMALL
    scale = np.arctan2(s, aw, out=tmp)
    scale /= np.where(big, s, 1.0)
    if not big.all():
        scale[~big] = 1.0 / aw[~big]
    scale *= 2.0
    np.copysign(scale, w, out=scale)                     # -q for w < 0: the same rotation, the short way
    V *= scale
    return V


def _slerp_cm(A: np.ndarray, B: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation of component-first quaternions ``A, B (4, ...)`` at ``t (...)`` along the
    shorter arc, as :func:`~stagger_nb.core.rotations.slerp`: ``sin((1 - t) θ) a + sin(t θ) b`` normalised (the
    common ``1 / sin θ`` cancels in the normalisation; below ``sin θ = 1e-9`` the weights ``1 - t`` and ``t``)."""
    d = _dot(A, B)
    sign = np.copysign(1.0, d)
    np.abs(d, out=d)
    theta = np.arccos(np.minimum(d, 1.0, out=d), out=d)
    small = theta < 1e-9
    w0 = np.sin((1.0 - t) * theta)
    w1 = np.sin(t * theta)
    if small.any():
        w0[small] = (1.0 - t)[small] if np.ndim(t) else 1.0 - t
        w1[small] = t[small] if np.ndim(t) else t
    w1 *= sign
    out = A * w0
    out += B * w1
    out /= np.sqrt(_dot(out, out))
    return out


def _fractional(f: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(i0, i1, w)`` of fractional frame indices ``f`` into ``count`` frames: ``f`` clamped, ``w = 0``
    within 1e-9 of a frame (a time on a frame reads that frame exactly)."""
    f = np.clip(f, 0.0, count - 1)
    i0 = np.minimum(np.floor(f + 1e-9).astype(np.int64), count - 1)
    w = f - i0
    w[np.abs(w) < 1e-9] = 0.0
    return i0, np.minimum(i0 + 1, count - 1), w


def _read_positions(P: np.ndarray, joints: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """``P (3, J, F)`` at fractional ``frames (n,)`` of ``joints (n,)`` (linear) -> ``(3, n)``."""
    i0, i1, w = _fractional(frames, P.shape[2])
    out = P[:, joints, i0]
    moving = w > 0
    if moving.any():
        wm = w[moving]
        out[:, moving] = P[:, joints[moving], i0[moving]] * (1 - wm) + P[:, joints[moving], i1[moving]] * wm
    return out


def _band_pass_energy(V: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Mean over samples of the squared band-passed angular velocity ``V (3, J, n)`` -> ``(J,)`` (rad²/s²):
    ``kernel`` is the difference of the two Gaussian low-passes (:func:`_detail_kernel`), one correlation along
    time (the nearest sample repeated past each end, as ``gaussian_filter1d(mode="nearest")``)."""
    from scipy.ndimage import correlate1d
    C, J, n = V.shape
    if n < 2:
        return np.zeros(J)
    hp = correlate1d(V.reshape(C * J, n), kernel, axis=1, mode="nearest")
    hp *= hp
    return hp.reshape(C, J, n).sum(axis=0).mean(axis=1)


def _detail_kernel(frame_time: float) -> np.ndarray:
    """Correlation weights of ``gaussian_filter1d(σ = DETAIL_FINE) - gaussian_filter1d(σ = DETAIL_SIGMA)``
    on samples ``frame_time`` apart (scipy's kernels: truncated at 4 σ, normalised), one kernel."""
    from scipy.ndimage._filters import _gaussian_kernel1d
    sf, sc = DETAIL_FINE / frame_time, DETAIL_SIGMA / frame_time
    rf, rc = int(4.0 * sf + 0.5), int(4.0 * sc + 0.5)
    k = -_gaussian_kernel1d(sc, 0, rc)[::-1]
    k[rc - rf: rc + rf + 1] += _gaussian_kernel1d(sf, 0, rf)[::-1]
    return k


def _segments(lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(starts, owner)`` of consecutive segments of ``lengths`` (all > 0) laid end to end: the start of
    each segment and, per element, its segment's start."""
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    return starts, np.repeat(starts, lengths)


def _travels(pe: np.ndarray, ps: np.ndarray, starts: np.ndarray, owner: np.ndarray):
    """Per segment: ``(travel against the source, raw travel)`` of positions ``pe (3, n)`` against
    ``ps (3, n)``: ``max |(p(n) - p(a)) - (p_src(n) - p_src(a))|`` and ``max |p(n) - p(a)|`` (``a`` the
    segment's first element)."""
    de = pe - pe[:, owner]
    rel = np.sqrt(np.maximum.reduceat(_norms2(de - (ps - ps[:, owner])), starts))
    raw = np.sqrt(np.maximum.reduceat(_norms2(de), starts))
    return rel, raw


def _detail_step(frame_time: float) -> int:
    """Source frames between two samples of the detail grid: the grid is the source's frames, every k-th
    one above DETAIL_RATE (a 120 Hz clip is read at 60 Hz)."""
    return max(1, int(1.0 / (DETAIL_RATE * frame_time) + 1e-9))
