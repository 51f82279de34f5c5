"""Fitting splines and displacement maps to dense motion (Coleman et al. 2008, §4.1.1, Appendix A).

Given pose times and refinements, every (segment, joint) pair gets a quaternion Bézier whose end points are
the knot values and whose two inner control quaternions ("tangents") minimise the squared angular distance
to the source samples on SO(3); the root translation gets a cubic Bézier fitted by linear least squares.
The displacement map is what is left: ``d(t') = s(t') ⊖ v(t')`` (§4.1.1), stored on the normalised segment
time, so ``evaluate`` reproduces the source exactly at the sample times.

The paper minimises ``w_f f_f + w_c f_c`` with Nelder–Mead per joint and segment (Appendix A). Here all
pairs are fitted at once. By default the splines are C1 (:func:`fit_rotation_tangents_c1`: one angular
velocity per knot, shared by both segments); the per-segment (C0) problem of the paper is
:func:`fit_rotation_tangents`: a closed-form initialisation (a Euclidean cubic Bézier fitted by linear least
squares to the samples' logarithms relative to the first knot) followed by a few damped Gauss–Newton
(Levenberg–Marquardt) steps on the rotation vectors of the residuals, with the controls parameterised on
the manifold (``q̂ <- q̂ exp(δ)``) so they stay unit quaternions without a penalty term.
:func:`fit_rotation_tangents_nelder_mead` is a straight port of Appendix A, kept as a reference.
"""
from __future__ import annotations

import numpy as np

from ..core.rotations import (quat_conj, quat_exp, quat_hemisphere, quat_log, quat_mul, quat_normalize,
                              quat_bezier, slerp)
from . import _kernels
from . import _kernels as K
from .representation import (StaggeredMotion, bezier_cubic, evaluate_samples, root_positions_at,
                             rotation_spline, translation_source_times)

__all__ = ["fit_staggered", "refit_merged", "fit_subset", "velocity_jumps", "displacement_rotvecs", "match_tangents",
           "match_translation_tangents", "fit_rotation_tangents_c1", "velocities_from_tangents",
           "fit_rotation_tangents", "fit_translation_tangents", "fit_rotation_tangents_nelder_mead",
           "sample_segments", "rotation_residuals"]

_RIDGE = 1e-9       # pulls under-determined inner controls (segments with < 2 interior samples) to the chord
_FD_STEP = 1e-6     # finite-difference step of the Gauss-Newton Jacobian (rotation-vector units, radians)
_ON_FRAME = 1e-6    # fractional frames closer than this to an integer are read directly (no slerp)
_LOCAL_MAX_SHARE = 0.6   # refit_merged declines when the segments it would refit span more of the clip
_LOG_SMALL = 1e-12   # below this |v| the logarithm uses its Taylor branch (as core.rotations)
_FD_BATCH = 1 << 18   # fits with at most this many samples x 6 take their finite differences in one kernel call
_START_BATCH = 1 << 13   # ... and up to this many samples x 7 try every shrink factor at once (measured: faster
                         # than the lazy loop below ~1,200 fit samples, slower above: 2.3 vs 3.6 ms at 540,
                         # 8.4 vs 5.9 ms at 2,970 on cull refits of CMU 01_01)
_SHRINK = (1.0, 0.85, 0.7, 0.55, 0.4, 0.2, 0.0)   # start polygons tried: Euclidean fit shrunk toward its chord


# -- sampling ----------------------------------------------------------------------------------------

