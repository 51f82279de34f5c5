"""C1 quaternion Bézier fits (Coleman et al. 2008, Appendix A, under a continuity constraint): one body angular
velocity per knot shared by both adjacent segments (:func:`fit_rotation_tangents_c1`), the C1 matching of given
splines (:func:`match_tangents`), and the velocities and their jumps at the knots.
"""
from __future__ import annotations

import numpy as np

from ..core.rotations import quat_exp, quat_mul, quat_normalize
from . import _kernels as K
from .representation import StaggeredMotion
from .rotation_fit import _FD_STEP, _rotvec_between

__all__ = ["fit_rotation_tangents_c1", "match_tangents", "velocities_from_tangents", "velocity_jumps"]


_FD_BATCH = 1 << 18   # fits with at most this many samples x 6 take their finite differences in one kernel call


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
