"""Per-segment (C0) quaternion Bézier fits (Coleman et al. 2008, Appendix A), all (segment, joint) pairs at once.

The paper minimises ``w_f f_f + w_c f_c`` with Nelder–Mead per joint and segment. :func:`fit_rotation_tangents`
starts from a closed form (a Euclidean cubic Bézier fitted by linear least squares to the samples' logarithms
relative to the first knot) and takes a few damped Gauss–Newton (Levenberg–Marquardt) steps on the rotation
vectors of the residuals, with the controls parameterised on the manifold (``q̂ <- q̂ exp(δ)``) so they stay
unit quaternions without a penalty term. A straight port of Appendix A (Nelder–Mead) is the tests' reference
(``tests/references.py``). The C1 fit is in :mod:`.rotation_fit_c1`.
"""
from __future__ import annotations

import numpy as np

from ..core.rotations import quat_conj, quat_exp, quat_log, quat_mul, quat_normalize
from . import _kernels as K
from .evaluation import rotation_spline
from .translation_fit import _fit_inner_controls

__all__ = ["fit_rotation_tangents", "rotation_residuals"]


_FD_STEP = 1e-6     # finite-difference step of the Gauss-Newton Jacobian (rotation-vector units, radians)


_START_BATCH = 1 << 13   # ... and up to this many samples x 7 try every shrink factor at once (measured: faster


                         # than the lazy loop below ~1,200 fit samples, slower above: 2.3 vs 3.6 ms at 540,
                         # 8.4 vs 5.9 ms at 2,970 on cull refits of CMU 01_01)
_SHRINK = (1.0, 0.85, 0.7, 0.55, 0.4, 0.2, 0.0)   # start polygons tried: Euclidean fit shrunk toward its chord


def _rotvec_between(a, b):
    """Rotation vector (radians) of ``a^-1 b``, shortest way; ``(N, 4)`` inputs, ``(N, 3)`` output."""
    return K.rotvec_between(np.ascontiguousarray(np.asarray(a, dtype=float).T),
                            np.ascontiguousarray(np.asarray(b, dtype=float).T)).T


def rotation_residuals(c0, c1, c2, c3, tn, targets):
    """Rotation vectors ``(N, 3)`` from each target to the spline, ``log(q^-1 s(t'))``; |r| is the angle."""
    return _rotvec_between(targets, rotation_spline(c0, c1, c2, c3, tn))