def sample_segments(knots: np.ndarray, frame_time: float, start_time: float = 0.0, oversample: int = 1):
    """Uniform ``t'`` sample grids of every segment of every control variable.

    Parameters
    ----------
    knots : (K, C) knot times (seconds), strictly increasing down each column
    frame_time : seconds between source frames; a segment of length L gets ``round(L / frame_time) + 1``
        samples (>= 2), so knots on source frames put every grid point on a source frame
    start_time : time of the source's frame 0
    oversample : samples per frame (``round(oversample * L / frame_time) + 1`` per segment)

    Returns
    -------
    pair : (N,) int, segment-major pair index ``k * C + c`` of each sample
    m : (N,) int, sample index within its pair
    counts : (P,) int, samples per pair, ``P = (K - 1) * C``
    tn : (N,) normalised time ``m / (count - 1)``
    frames : (N,) fractional source frame of each sample
    """
    a = knots[:-1].reshape(-1)
    b = knots[1:].reshape(-1)
    counts = np.maximum(np.rint(oversample * (b - a) / frame_time).astype(np.int64) + 1, 2)
    pair = np.repeat(np.arange(counts.size), counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    m = np.arange(pair.size) - starts[pair]
    tn = m / (counts[pair] - 1.0)
    t = a[pair] + tn * (b - a)[pair]
    return pair, m, counts, tn, (t - start_time) / frame_time


def fit_subset(m: np.ndarray, counts: np.ndarray, pair: np.ndarray, max_samples: int | None) -> np.ndarray:
    """Boolean (N,) mask of the samples the splines are fitted to: every sample of a pair with at most
    ``max_samples`` samples, else ``max_samples`` evenly spaced ones, ``m = round(j (n - 1) / (S - 1))``,
    ``j = 0 .. S - 1`` (first and last included). ``None`` selects all."""
    n = counts[pair]
    if max_samples is None:
        return np.ones(pair.size, dtype=bool)
    S = int(max_samples)
    step = (n - 1.0) / (S - 1.0)
    big = n > S
    j = np.rint(m / np.where(big, step, 1.0))        # step > 1: each m is near at most one grid point j
    return ~big | (np.rint(j * step) == m)


def _read(arr: np.ndarray, frames: np.ndarray, cols: np.ndarray | None, quat: bool) -> np.ndarray:
    """Sample ``arr (F, C, D)`` (or ``(F, D)`` when ``cols`` is None) at fractional frames (clamped)."""
    F = arr.shape[0]
    f = np.clip(frames, 0.0, F - 1)
    r = np.rint(f)
    if np.all(np.abs(f - r) < _ON_FRAME):
        i = r.astype(np.int64)
        return arr[i] if cols is None else arr[i, cols]
    i0 = np.minimum(np.floor(f).astype(np.int64), F - 1)
    i1 = np.minimum(i0 + 1, F - 1)
    w = f - i0
    x0 = arr[i0] if cols is None else arr[i0, cols]
    x1 = arr[i1] if cols is None else arr[i1, cols]
    if quat:
        return slerp(x0, x1, w)
    return x0 * (1.0 - w[:, None]) + x1 * w[:, None]


# -- Euclidean cubic Bézier inner controls (closed form) ---------------------------------------------

def _fit_inner_controls(tn, y, pair, b0, b3, num_pairs):
    """Least-squares ``(b1, b2)`` of cubic Béziers with fixed ends ``b0, b3 (P, D)``; samples ``y (N, D)``.

    A tiny ridge toward the straight chord (``b1 = (2 b0 + b3)/3``, ``b2 = (b0 + 2 b3)/3``) decides
    segments with fewer than two interior samples. Returns ``(P, 2, D)``.
    """
    u = 1.0 - tn
    B1 = 3.0 * u * u * tn
    B2 = 3.0 * u * tn * tn
    r = y - (u ** 3)[:, None] * b0[pair] - (tn ** 3)[:, None] * b3[pair]
    g11 = np.bincount(pair, B1 * B1, num_pairs) + _RIDGE
    g12 = np.bincount(pair, B1 * B2, num_pairs)
    g22 = np.bincount(pair, B2 * B2, num_pairs) + _RIDGE
    c1 = (2.0 * b0 + b3) / 3.0
    c2 = (b0 + 2.0 * b3) / 3.0
    D = y.shape[1]
    h1 = np.stack([np.bincount(pair, B1 * r[:, d], num_pairs) for d in range(D)], axis=1) + _RIDGE * c1
    h2 = np.stack([np.bincount(pair, B2 * r[:, d], num_pairs) for d in range(D)], axis=1) + _RIDGE * c2
    det = (g11 * g22 - g12 * g12)[:, None]
    x1 = (g22[:, None] * h1 - g12[:, None] * h2) / det
    x2 = (g11[:, None] * h2 - g12[:, None] * h1) / det
    return np.stack([x1, x2], axis=1)


def fit_translation_tangents(tn, y, pair, p0, p3, num_pairs):
    """Inner control points ``(P, 2, 3)`` of cubic Béziers with ends ``p0, p3 (P, 3)`` fitted to samples
    ``y (N, 3)`` at normalised times ``tn (N,)`` of pair ``pair (N,)`` (linear least squares, §4.1.1)."""
    return _fit_inner_controls(tn, y, pair, p0, p3, num_pairs)


# -- rotations -------------------------------------------------------------------------------------

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


def fit_rotation_tangents_nelder_mead(tn, targets, v0, v3, w_f: float = 1000.0, w_c: float = 1.0,
                                      maxiter: int | None = None):
    """Straight port of Appendix A for one joint and one segment (reference for benchmarks/tests).

    Minimises ``w_f f_f + w_c f_c`` over the raw 8 numbers of ``(q̂2, q̂3)`` with scipy's Nelder–Mead,
    starting from the linear rotation spline, then renormalises. ``f_f`` is the mean over interior samples
    of ``acos(q_k · s(t_k))²`` and ``f_c = | |q̂2|² + |q̂3|² - 2 |``.

    Parameters
    ----------
    tn : (n,) normalised times (first 0, last 1); targets : (n, 4); v0, v3 : (4,) end knots

    Returns
    -------
    tangents : (2, 4) unit quaternions
    """
    from scipy.optimize import minimize

    inner = slice(1, len(tn) - 1)
    ti, qi = np.asarray(tn)[inner], np.asarray(targets)[inner]
    x0 = np.concatenate([slerp(v0, v3, 1.0 / 3.0), slerp(v0, v3, 2.0 / 3.0)])
    if ti.size == 0:
        return x0.reshape(2, 4)

    def f(x):
        a, b = x[:4], x[4:]
        na, nb = np.linalg.norm(a), np.linalg.norm(b)
        s = quat_bezier(v0, a / max(na, 1e-12), b / max(nb, 1e-12), v3, ti)
        d = np.clip(np.abs(np.sum(qi * s, axis=-1)), -1.0, 1.0)
        ff = np.mean(np.arccos(d) ** 2)
        fc = abs(na * na + nb * nb - 2.0)
        return w_f * ff + w_c * fc

    # scipy's default Nelder-Mead settings (maxiter 200 * 8, xatol = fatol = 1e-4): a straight port
    res = minimize(f, x0, method="Nelder-Mead", options={"maxiter": maxiter} if maxiter else None)
    return quat_normalize(res.x.reshape(2, 4))


# -- the whole representation ---------------------------------------------------------------------

def match_tangents(values, tangents, knots):
    """Make quaternion splines C1 at interior knots (same angular velocity on both sides of each join).

    At knot ``k`` the body angular velocities of the two segments are ``w_in = 3 log(q̂3_{k-1}^-1 v_k) / Δ_{k-1}``
    and ``w_out = 3 log(v_k^-1 q̂2_k) / Δ_k`` (rotation vectors / s). Both become the common
    ``ω = (Δ_{k-1}² w_in + Δ_k² w_out) / (Δ_{k-1}² + Δ_k²)`` (the least change of the two control
    quaternions), by setting ``q̂3_{k-1} = v_k exp(-ω Δ_{k-1} / 3)`` and ``q̂2_k = v_k exp(ω Δ_k / 3)``.

    Parameters
    ----------
    values : (K, C, 4); tangents : (K - 1, C, 2, 4); knots : (K, C) seconds, increasing down columns

    Returns
    -------
    tangents : (K - 1, C, 2, 4), new array; end controls of the first and last segment unchanged.
    """
    tangents = np.array(tangents, dtype=float)
    if values.shape[0] < 3:
        return tangents
    d = np.diff(knots, axis=0)[..., None]                                   # (K-1, C, 1)
    v = values[1:-1]
    w_in = 3.0 * _rotvec_between(tangents[:-1, :, 1].reshape(-1, 4), v.reshape(-1, 4)).reshape(v.shape[:-1] + (3,))
    w_out = 3.0 * _rotvec_between(v.reshape(-1, 4), tangents[1:, :, 0].reshape(-1, 4)).reshape(v.shape[:-1] + (3,))
    w_in /= d[:-1]
    w_out /= d[1:]
    a2, b2 = d[:-1] ** 2, d[1:] ** 2
    omega = (a2 * w_in + b2 * w_out) / (a2 + b2)
    tangents[:-1, :, 1] = quat_mul(v, quat_exp(-0.5 * omega * d[:-1] / 3.0))
    tangents[1:, :, 0] = quat_mul(v, quat_exp(0.5 * omega * d[1:] / 3.0))
    return tangents


def match_translation_tangents(values, tangents, knots):
    """C1 root-translation Béziers: at interior knots both sides get the velocity
    ``(Δ_{k-1}² u_in + Δ_k² u_out) / (Δ_{k-1}² + Δ_k²)`` with ``u_in = 3 (p_k - p2_{k-1}) / Δ_{k-1}`` and
    ``u_out = 3 (p1_k - p_k) / Δ_k``. ``values (K, 3)``, ``tangents (K - 1, 2, 3)``, ``knots (K,)``."""
    tangents = np.array(tangents, dtype=float)
    if values.shape[0] < 3:
        return tangents
    d = np.diff(knots)[:, None]
    v = values[1:-1]
    u_in = 3.0 * (v - tangents[:-1, 1]) / d[:-1]
    u_out = 3.0 * (tangents[1:, 0] - v) / d[1:]
    a2, b2 = d[:-1] ** 2, d[1:] ** 2
    u = (a2 * u_in + b2 * u_out) / (a2 + b2)
    tangents[:-1, 1] = v - u * d[:-1] / 3.0
    tangents[1:, 0] = v + u * d[1:] / 3.0
    return tangents


def _tangents_from_velocities(values, omega, d):
    """Controls ``q̂2_k = v_k exp(ω_k Δ_k / 3)``, ``q̂3_k = v_{k+1} exp(-ω_{k+1} Δ_k / 3)`` as (4, P) each
    (P = (K-1) C, segment-major). ``values (K, C, 4)``, ``omega (K, C, 3)`` rad/s, ``d (K-1, C)`` s."""
    a = quat_mul(values[:-1], quat_exp(0.5 * omega[:-1] * d[..., None] / 3.0))
    b = quat_mul(values[1:], quat_exp(-0.5 * omega[1:] * d[..., None] / 3.0))
    return np.ascontiguousarray(a.reshape(-1, 4).T), np.ascontiguousarray(b.reshape(-1, 4).T)


def _legs_within_half_turn(values, a, b):
    """(P,) bool: the legs ``v_k -> a -> b -> v_k+1`` of each pair's control polygon (``a, b`` (4, P),
    ``values (K, C, 4)``, pairs segment-major) all have positive quaternion dot products."""
    P = a.shape[1]
    v0 = values[:-1].reshape(P, 4).T
    v3 = values[1:].reshape(P, 4).T
    return (np.sum(v0 * a, axis=0) > 0) & (np.sum(a * b, axis=0) > 0) & (np.sum(b * v3, axis=0) > 0)


def fit_rotation_tangents_c1(tn, targets, pair, values, knots, omega, iterations: int = 3, fixed=None):
    """C1 quaternion splines: one body angular velocity ``ω_{k,c}`` per knot shared by both adjacent
    segments, fitted by Levenberg–Marquardt on the squared residual angles of all samples (Appendix A's
    objective under a continuity constraint).

    The Jacobian comes from finite differences with a two-colouring of the knots (a segment sees exactly
    one even and one odd knot), so one iteration costs 7 spline evaluations whatever K is; the normal
    equations are block-tridiagonal per control variable and solved as one sparse system.

    Constraint: no control-polygon leg past a half turn (the recursive slerp would follow it the other way
    round, a spline swinging through ~360 deg). Start velocities are halved at the knots of such segments
    and steps that create one are rejected (except in segments whose chord ``v_k -> v_k+1`` is itself past
    a half turn).

    Parameters
    ----------
    tn, targets, pair : samples as in :func:`fit_rotation_tangents` (pairs segment-major, ``k * C + c``)
    values : (K, C, 4) knots; knots : (K, C) knot times (s); omega : (K, C, 3) start velocities (rad/s)
    fixed : (K,) bool or None; knots whose velocities stay at ``omega`` (a local refit between kept
        segments, :func:`refit_merged`); pairs with both knots fixed are not checked for long legs

    Returns
    -------
    omega : (K, C, 3); tangents : (P, 2, 4); cost : (P,) sum of squared residual angles per pair
    """
    Kn, C = knots.shape
    P = (Kn - 1) * C
    d = np.diff(knots, axis=0)
    T4 = np.ascontiguousarray(targets.T)
    V0 = np.ascontiguousarray(values[:-1].reshape(P, 4).T)
    V3 = np.ascontiguousarray(values[1:].reshape(P, 4).T)
    tn = np.ascontiguousarray(tn, dtype=float)
    seg = pair // C
    col = pair % C

    def residual(om):
        a, b = _tangents_from_velocities(values, om, d)
        return K.spline_residual_into(T4, V0, a, b, V3, pair, tn, np.empty((3, tn.size)))

    def joint_cost(r):
        return np.bincount(col, r[0] * r[0] + r[1] * r[1] + r[2] * r[2], C)

    fix = np.zeros(Kn, dtype=bool) if fixed is None else np.asarray(fixed, dtype=bool).reshape(Kn)
    free_pair = np.repeat(~(fix[:-1] & fix[1:]), C)        # (P,) pairs a step can change

    def legs_ok(om):                                       # (P,) every control leg within a half turn
        a, b = _tangents_from_velocities(values, om, d)
        return _legs_within_half_turn(values, a, b) | ~free_pair

    # The recursive slerp follows each control-polygon leg the short way: a leg past a half turn makes the
    # spline swing the other way round. Halve the start velocities at the knots of such segments (omega = 0
    # makes the legs 0, v_k -> v_k+1, 0), and reject steps that push a leg of a joint past a half turn.
    omega = np.array(omega, dtype=float)
    chord_ok = _legs_within_half_turn(values, values[:-1].reshape(P, 4).T, values[1:].reshape(P, 4).T)
    for _ in range(8):
        bad = ~legs_ok(omega) & chord_ok
        if not bad.any():
            break
        kb, cb = np.divmod(np.flatnonzero(bad), C)
        omega[kb[~fix[kb]], cb[~fix[kb]]] *= 0.5
        omega[kb[~fix[kb + 1]] + 1, cb[~fix[kb + 1]]] *= 0.5
    else:
        bad = ~legs_ok(omega) & chord_ok
        kb, cb = np.divmod(np.flatnonzero(bad), C)
        omega[kb[~fix[kb]], cb[~fix[kb]]] = 0.0
        omega[kb[~fix[kb + 1]] + 1, cb[~fix[kb + 1]]] = 0.0
    r = residual(omega)
    cost = joint_cost(r)
    lam = np.full(C, 1e-4)
    if pair.size == 0:
        iterations = 0
    starts = np.concatenate([[0], np.flatnonzero(np.diff(pair)) + 1]) if pair.size else np.zeros(0, np.int64)
    parity = np.arange(Kn) % 2
    pc, pk = col[starts], seg[starts]                      # per pair with samples: column, a-knot (k)
    a_even = (seg % 2 == 0)                                 # samples whose a-knot has colour 0
    N = tn.size
    if 6 * N <= _FD_BATCH:
        # small fits (cull refits): the six perturbed fits as one set of 6 C columns, one kernel call
        T6, tn6 = np.tile(T4, 6), np.tile(tn, 6)
        pair6 = (seg * 6 * C + (np.arange(6) * C)[:, None] + col).ravel()
        values6, d6 = np.tile(values, (1, 6, 1)), np.tile(d, (1, 6))
        V06 = np.ascontiguousarray(values6[:-1].reshape(-1, 4).T)
        V36 = np.ascontiguousarray(values6[1:].reshape(-1, 4).T)

    def perturbed_residuals():                             # (colour, component) -> d r / d ω (3, N)
        oms = []
        for c in (0, 1):
            for j in range(3):
                om = np.array(omega)
                om[parity == c, :, j] += _FD_STEP
                oms.append(om)
        if 6 * N > _FD_BATCH:
            for om in oms:
                yield residual(om)
            return
        a, b = _tangents_from_velocities(values6, np.concatenate(oms, axis=1), d6)
        out = K.spline_residual_into(T6, V06, a, b, V36, pair6, tn6, np.empty((3, 6 * N)))
        yield from (out[:, i * N:(i + 1) * N] for i in range(6))

    for _ in range(iterations):
        Ja = np.empty((3,) + r.shape)                      # component, residual row, sample: d r / d ω_a
        Jb = np.empty((3,) + r.shape)                      # ... d r / d ω_b
        fd = perturbed_residuals()
        for c in (0, 1):
            for j in range(3):
                dr = next(fd)
                dr -= r
                dr /= _FD_STEP
                np.copyto(Ja[j], dr, where=a_even if c == 0 else ~a_even)
                np.copyto(Jb[j], dr, where=~a_even if c == 0 else a_even)
                del dr
        if fix.any():                                      # fixed knots: no Jacobian, so a zero step
            Ja *= ~fix[seg]
            Jb *= ~fix[seg + 1]
        delta = _solve_c1_step(Ja, Jb, r, starts, pc, pk, C, Kn, lam)
        del Ja, Jb
        new = omega + delta.reshape(C, Kn, 3).transpose(1, 0, 2)
        rn = residual(new)
        cn = joint_cost(rn)
        cn[np.unique(np.flatnonzero(~legs_ok(new) & chord_ok) % C)] = np.inf
        ok = cn < cost
        omega = np.where(ok[None, :, None], new, omega)
        r = np.where(ok[col], rn, r)
        cost = np.where(ok, cn, cost)
        lam = np.where(ok, lam * 0.1, lam * 10.0)
    a, b = _tangents_from_velocities(values, omega, d)
    pair_cost = np.bincount(pair, r[0] * r[0] + r[1] * r[1] + r[2] * r[2], P)
    return omega, np.stack([quat_normalize(a.T), quat_normalize(b.T)], axis=1), pair_cost


def _solve_c1_step(Ja, Jb, r, starts, pc, pk, C, Kn, lam):
    """The damped Gauss-Newton step of :func:`fit_rotation_tangents_c1`, (C * Kn * 3,) ordered
    ``(c * Kn + k) * 3 + j`` (column c, knot k, component j).

    ``Ja, Jb (3, 3, N)``: derivatives of the residuals ``r (3, N)`` by the velocities of each sample's first
    and second knot; samples of a pair contiguous from ``starts``, the pair's column ``pc`` and first knot
    ``pk``; ``lam (C,)`` Levenberg-Marquardt damping per column (relative to the diagonal). A segment
    couples only its two knots, so the normal equations of a column are block-tridiagonal (3 x 3 blocks)
    and the whole system is a symmetric band of half-width 5: a banded Cholesky (LAPACK pbsv) solves it in
    O(C Kn).
    """
    from scipy.linalg import LinAlgError, solve_banded, solveh_banded

    def block(x, y):
        return np.add.reduceat(np.einsum("ian,jan->nij", x, y), starts, axis=0)

    D = np.zeros((C, Kn, 3, 3))                            # diagonal blocks per (column, knot)
    E = np.zeros((C, Kn - 1, 3, 3))                        # blocks (knot k, knot k + 1)
    G = np.zeros((C, Kn, 3))
    D[pc, pk] += block(Ja, Ja)                             # (pc, pk) unique per pair
    D[pc, pk + 1] += block(Jb, Jb)
    E[pc, pk] = block(Ja, Jb)
    G[pc, pk] += np.add.reduceat(np.einsum("ian,an->ni", Ja, r), starts, axis=0)
    G[pc, pk + 1] += np.add.reduceat(np.einsum("ian,an->ni", Jb, r), starts, axis=0)
    n = C * Kn * 3
    ab = np.zeros((6, n))                                  # upper band: ab[5 + i - j, j] = A[i, j]
    Df = D.reshape(C * Kn, 3, 3)
    for i in range(3):
        for j in range(i, 3):
            ab[5 + i - j, j::3] = Df[:, i, j]
    col0 = ((np.arange(C)[:, None] * Kn + np.arange(1, Kn)) * 3).ravel()   # first unknown of knot k + 1
    for i in range(3):
        for j in range(3):
            ab[2 + i - j, col0 + j] = E[:, :, i, j].ravel()
    diag = ab[5].copy()
    ab[5] += np.repeat(lam, Kn * 3) * np.maximum(diag, 1e-12) + 1e-12
    g = G.reshape(n)
    try:
        return -solveh_banded(ab, g, check_finite=False)
    except LinAlgError:                                    # not positive definite in rounding: LU instead
        full = np.zeros((11, n))
        full[:6] = ab
        for k in range(1, 6):                              # lower band = mirrored upper band
            full[5 + k, :n - k] = ab[5 - k, k:]
        return -solve_banded((5, 5), full, g, check_finite=False)


def velocities_from_tangents(values, tangents, knots):
    """Per-knot body angular velocities (K, C, 3) rad/s of C0 splines, averaged as in :func:`match_tangents`
    (the first and last knot take their single side)."""
    d = np.diff(knots, axis=0)[..., None]
    sh = d.shape[:-1] + (3,)
    w_out = 3.0 * _rotvec_between(values[:-1].reshape(-1, 4), tangents[:, :, 0].reshape(-1, 4)).reshape(sh) / d
    w_in = 3.0 * _rotvec_between(tangents[:, :, 1].reshape(-1, 4), values[1:].reshape(-1, 4)).reshape(sh) / d
    om = np.empty(values.shape[:-1] + (3,))
    om[0] = w_out[0]
    om[-1] = w_in[-1]
    a2, b2 = d[:-1] ** 2, d[1:] ** 2
    om[1:-1] = (a2 * w_in[:-1] + b2 * w_out[1:]) / (a2 + b2)
    return om


def velocity_jumps(sm: StaggeredMotion):
    """Angular-velocity jump of the splines (before displacement) at every interior knot.

    Returns ``jump, speed`` of shape (K - 2, J): ``|w_out - w_in|`` and ``max(|w_in|, |w_out|)`` in rad/s,
    with the body angular velocities ``w_in = 3 log(q̂3_{k-1}^-1 v_k) / Δ_{k-1}``,
    ``w_out = 3 log(v_k^-1 q̂2_k) / Δ_k``. Zero jumps mean C1 splines.
    """
    d = np.diff(sm.pose_times[:, None] + sm.refinements, axis=0)[..., None]
    v, tg = sm.values, sm.tangents
    sh = v[1:-1].shape[:-1] + (3,)
    w_in = 3.0 * _rotvec_between(tg[:-1, :, 1].reshape(-1, 4), v[1:-1].reshape(-1, 4)).reshape(sh) / d[:-1]
    w_out = 3.0 * _rotvec_between(v[1:-1].reshape(-1, 4), tg[1:, :, 0].reshape(-1, 4)).reshape(sh) / d[1:]
    return (np.linalg.norm(w_out - w_in, axis=-1),
            np.maximum(np.linalg.norm(w_in, axis=-1), np.linalg.norm(w_out, axis=-1)))


def displacement_rotvecs(s, targets, pair):
    """Displacement samples ``d = v ⊖ s`` as rotation vectors (N, 3), unwrapped along each pair.

    The quaternions ``s^-1 v`` are made sign-continuous along each pair's samples (starting on the
    ``w >= 0`` side), then mapped by the logarithm without hemisphere folding, so angles run continuously
    in [0, 2 pi): linear interpolation between neighbouring samples then never jumps across the pi
    ambiguity (large residuals occur on long merged segments).

    ``s, targets (N, 4)`` (transposed views of component-first ``(4, N)`` arrays are used without a
    copy); ``pair (N,)``, samples of a pair contiguous. Works on ``(4, N)`` rows throughout."""
    S = np.asarray(s, dtype=float).T
    T = np.asarray(targets, dtype=float).T
    N = S.shape[1]
    if N == 0:
        return np.zeros((0, 3))
    CH = K.CHUNK                                     # blocks of samples: every temporary stays in cache
    e = np.empty((4, N))                             # s^-1 v
    sc, tmp = np.empty((4, CH)), np.empty(CH)
    for a in range(0, N, CH):
        b = min(N, a + CH)
        np.negative(S[:3, a:b], out=sc[:3, :b - a])
        sc[3, :b - a] = S[3, a:b]
        K.qmul_into(sc[:, :b - a], T[:, a:b], e[:, a:b], tmp[:b - a])
    first = np.concatenate([[True], pair[1:] != pair[:-1]])
    f = np.flatnonzero(first)
    e[:, f] = np.where(e[3, f] < 0, -e[:, f], e[:, f])                  # each pair starts with w >= 0
    d = np.empty(max(N - 1, 0))
    for a in range(0, N - 1, CH):
        b = min(N - 1, a + CH)
        K.dot_into(e[:, a + 1:b + 1], e[:, a:b], d[a:b], tmp[:b - a])
    neg = np.concatenate([[0], np.cumsum((d < 0) & ~first[1:])])
    scale2 = np.where((neg - np.repeat(neg[f], np.diff(np.append(f, N)))) % 2 == 1, -2.0, 2.0)
    out = np.empty((N, 3))
    for a in range(0, N, CH):
        b = min(N, a + CH)
        x = e[:, a:b] * scale2[a:b]                 # sign-continuous, and x2: rotvec = 2 log(q)
        n = np.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])          # 2 |v|
        half = np.arctan2(n, x[3])                                      # half angle in [0, pi]
        big = n > 2.0 * _LOG_SMALL
        # angle / |v| = 2 half / |v|; Taylor below _LOG_SMALL: 2 / w (as core.rotations.quat_log)
        sc_ = np.where(big, 2.0 * half / np.where(big, n, 1.0), 2.0 / np.where(x[3] != 0, x[3], 1.0))
        out[a:b] = (x[:3] * sc_).T
    return out


