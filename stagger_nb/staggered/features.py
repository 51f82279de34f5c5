"""Local evidence for staggered poses: motion-trail curvature (Coleman et al. 2008, §4.1).

For each rotating joint, two local-space motion trails per child joint: ``m1`` traces the end of the
normalised axis toward the child, ``m2`` an axis orthogonal to the limb (to catch twist). The root also gets
the trail of its world position. The modified discrete curvature ``κ̂ = n·e/|e|`` (in [0, 1]) of each trail,
maxed over a joint's trails and smoothed by iterated Laplacian smoothing, is the joint's local pose
probability ``p_i(t)``; its weight is ``w_i = Σ_j |x_i − x_j| |m_j|`` (limb length × trail arc length).
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_rotate

__all__ = ["motion_trail_curvature", "laplacian_smooth", "limb_axes", "motion_trails", "local_evidence",
           "default_smoothing_iterations"]

_STILL = 1e-9   # edges shorter than this (trail units) carry no direction: their κ̂ is 0


def motion_trail_curvature(trail: np.ndarray) -> np.ndarray:
    """Modified discrete curvature ``κ̂`` of sampled curves (§4.1).

    At vertex ``t`` with edges ``e+ = x[t+1] - x[t]`` and ``e- = x[t-1] - x[t]`` and the Frenet normal
    ``n = normalise(ê+ + ê-)`` (pointing to the concave side), ``κ̂ = n·e/|e|`` for each edge, averaged with
    the edge lengths as weights. Equals ``sin(φ/2)`` for a polygon turning by ``φ`` per vertex (so a
    uniformly sampled circle has constant κ̂), 0 on a straight line, 1 where the curve reverses.
    End vertices copy their neighbour; vertices with a zero-length edge get 0.

    Both edges give the same ``n·ê = (1 + ê+·ê-) / |ê+ + ê-| = |ê+ + ê-| / 2``, so the weighted mean is
    ``|ê+ + ê-| / 2`` whatever the edge lengths; that form is evaluated (no cancellation near straight
    lines).

    Parameters
    ----------
    trail : (F, ..., D) points along axis 0

    Returns
    -------
    (F, ...) values in [0, 1].
    """
    x = np.asarray(trail, dtype=float)
    return _curvature_components([x[..., d] for d in range(x.shape[-1])])


def _curvature_components(xs) -> np.ndarray:
    """:func:`motion_trail_curvature` of a trail given as its D coordinate arrays ``xs[d] (F, ...)`` (a
    component-first layout: every operation runs on whole contiguous arrays)."""
    F = xs[0].shape[0]
    out = np.zeros(xs[0].shape)
    if F < 3:
        return out
    lp, lm = np.zeros(out[1:-1].shape), np.zeros(out[1:-1].shape)
    ep, em = [], []
    for x in xs:
        a = x[2:] - x[1:-1]
        b = x[:-2] - x[1:-1]
        lp += a * a
        lm += b * b
        ep.append(a)
        em.append(b)
    np.sqrt(lp, out=lp)
    np.sqrt(lm, out=lm)
    ok = (lp > _STILL) & (lm > _STILL)
    ip = 1.0 / np.where(ok, lp, 1.0)
    im = 1.0 / np.where(ok, lm, 1.0)
    nn = lp                                          # reused: |ê+ + ê-|²
    nn.fill(0.0)
    for a, b in zip(ep, em):
        a *= ip
        b *= im
        a += b
        nn += a * a
    k = np.sqrt(nn, out=nn)
    k *= 0.5
    k[~ok] = 0.0                                     # still: no turning
    out[1:-1] = np.minimum(k, 1.0)
    out[0] = out[1]
    out[-1] = out[-2]
    return out


_LOOP_PASSES = 64   # up to this many passes run as the loop; more use the exact spectral form (O(F log F))


def laplacian_smooth(signal: np.ndarray, iterations: int, lam: float = 0.5) -> np.ndarray:
    """Iterated Laplacian smoothing along axis 0: ``p <- p + lam/2 (p[t-1] - 2 p[t] + p[t+1])`` (§4.1).

    Each pass is the kernel ``[lam/2, 1 - lam, lam/2]`` (variance ``lam`` frames²); ends are reflected so
    a constant signal is unchanged. ``iterations`` passes ≈ a Gaussian of std ``sqrt(iterations * lam)``.

    With the reflected ends (``p[-1] = p[1]``, ``p[F] = p[F-2]``) one pass is diagonal in the DCT-I basis
    ``cos(π k t / (F - 1))`` with eigenvalue ``1 - lam (1 - cos(π k / (F - 1)))``, so ``n`` passes are one
    DCT-I, a multiplication by the eigenvalues to the power ``n`` and the inverse: the cost no longer grows
    with ``n`` (which grows as ``1 / frame_time²``, see :func:`default_smoothing_iterations`). Up to
    ``_LOOP_PASSES`` passes run as the loop (the two agree to ~1e-15).
    """
    if not 0.0 < lam <= 1.0:
        raise ValueError(f"laplacian_smooth: lam must be in (0, 1], got {lam}")
    p = np.array(signal, dtype=float)
    n = int(iterations)
    F = p.shape[0]
    if F < 2 or n <= 0:
        return p
    if n > _LOOP_PASSES:
        from scipy.fft import dct, idct
        eig = 1.0 - lam * (1.0 - np.cos(np.pi * np.arange(F) / (F - 1)))
        gain = np.power(eig, float(n)).reshape((F,) + (1,) * (p.ndim - 1))
        return idct(dct(p, type=1, axis=0) * gain, type=1, axis=0)
    buf = np.empty_like(p)
    for _ in range(n):               # buf = (p[t-1] - 2 p[t]) + p[t+1] (reflected ends), p += lam/2 buf
        np.multiply(p, -2.0, out=buf)
        buf[1:] += p[:-1]
        buf[0] += p[1]
        buf[:-1] += p[1:]
        buf[-1] += p[-2]
        buf *= 0.5 * lam
        p += buf
    return p


def default_smoothing_iterations(frame_time: float, sigma: float = 0.02, lam: float = 0.5) -> int:
    """Passes of :func:`laplacian_smooth` giving a smoothing std of ``sigma`` seconds at this frame rate
    (so 30 Hz and 120 Hz data are smoothed alike): ``round((sigma / frame_time)² / lam)``."""
    return int(round((sigma / frame_time) ** 2 / lam))


def _orthogonal(u: np.ndarray) -> np.ndarray:
    """A unit vector orthogonal to each unit ``u (n, 3)``."""
    e = np.eye(3)[np.argmin(np.abs(u), axis=1)]
    v = np.cross(u, e)
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def limb_axes(skeleton):
    """Limb axes of every rotating joint: one entry per (joint, child or end site).

    Returns
    -------
    joint : (L,) int, the rotating joint
    child : (L,) int, the child joint (-1 for an End Site)
    u1 : (L, 3) unit axis toward the child in the joint's local frame
    u2 : (L, 3) unit axis orthogonal to ``u1``
    length : (L,) limb length (file units), ``|x_i - x_j|``
    Children at zero offset are skipped (they give no direction).
    """
    J = skeleton.num_joints
    joint, child, off = [], [], []
    for c in range(1, J):
        joint.append(int(skeleton.parents[c]))
        child.append(c)
        off.append(skeleton.offsets[c])
    for j, o in skeleton.end_sites.items():
        joint.append(int(j))
        child.append(-1)
        off.append(o)
    off = np.asarray(off, dtype=float).reshape(-1, 3)
    length = np.linalg.norm(off, axis=1)
    keep = length > 1e-9
    joint, child = np.asarray(joint, dtype=np.int64)[keep], np.asarray(child, dtype=np.int64)[keep]  # ints when empty
    off, length = off[keep], length[keep]
    u1 = off / length[:, None]
    return joint, child, u1, _orthogonal(u1), length


def motion_trails(motion: Motion):
    """Local-space motion trails ``m1, m2`` of every limb axis (see :func:`limb_axes`).

    Returns ``(axes, m1, m2)`` with ``m1, m2 : (F, L, 3)``: ``q_i(t) u`` for the joint's local rotation.
    Animated joint translations (``local_translations``) are not used: the rest offsets define the axes.
    """
    axes = limb_axes(motion.skeleton)
    joint, _, u1, u2, _ = axes
    q = motion.local_quats[:, joint]
    return axes, quat_rotate(q, u1), quat_rotate(q, u2)


def _rotated_axes(qc, u):
    """Components ``[x, y, z]`` (each shaped like ``qc[0]``) of the axis ``u (3,)`` rotated by the
    quaternions ``qc`` (4, ...) (rows x, y, z, w): ``v = u + w t + q × t`` with ``t = 2 q × u``."""
    x, y, z, w = qc
    ux, uy, uz = (float(c) for c in u)
    tx = 2.0 * (y * uz - z * uy)
    ty = 2.0 * (z * ux - x * uz)
    tz = 2.0 * (x * uy - y * ux)
    return [ux + w * tx + (y * tz - z * ty), uy + w * ty + (z * tx - x * tz), uz + w * tz + (x * ty - y * tx)]


def local_evidence(motion: Motion, smoothing_iterations: int | None = None, smoothing_lambda: float = 0.5,
                   root_translation_weight: float = 1.0):
    """Per-control-variable pose probabilities and weights (§4.1, "Local evidence measures").

    Parameters
    ----------
    motion : Motion
    smoothing_iterations : passes of Laplacian smoothing (default :func:`default_smoothing_iterations`)
    smoothing_lambda : Laplacian step in (0, 1]
    root_translation_weight : multiplier of the root-translation weight (its arc length, file units)

    Returns
    -------
    p : (F, J + 1) smoothed probabilities in [0, 1]; columns 0..J-1 the joint rotations, column J the
        root translation
    w : (J + 1,) weights: ``Σ_j |x_i − x_j| |m1_j|`` per joint (0 for joints without a limb axis) and the
        root trail's arc length times ``root_translation_weight``
    """
    F, J = motion.num_frames, motion.num_joints
    if smoothing_iterations is None:
        smoothing_iterations = default_smoothing_iterations(motion.frame_time, lam=smoothing_lambda)
    # one limb at a time on component rows: every array is one (F,) row (a few MB at 100,000 frames,
    # cache-sized where (F, L, 3) arrays are not)
    joint, _, u1, u2, length = limb_axes(motion.skeleton)
    pt = np.zeros((J + 1, F))                                                    # p transposed
    w = np.zeros(J + 1)
    qc = np.ascontiguousarray(motion.local_quats.transpose(1, 2, 0)) if joint.size else None   # (J, 4, F)
    for i, j in enumerate(joint):
        m1 = _rotated_axes(qc[j], u1[i])
        k = np.maximum(_curvature_components(m1), _curvature_components(_rotated_axes(qc[j], u2[i])))
        np.maximum(pt[j], k, out=pt[j])                                          # max over a joint's trails
        d2 = np.zeros(F - 1)
        for c in m1:
            d = np.diff(c)
            d2 += d * d
        w[j] += length[i] * np.sqrt(d2).sum()                                    # limb length x arc length
    del qc
    root = motion.root_positions
    pt[J] = motion_trail_curvature(root)
    w[J] = root_translation_weight * float(np.linalg.norm(np.diff(root, axis=0), axis=-1).sum())
    for row in pt:                                    # row by row: each (F,) row stays in cache
        row[:] = laplacian_smooth(row, smoothing_iterations, smoothing_lambda)
    return pt.T, w