def fit_rotation_tangents(tn, targets, pair, v0, v3, num_pairs, iterations: int = 3):
    """Inner control quaternions of quaternion Béziers fitted to samples on SO(3) (Appendix A, vectorised).

    Parameters
    ----------
    tn : (N,) normalised sample times in [0, 1]
    targets : (N, 4) (x, y, z, w) sampled rotations, sign-continuous within each pair
    pair : (N,) pair index of each sample, samples of a pair contiguous and in order of pairs; a pair
        without samples gets the chord (the linear rotation spline)
    v0, v3 : (P, 4) end knots of each pair
    iterations : Levenberg–Marquardt steps after the closed-form start (0: the start only)

    Returns
    -------
    tangents : (P, 2, 4) unit quaternions ``(q̂2, q̂3)``
    cost : (P,) sum of squared residual angles (rad²) of each pair
    """
    P = num_pairs
    T4 = np.ascontiguousarray(targets.T)
    V0, V3 = np.ascontiguousarray(v0.T), np.ascontiguousarray(v3.T)
    tn = np.ascontiguousarray(tn, dtype=float)

    def residual(a1, a2):                      # (3, N) rotation vectors target -> spline
        return K.spline_residual_into(T4, V0, a1, a2, V3, pair, tn, np.empty((3, tn.size)))

    def pair_cost(r):
        return np.bincount(pair, r[0] * r[0] + r[1] * r[1] + r[2] * r[2], P)

    # Closed-form start: a Euclidean Bézier on x = log(v0^-1 q) (exact for a one-axis rotation at any rate;
    # targets are sign-continuous so the log stays continuous past pi). The recursive slerp takes each
    # control-polygon leg the short way, so a leg of the Euclidean polygon longer than a half turn is
    # followed the other way round: the least-squares polygon of a segment that holds a full flexion and
    # extension (a knee over half a running stride) has such a leg. So the start is the best, by the true
    # cost, of the Euclidean polygon shrunk toward its chord by the factors ``_SHRINK`` whose legs all stay
    # within a half turn; factor 0 is the chord, i.e. the paper's linear rotation spline.
    # Small fits (culls) try every factor on every pair in one kernel call. Long ones try the factors in
    # turn and a pair stops at the first factor that does not lower its cost once it has a legal polygon
    # (the cost along the factor is unimodal in practice: the unshrunk polygon is the least-squares one);
    # only the pairs still improving are evaluated again: about two spline evaluations, not len(_SHRINK).
    x = quat_log(quat_mul(quat_conj(v0[pair]), targets))
    b3 = quat_log(quat_mul(quat_conj(v0), v3))
    inner = _fit_inner_controls(tn, x, pair, np.zeros_like(b3), b3, P)
    del x
    chord = np.stack([b3 / 3.0, 2.0 * b3 / 3.0], axis=1)
    e3 = quat_exp(b3)
    cost = np.full(P, np.inf)
    c1 = c2 = r = None
    active = np.ones(P, dtype=bool)
    if len(_SHRINK) * tn.size <= _START_BATCH:
        c1, c2, r, cost = _start_every_factor(T4, V0, V3, tn, pair, chord, inner, e3, P)
        active[:] = False
    for alpha in _SHRINK:
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        whole = idx.size == P
        e = quat_exp(chord[idx] + alpha * (inner[idx] - chord[idx]))      # (n, 2, 4) controls relative to v0
        legal = ((e[:, 0, 3] > 0) & (np.sum(e[:, 0] * e[:, 1], axis=1) > 0)
                 & (np.sum(e[:, 1] * e3[idx], axis=1) > 0)) | (alpha == 0.0)
        a1 = quat_mul(v0[idx], e[:, 0]).T
        a2 = quat_mul(v0[idx], e[:, 1]).T
        if whole:
            ra = residual(a1, a2)
            ca = np.where(legal, pair_cost(ra), np.inf)
        else:                                   # the samples of the active pairs, pairs renumbered 0..n-1
            smask = active[pair]
            sp = (np.cumsum(active) - 1)[pair[smask]]
            ra = K.spline_residual_into(np.ascontiguousarray(T4[:, smask]), np.ascontiguousarray(V0[:, idx]),
                                        a1, a2, np.ascontiguousarray(V3[:, idx]), sp, tn[smask],
                                        np.empty((3, sp.size)))
            ca = np.where(legal, np.bincount(sp, ra[0] * ra[0] + ra[1] * ra[1] + ra[2] * ra[2], idx.size), np.inf)
        use = ca < cost[idx]
        if c1 is None:
            c1, c2, r = a1, a2, ra
        else:
            c1[:, idx[use]] = a1[:, use]
            c2[:, idx[use]] = a2[:, use]
            if whole:
                r = np.where(use[pair], ra, r)
            else:
                r[:, np.flatnonzero(smask)[use[sp]]] = ra[:, use[sp]]
        cost[idx[use]] = ca[use]
        active[idx] = use | ~np.isfinite(cost[idx])      # improving, or no legal polygon yet

    lam = np.full(P, 1e-6)
    starts = np.concatenate([[0], np.flatnonzero(np.diff(pair)) + 1])
    present = pair[starts] if pair.size else np.zeros(0, np.int64)   # pairs with samples (others: zero step)
    if pair.size == 0:
        iterations = 0
    eye = np.eye(6)
    for _ in range(iterations):
        Jac = np.empty((6,) + r.shape)
        for j in range(6):
            e = np.zeros((3, 1))
            e[j % 3] = 0.5 * _FD_STEP          # quat_exp takes half the rotation vector
            step = K.qexp(np.ascontiguousarray(np.broadcast_to(e, (3, P))))
            rp = residual(K.qmul(c1, step), c2) if j < 3 else residual(c1, K.qmul(c2, step))
            Jac[j] = (rp - r) / _FD_STEP
        JTJ = np.zeros((P, 6, 6))
        JTr = np.zeros((P, 6))
        JTJ[present] = np.add.reduceat(np.einsum("ian,jan->nij", Jac, Jac), starts, axis=0)
        JTr[present] = np.add.reduceat(np.einsum("ian,an->ni", Jac, r), starts, axis=0)
        scale = np.trace(JTJ, axis1=1, axis2=2) / 6.0 + 1e-12
        A = JTJ + (lam * scale)[:, None, None] * eye
        delta = -np.linalg.solve(A, JTr[..., None])[..., 0]
        n1 = K.qmul(c1, quat_exp(0.5 * delta[:, :3]).T)
        n2 = K.qmul(c2, quat_exp(0.5 * delta[:, 3:]).T)
        rn = residual(n1, n2)
        cn = pair_cost(rn)
        ok = cn < cost
        c1 = np.where(ok, n1, c1)
        c2 = np.where(ok, n2, c2)
        cost = np.where(ok, cn, cost)
        r = np.where(ok[pair], rn, r)
        lam = np.where(ok, lam * 0.1, lam * 10.0)
    return np.stack([quat_normalize(c1.T), quat_normalize(c2.T)], axis=1), cost


def _start_every_factor(T4, V0, V3, tn, pair, chord, inner, e3, P):
    """The start of :func:`fit_rotation_tangents` with every shrink factor tried on every pair, as one
    kernel call over ``len(_SHRINK)`` copies of the pairs; per pair the first factor of least cost among
    the legal ones. Returns ``c1, c2 (4, P), r (3, N), cost (P,)``."""
    S, N = len(_SHRINK), tn.size
    al = np.asarray(_SHRINK)[:, None, None, None]
    e = quat_exp(chord + al * (inner - chord))                             # (S, P, 2, 4) relative to v0
    legal = (((e[..., 0, 3] > 0) & (np.sum(e[..., 0, :] * e[..., 1, :], axis=-1) > 0)
              & (np.sum(e[..., 1, :] * e3, axis=-1) > 0)) | (al[:, :, 0, 0] == 0.0))
    v0 = V0.T
    a1, a2 = quat_mul(v0, e[..., 0, :]), quat_mul(v0, e[..., 1, :])      # (S, P, 4)
    pS = (pair + P * np.arange(S)[:, None]).ravel()
    R = K.spline_residual_into(np.tile(T4, S), np.tile(V0, S), np.ascontiguousarray(a1.reshape(S * P, 4).T),
                               np.ascontiguousarray(a2.reshape(S * P, 4).T), np.tile(V3, S), pS, np.tile(tn, S),
                               np.empty((3, S * N)))
    costs = np.where(legal, np.bincount(pS, R[0] * R[0] + R[1] * R[1] + R[2] * R[2], S * P).reshape(S, P), np.inf)
    best = np.argmin(costs, axis=0)                                         # first of the least (ties: earlier)
    ar = np.arange(P)
    r = R.reshape(3, S, N)[:, best[pair], np.arange(N)]
    return a1[best, ar].T, a2[best, ar].T, r, costs[best, ar]