def _continuous_per_pair(e, first):
    """Flip signs of ``e (N, 4)`` so consecutive samples of a pair (runs starting where ``first``) have
    non-negative dot products; the first sample of each pair keeps its sign."""
    d = np.sum(e[1:] * e[:-1], axis=1)
    neg = np.concatenate([[0], np.cumsum((d < 0) & ~first[1:])])
    start = np.flatnonzero(first)
    base = np.repeat(neg[start], np.diff(np.concatenate([start, [first.size]])))
    return np.where(((neg - base) % 2 == 1)[:, None], -e, e)


def _segment_major(seg, joint, m) -> bool:
    """True when samples are in (segment, joint, sample) order (as :func:`sample_segments` lays them out):
    then a stable sort by joint alone gives the (joint, segment, sample) order."""
    dk, dj, dm = np.diff(seg), np.diff(joint), np.diff(m)
    return bool(np.all((dk > 0) | ((dk == 0) & ((dj > 0) | ((dj == 0) & (dm > 0))))))


def _continuous_per_joint(q, joint, seg, m):
    """Flip signs of samples ``q (N, 4)`` so each joint's samples, taken in time order (segment, then
    sample index), have non-negative consecutive dot products."""
    if _segment_major(seg, joint, m):
        return _continuous_segment_major(q, joint, seg)
    order = np.lexsort((m, seg, joint))
    seq = q[order]
    js = joint[order]
    d = np.sum(seq[1:] * seq[:-1], axis=1)
    neg = np.concatenate([[0], np.cumsum((d < 0) & (js[1:] == js[:-1]))])
    start = np.concatenate([[0], np.flatnonzero(np.diff(js)) + 1])
    base = np.repeat(neg[start], np.diff(np.concatenate([start, [js.size]])))
    out = np.empty_like(q)
    out[order] = np.where(((neg - base) % 2 == 1)[:, None], -seq, seq)
    return out


