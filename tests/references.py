"""Slow, straightforward reference implementations, for tests and benchmarks only (they live beside the tests
that check the fast code against them, not in the package).

Each is written "in the most straightforward manner" (per joint, one formula at a time, core helpers or scipy)
so that the vectorised code can be compared with it. Benchmarks import this module from ``tests/``.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from stagger_nb.core.motion import Motion
from stagger_nb.core.rotations import quat_bezier, quat_mul, quat_normalize, rotvec_to_quat, slerp
from stagger_nb.staggered.representation import StaggeredMotion, knot_times

__all__ = ["forward_kinematics_reference", "evaluate_reference", "fit_rotation_tangents_nelder_mead",
           "plateau_weights_reference"]


def forward_kinematics_reference(motion: Motion):
    """World positions ``(F, J, 3)`` and world rotation matrices ``(F, J, 3, 3)`` of ``motion``.

    For each joint ``j``: ``T_j = [[R(q_j), t_j], [0, 1]]`` with ``R`` from scipy, ``t_j`` the joint's
    translation in its parent's frame (the root's: its world position), and
    ``W_j = W_parent(j) @ T_j``; the position is ``W_j[:3, 3]``.
    """
    F, J = motion.num_frames, motion.num_joints
    trans = motion.translations()
    world = np.empty((F, J, 4, 4))
    for j in range(J):
        T = np.zeros((F, 4, 4))
        T[:, :3, :3] = Rotation.from_quat(motion.local_quats[:, j]).as_matrix()
        T[:, :3, 3] = trans[:, j]
        T[:, 3, 3] = 1.0
        p = motion.skeleton.parents[j]
        world[:, j] = T if p < 0 else world[:, p] @ T
    return world[:, :, :3, 3].copy(), world[:, :, :3, :3].copy()


def evaluate_reference(sm: StaggeredMotion, times) -> np.ndarray:
    """``staggered.evaluate_arrays``' rotations computed in the most straightforward manner (per joint: segment by
    searchsorted, :func:`~stagger_nb.core.rotations.quat_bezier`, linear rotation-vector displacement --
    on the quaternions (normalised lerp) for a segment whose displacement turns more than pi somewhere --,
    ``quat_mul``). Slow; a reference for tests and benchmarks. Returns ``(N, J, 4)``."""
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
        d0, d1 = sm.displacements[seg, i, m0], sm.displacements[seg, i, m0 + 1]
        e = rotvec_to_quat(d0 * (1 - f) + d1 * f)
        wide = (np.linalg.norm(sm.displacements[seg, i], axis=-1) > np.pi).any(axis=-1)
        for r in np.flatnonzero(wide):
            q0, q1 = rotvec_to_quat(d0[r]), rotvec_to_quat(d1[r])
            q1 = -q1 if np.dot(q0, q1) < 0 else q1
            e[r] = quat_normalize(q0 * (1 - f[r]) + q1 * f[r])
        out[:, i] = quat_mul(s, e)
    return out


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


def plateau_weights_reference(knots: np.ndarray, tk: np.ndarray, k: np.ndarray, col: np.ndarray, t: np.ndarray,
                     side: np.ndarray) -> np.ndarray:
    """Weight ``(N,)`` of pose ``k`` at time ``t`` for control variable ``col`` of ``knots (K, C)`` on
    ``side`` (-1: t is before pose k's knot, in segment k-1; +1: after, in segment k): 1 on the plateau
    between ``t_k`` and ``T[k, col]``, a raised cosine down to 0 at the neighbouring pose's plateau edge (per
    sample, numpy's cos: the reference of ``geometry._pair_plateau_weights``)."""
    T = np.maximum.accumulate(knots, axis=0)
    lo = np.minimum(tk[:, None], T)          # plateau [lo, hi] of every (pose, column)
    hi = np.maximum(tk[:, None], T)
    kn = np.clip(k + side, 0, T.shape[0] - 1)
    inner = np.where(side < 0, hi[kn, col], lo[kn, col])   # where the ramp reaches 0
    outer = np.where(side < 0, lo[k, col], hi[k, col])     # where the ramp reaches 1
    L = outer - inner
    u = np.where(np.abs(L) > 0, (t - inner) / np.where(np.abs(L) > 0, L, 1.0), 1.0)
    u = np.clip(u, 0.0, 1.0)
    w = 0.5 * (1.0 - np.cos(np.pi * u))
    on_plateau = (t >= lo[k, col]) & (t <= hi[k, col])
    return np.where(on_plateau, 1.0, w)