def _continuous_segment_major(q, joint, seg):
    """:func:`_continuous_per_joint` for samples in (segment, joint, sample) order with every (segment,
    joint) pair present (as :func:`sample_segments` lays them out), without sorting: a sample's flip is the
    parity of the negative consecutive dot products before it in its joint's sequence, counted inside its
    pair, plus those of the joint's earlier pairs and of the joins between them (per pair, a cumulative sum
    down the segments)."""
    N = q.shape[0]
    new_pair = np.concatenate([[True], (np.diff(seg) != 0) | (np.diff(joint) != 0)])
    starts = np.flatnonzero(new_pair)
    ends = np.concatenate([starts[1:], [N]]) - 1
    C = int(joint[starts].max()) + 1
    Ks = starts.size // C
    neg = np.einsum("ij,ij->i", q[1:], q[:-1]) < 0
    neg[new_pair[1:]] = False                                   # joins between pairs are counted below
    cnt = np.concatenate([[0], np.cumsum(neg)])                 # negatives before each sample
    inside = (cnt[ends] - cnt[starts]).reshape(Ks, C)           # within each pair
    join = np.zeros((Ks, C), dtype=np.int64)                   # pair (k - 1, c) -> (k, c)
    join[1:] = (np.einsum("ij,ij->i", q[ends[:-C]], q[starts[C:]]) < 0).reshape(Ks - 1, C)
    before = np.cumsum(join, axis=0)
    before[1:] += np.cumsum(inside, axis=0)[:-1]
    pair_of = np.cumsum(new_pair) - 1
    flip = (before.reshape(-1)[pair_of] + cnt[:N] - cnt[starts][pair_of]) % 2 == 1
    return np.where(flip[:, None], -q, q)


def _fit_root(root_at, rk, ft, start_time, oversample, continuity):
    """Root translation of :func:`fit_staggered` (§4.1.1): cubic Béziers through ``root_at`` at the knots
    ``rk (K,)`` s, inner controls by least squares (C1-matched on "C1"), and the displacement table.
    Returns ``root_values (K, 3), tangents (K - 1, 2, 3), table (K - 1, M, 3), counts (K - 1,)``."""
    rk = np.asarray(rk, dtype=float)[:, None]
    rpair, rm, rcounts, rtn, rframes = sample_segments(rk, ft, start_time, oversample)
    ry = root_at(rframes)
    root_values = root_at((rk[:, 0] - start_time) / ft)
    p0, p3 = root_values[:-1], root_values[1:]
    ry[rm == 0] = p0[rpair[rm == 0]]
    ry[rm == rcounts[rpair] - 1] = p3[rpair[rm == rcounts[rpair] - 1]]
    rtan = fit_translation_tangents(rtn, ry, rpair, p0, p3, rk.shape[0] - 1)
    if continuity == "C1":
        rtan = match_translation_tangents(root_values, rtan, rk[:, 0])
    rs = bezier_cubic(p0[rpair], rtan[rpair, 0], rtan[rpair, 1], p3[rpair], rtn)
    rtable = np.zeros((rk.shape[0] - 1, int(rcounts.max()), 3))
    rtable[rpair, rm] = ry - rs
    return root_values, rtan, rtable, rcounts


def _fit_mask(sub, first, last, moving):
    """The samples (N,) bool the splines are fitted to: ``sub`` (:func:`fit_subset`) without the samples
    that cannot inform a fit. The end samples of a pair are its knot values, which every spline of that pair
    meets (the Bernstein weights of the inner controls vanish there: no residual, no Jacobian); samples of
    static joints (``moving`` False, :func:`_static_joints`) fit exactly with a zero velocity, their start.
    Leaving them out keeps the fit (to rounding) and saves their share of every spline evaluation."""
    return sub & ~first & ~last & moving


def _pin_static(tangents, static, const):
    """``tangents (P, 2, 4)`` (pairs segment-major over J joints) with the controls of static joints set to
    their quaternion bit for bit (the fit gives it up to the last bit of a normalisation), so the result is
    recognised as static by :func:`_static_joints` when it is refitted (culls)."""
    if not static.any():
        return tangents
    J = static.size
    jp = np.arange(tangents.shape[0]) % J
    sel = static[jp]
    tangents = np.array(tangents)
    tangents[sel] = const[jp[sel]][:, None, :]
    return tangents


def _static_joints(source):
    """``(J,) bool, (J, 4)``: the joints whose rotation is one quaternion over the whole ``source``, and
    each joint's first rotation. A Motion: every frame equal bit for bit. A StaggeredMotion: every knot and
    control equal to the first knot and the displacement map zero (its ``evaluate`` is then that
    quaternion up to rounding)."""
    if isinstance(source, StaggeredMotion):
        c = source.values[0]
        static = (np.all(source.values == c, axis=(0, 2))
                  & np.all(source.tangents == c[None, :, None, :], axis=(0, 2, 3))
                  & ~np.any(source.displacements, axis=(0, 2, 3)))
        return static, c
    q = source.local_quats
    return np.all(q == q[0], axis=(0, 2)), q[0]


def _fit_stats(angles, inner, iterations, continuity):
    """``metadata["fit"]`` of :func:`fit_staggered` from the residual angles (rad) of every sample."""
    return {"mean_residual_rad": float(angles[inner].mean()) if inner.any() else 0.0,
            "max_residual_rad": float(angles.max()) if angles.size else 0.0,
            "iterations": iterations, "continuity": continuity}


def fit_staggered(source, pose_times, refinements, root_refinements=None, *,
                  pose_probability=None, contacts=(), start_time: float = 0.0, iterations: int = 2,
                  continuity: str = "C1", oversample: int = 1, fit_samples: int | None = 12,
                  metadata: dict | None = None, progress=None) -> StaggeredMotion:
    """Fit splines and displacement maps for given staggered poses (§4.1.1).

    Parameters
    ----------
    source : Motion or StaggeredMotion
        Dense motion whose frame 0 is at ``start_time`` seconds, or a staggered-pose motion (possibly
        edited) that is resampled exactly at the new segments' sample times (absolute times; used by
        :func:`~.extraction.cull` to re-measure splines and displacements over merged segments, §5.1).
    pose_times : (K,) seconds, strictly increasing, inside the source's time span
    refinements : (K, J) seconds; knot times ``pose_times[:, None] + refinements`` strictly increasing
    root_refinements : (K,) seconds for the root translation (default zeros)
    pose_probability : (K,) P(t_k), default ones
    contacts : tuple of (joint_name, start_frame, stop_frame)
    iterations : Levenberg–Marquardt steps of the rotation fit
    continuity : "C1" (default) fits one angular velocity per knot shared by both adjacent segments
        (:func:`fit_rotation_tangents_c1`; the root translation is made C1 by :func:`match_translation_tangents`);
        "C0" fits every segment independently (:func:`fit_rotation_tangents`: smaller residual, velocity
        jumps at joins). Values are continuous either way, and the displacement map absorbs the residual,
        so the reconstruction is exact in both cases.
    oversample : int >= 1, displacement samples per source frame (1: grid points on source frames)
    fit_samples : int >= 4 or None
        Samples per (segment, joint) pair the splines are fitted to (evenly spaced, ends included; see
        :func:`fit_subset`); None fits all. The displacement maps are measured at every sample either way,
        so the reconstruction stays exact; the spline is a least-squares fit to 12 points of a smooth
        segment instead of to all (the residual it leaves is in ``metadata["fit"]``). Pairs with at most
        ``fit_samples`` samples are fitted exactly as with None. Keeps the fit's cost at
        O(K J fit_samples) whatever the frame rate and segment lengths (long takes, culls).
    progress : callable(fraction in [0, 1]) or None, called as the fit advances

    Returns
    -------
    StaggeredMotion reproducing ``source`` at every sample time (displacements absorb the fit residual).
    Fit statistics are in ``metadata["fit"]``: mean and max residual angle of the spline before
    displacement over interior samples (rad), the iterations and the continuity used.
    """
    J = source.num_joints
    pose_times = np.asarray(pose_times, dtype=float).reshape(-1)
    K = pose_times.size
    refinements = np.asarray(refinements, dtype=float)
    if K < 2 or not np.all(np.diff(pose_times) > 0):
        raise ValueError("fit_staggered: pose_times must hold >= 2 strictly increasing times")
    if refinements.shape != (K, J):
        raise ValueError(f"fit_staggered: refinements must have shape ({K}, {J}), got {refinements.shape}")
    rr = np.zeros(K) if root_refinements is None else np.asarray(root_refinements, dtype=float).reshape(K)
    knots = pose_times[:, None] + refinements
    if not np.all(np.diff(knots, axis=0) > 0) or not np.all(np.diff(pose_times + rr) > 0):
        raise ValueError("fit_staggered: refined knot times must be strictly increasing for every joint")
    ft = source.frame_time
    from_sm = isinstance(source, StaggeredMotion)
    if from_sm:                     # resample the representation itself (exact after any edit), §5.1
        start_time = 0.0

        def rot_at(frames, joints):
            return evaluate_samples(source, frames * ft, joints)

        def root_at(frames):
            return root_positions_at(source, frames * ft)
    else:
        lq, rp = source.local_quats, source.root_positions

        def rot_at(frames, joints):
            return _read(lq, frames, joints, quat=True)

        def root_at(frames):
            return _read(rp, frames, None, quat=False)

    # static joints (one quaternion throughout) are that quaternion at every sample: not evaluated, not
    # fitted (the zero velocity is exact), their displacement maps zero
    static, const = _static_joints(source)
    if static.any():
        sample_at = rot_at

        def rot_at(frames, joints):
            mov = ~static[joints]
            out = np.empty((joints.size, 4))
            out[~mov] = const[joints[~mov]]
            if mov.any():
                out[mov] = sample_at(frames[mov], joints[mov])
            return out

    # rotations: every (segment, joint) pair at once
    pair, m, counts, tn, frames = sample_segments(knots, ft, start_time, oversample)
    P = counts.size
    joint = pair % J
    N = pair.size
    edit_frames, edit_joints = np.repeat((pose_times - start_time) / ft, J), np.tile(np.arange(J), K)
    if from_sm:                     # one evaluation for the samples and the editing knots
        both = rot_at(np.concatenate([frames, edit_frames]), np.concatenate([joint, edit_joints]))
        targets, editing = both[:N], both[N:].reshape(K, J, 4)
        del both
        targets = _continuous_per_joint(targets, joint, pair // J, m)
        ends = np.concatenate([np.flatnonzero(m == 0), np.cumsum(counts)[P - J:] - 1])
        values = targets[ends].reshape(K, J, 4)
    else:
        targets = rot_at(frames, joint)
        kf = (knots - start_time) / ft
        values = rot_at(kf.reshape(-1), np.tile(np.arange(J), K)).reshape(K, J, 4)
    v0 = values[:-1].reshape(P, 4)
    v3 = values[1:].reshape(P, 4)
    # the first and last sample of each pair are the knots themselves: use them bit-for-bit
    first = m == 0
    last = m == counts[pair] - 1
    targets[first] = v0[pair[first]]
    targets[last] = v3[pair[last]]
    if int(oversample) < 1:
        raise ValueError(f"fit_staggered: oversample must be an integer >= 1, got {oversample!r}")
    if continuity not in ("C0", "C1"):
        raise ValueError(f"fit_staggered: continuity must be 'C0' or 'C1', got {continuity!r}")
    if fit_samples is not None and not (isinstance(fit_samples, (int, np.integer)) and fit_samples >= 4):
        raise ValueError(f"fit_staggered: fit_samples must be an integer >= 4 or None, got {fit_samples!r}")
    report = progress if progress is not None else (lambda f: None)
    report(0.1)
    sub = _fit_mask(fit_subset(m, counts, pair, fit_samples), first, last, ~static[joint])
    tn_f, targets_f, pair_f = tn[sub], targets[sub], pair[sub]
    if continuity == "C1":
        start, _ = fit_rotation_tangents(tn_f, targets_f, pair_f, v0, v3, P, 0)
        report(0.3)
        omega = velocities_from_tangents(values, start.reshape(K - 1, J, 2, 4), knots)
        omega, tangents, cost = fit_rotation_tangents_c1(tn_f, targets_f, pair_f, values, knots, omega, iterations)
    else:
        tangents, cost = fit_rotation_tangents(tn_f, targets_f, pair_f, v0, v3, P, iterations)
    report(0.7)
    del tn_f, targets_f, pair_f
    tangents = _pin_static(tangents, static, const)
    mov = ~static[joint] if static.any() else slice(None)
    pm = pair[mov]
    s = _kernels.spline_into(np.ascontiguousarray(v0.T), np.ascontiguousarray(tangents[:, 0].T),
                             np.ascontiguousarray(tangents[:, 1].T), np.ascontiguousarray(v3.T), pm,
                             np.ascontiguousarray(tn[mov]), np.empty((4, pm.size))).T
    if static.any():
        disp = np.zeros((N, 3))
        disp[mov] = displacement_rotvecs(s, targets[mov], pm)
    else:
        disp = displacement_rotvecs(s, targets, pair)
    del s, pm
    report(0.9)
    M = int(counts.max())
    table = np.zeros((P, M, 3))
    table[pair, m] = disp

    rk = (pose_times + rr)[:, None]
    root_values, rtan, rtable, rcounts = _fit_root(root_at, rk[:, 0], ft, start_time, oversample, continuity)

    if not from_sm:
        editing = rot_at(edit_frames, edit_joints).reshape(K, J, 4)
    editing = np.where((refinements != 0)[..., None], editing, values)

    # passed through on absolute time (a source not starting at 0 s: the caller passes its own)
    lt = source.local_translations if (from_sm or start_time == 0.0) else None
    tt = None
    if lt is not None:           # source times of the animated translations at the root-translation knots
        tt = translation_source_times(source, rk[:, 0]) if from_sm else rk[:, 0]
    angles = np.linalg.norm(disp, axis=1)
    angles = np.minimum(angles, 2.0 * np.pi - angles)             # unwrapped rotvecs: the rotation's angle
    inner_mask = ~(first | last)
    meta = dict(metadata or {})
    meta["fit"] = _fit_stats(angles, inner_mask, iterations, continuity)
    out = StaggeredMotion(
        skeleton=source.skeleton, frame_time=ft, pose_times=pose_times, refinements=refinements,
        values=values, tangents=tangents.reshape(K - 1, J, 2, 4),
        displacements=table.reshape(K - 1, J, M, 3), displacement_counts=counts.reshape(K - 1, J),
        root_values=root_values, root_refinements=rr, root_tangents=rtan,
        root_displacements=rtable, root_displacement_counts=rcounts,
        editing_knots=editing, pose_probability=np.ones(K) if pose_probability is None else pose_probability,
        contacts=tuple(contacts), local_translations=lt, translation_times=tt, metadata=meta)
    report(1.0)
    return out


def refit_merged(sm: StaggeredMotion, keep, *, iterations: int = 2, continuity: str = "C1",
                 fit_samples: int | None = 12, metadata: dict | None = None, progress=None):
    """The refit of :func:`~.extraction.cull` done locally: only segments that merge removed poses change.

    ``keep (K',)`` sorted pose indices of ``sm`` (first and last included). A kept segment between two
    consecutive poses of ``sm`` keeps its spline controls and displacement map verbatim. The merged
    segments (``keep[i + 1] - keep[i] > 1``) are fitted to ``sm`` itself (samples at the frames, as
    :func:`fit_staggered` with a StaggeredMotion source), with their displacement maps re-measured.

    Continuity: "C0" fits are per segment, so the result equals a full refit up to rounding. "C1" couples
    all knots of a joint through one angular velocity per knot (:func:`fit_rotation_tangents_c1`); here each
    run of consecutive merged segments is refitted with the velocities at its end knots fixed to those of
    the adjacent kept segments (so the splines stay C1 across the joins), its inner knots free. The full refit
    instead also moves the velocities of knots away from the removed poses (its Levenberg–Marquardt step is
    global per joint); the two differ by what those steps move, which the displacement maps absorb:
    both reproduce ``sm`` exactly at the frames.

    The root translation is refitted whole (cheap, and then identical to the full refit).

    Returns the new StaggeredMotion, or None when the local refit does not apply or does not pay (the
    refitted segments span more than 60 % of the clip: measured as fast as the full refit there; knots off the frame grid,
    ``sm`` fitted with other options or other displacement sampling, a knot value of opposite sign to the
    samples beside it); the caller then refits fully.
    """
    keep = np.asarray(keep, dtype=np.int64)
    fit = sm.metadata.get("fit") or {}
    if fit.get("continuity") != continuity or fit.get("iterations") != iterations or keep.size < 2:
        return None
    J, ft, Kc = sm.num_joints, sm.frame_time, keep.size
    report = progress if progress is not None else (lambda f: None)
    old_knots = sm.pose_times[:, None] + sm.refinements
    merged = np.diff(keep) > 1                                          # (Kc - 1,) merged segments
    # refitted: the merged segments and one kept segment on each side, so the velocities at the merged
    # segments' ends are free (a velocity fitted over a short segment does not suit a long one) and the
    # fixed ones sit at the far ends of short kept segments
    changed = merged.copy()
    changed[1:] |= merged[:-1]
    changed[:-1] |= merged[1:]
    unch = np.flatnonzero(~changed)
    span = np.diff(sm.pose_times[keep])
    if span[changed].sum() > _LOCAL_MAX_SHARE * span.sum():
        return None                                    # most of the clip changes: the full refit is as fast
    if np.any(sm.displacement_counts[keep[unch]]
              != np.maximum(np.rint(np.diff(old_knots, axis=0)[keep[unch]] / ft).astype(np.int64) + 1, 2)):
        return None                                    # kept segments sampled otherwise (oversampled fits)
    tk = sm.pose_times[keep]
    knots = tk[:, None] + sm.refinements[keep]
    values = sm.values[keep]
    tangents = np.array(sm.tangents[keep[:-1]])
    counts = np.array(sm.displacement_counts[keep[:-1]])
    ci = np.flatnonzero(changed)
    sel = np.unique(np.concatenate([ci, ci + 1]))                       # knots touching a merged segment
    Ks = sel.size
    real = (np.diff(sel) == 1) & changed[sel[:-1]]                      # sub-segments that are merged ones
    # a knot bordering a kept segment keeps that segment's velocity (C1); others are free
    out_kept = (sel < Kc - 1) & ~changed[np.minimum(sel, Kc - 2)]
    in_kept = (sel > 0) & ~changed[np.maximum(sel - 1, 0)]
    fixed = out_kept | in_kept
    ks, vs = knots[sel], values[sel]
    P = (Ks - 1) * J
    pair, m, cnt, tn, frames = sample_segments(ks, ft, 0.0, 1)
    seg = pair // J
    last = m == cnt[pair] - 1
    use = real[seg] | (m == 0) | last              # sub-segments between two fixed knots: ends only
    pair, m, tn, frames, last = pair[use], m[use], tn[use], frames[use], last[use]
    seg = pair // J
    m = np.where(real[seg] | (m == 0), m, 1)
    cnt = np.where(np.repeat(real, J), cnt, 2)
    v0, v3 = vs[:-1].reshape(P, 4), vs[1:].reshape(P, 4)
    first = m == 0
    inner = real[seg] & ~first & ~last
    targets = np.empty((pair.size, 4))
    targets[inner] = evaluate_samples(sm, frames[inner] * ft, pair[inner] % J)
    targets[first] = v0[pair[first]]
    targets[last] = v3[pair[last]]
    cont = _continuous_per_pair(targets, first)
    if np.any((np.sum(cont[last] * targets[last], axis=1) < 0) & real[seg[last]]):
        return None                                    # a knot value on the other sign of its samples
    targets = np.where(real[seg][:, None], cont, targets)
    report(0.2)
    sub = _fit_mask(fit_subset(m, cnt, pair, fit_samples), first, last, ~_static_joints(sm)[0][pair % J])
    tn_f, targets_f, pair_f = tn[sub], targets[sub], pair[sub]
    if continuity == "C1":
        start, _ = fit_rotation_tangents(tn_f, targets_f, pair_f, v0, v3, P, 0)
        omega = velocities_from_tangents(vs, start.reshape(Ks - 1, J, 2, 4), ks)
        d_old = np.diff(old_knots, axis=0)[..., None]
        ko, ki = keep[sel[out_kept]], keep[sel[in_kept]] - 1            # the kept segments of sm beside them
        omega[out_kept] = 3.0 * _rotvec_between(sm.values[ko].reshape(-1, 4), sm.tangents[ko, :, 0].reshape(-1, 4)
                                                ).reshape(-1, J, 3) / d_old[ko]
        omega[in_kept & ~out_kept] = (3.0 * _rotvec_between(sm.tangents[ki, :, 1].reshape(-1, 4),
                                                            sm.values[ki + 1].reshape(-1, 4)).reshape(-1, J, 3)
                                      / d_old[ki])[~out_kept[in_kept]]
        _, tg, _ = fit_rotation_tangents_c1(tn_f, targets_f, pair_f, vs, ks, omega, iterations, fixed=fixed)
    else:
        tg, _ = fit_rotation_tangents(tn_f, targets_f, pair_f, v0, v3, P, iterations)
    report(0.7)
    # merged segments: new controls and displacement maps
    rs = np.repeat(real, J)[pair]
    rp = pair[rs]
    s = _kernels.spline_into(np.ascontiguousarray(v0[rp].T), np.ascontiguousarray(tg[rp, 0].T),
                             np.ascontiguousarray(tg[rp, 1].T), np.ascontiguousarray(v3[rp].T),
                             np.arange(rp.size), np.ascontiguousarray(tn[rs]), np.empty((4, rp.size))).T
    disp = displacement_rotvecs(s, targets[rs], rp)
    dest = sel[:-1][real]                                               # culled segment of each real one
    tangents[dest] = _pin_static(tg, *_static_joints(sm)).reshape(Ks - 1, J, 2, 4)[real]
    counts[dest] = cnt.reshape(Ks - 1, J)[real]
    M = int(counts.max())
    table = np.zeros((Kc - 1, J, M, 3))
    Mo = min(M, sm.displacements.shape[2])
    table[unch, :, :Mo] = sm.displacements[keep[unch], :, :Mo]
    seg_c = sel[rp // J]
    table[seg_c, rp % J, m[rs]] = disp
    # residual statistics over every sample (kept segments from their stored maps)
    idx = np.arange(M)
    valid = idx < counts[..., None]
    ang = np.linalg.norm(table, axis=-1)
    ang = np.minimum(ang, 2.0 * np.pi - ang)
    inner_t = valid & (idx > 0) & (idx < counts[..., None] - 1)
    meta = dict(metadata or {})
    meta["fit"] = _fit_stats(ang[valid], inner_t[valid], iterations, continuity)
    rr = sm.root_refinements[keep]
    rk = tk + rr
    root_values, rtan, rtable, rcounts = _fit_root(lambda f: root_positions_at(sm, f * ft), rk, ft, 0.0, 1,
                                                   continuity)
    lt = sm.local_translations
    out = StaggeredMotion(
        skeleton=sm.skeleton, frame_time=ft, pose_times=tk, refinements=sm.refinements[keep], values=values,
        tangents=tangents, displacements=table, displacement_counts=counts,
        root_values=root_values, root_refinements=rr, root_tangents=rtan,
        root_displacements=rtable, root_displacement_counts=rcounts,
        editing_knots=sm.editing_knots[keep], pose_probability=sm.pose_probability[keep],
        contacts=tuple(sm.contacts), local_translations=lt,
        translation_times=None if lt is None else translation_source_times(sm, rk), metadata=meta)
    report(1.0)
    return out
