"""Analytic leg (two-bone limb) IK for the contact layer (:mod:`stagger_nb.staggered.plants`): the knee turns about
its hinge (measured on the source) by the exact angle that gives the wanted hip-ankle distance, on the
forward-bent branch (no knee flip, never beyond full extension); the hip then aims the leg by the shortest arc.
"""
from __future__ import annotations

import numpy as np

from ..core.kinematics import _fk_component_major
from ..core.motion import Motion
from ..core.rotations import (
    quat_angle,
    quat_between_vectors,
    quat_conj,
    quat_mul,
    quat_rotate,
    quat_to_rotvec,
    rotvec_to_quat,
)
from .contacts import chain_subset
from .limbs import Limb


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def _leg_ik(a, b, c, t, hinge, d_max, soft=None, max_back=np.pi, groups=None):
    """Analytic two-bone IK, vectorised over rows.

    The middle joint turns about its hinge axis ``hinge`` (world, unit; the knee's bend axis measured on the
    source, so the knee bends the way it bends and never flips sideways or backwards) by the exact angle that
    puts the effector at the wanted distance from the upper joint; the upper joint then aims the limb at the
    target by the shortest arc (no twist). Of the two angles that give the distance, the forward-bent one,
    except where the current pose is bent backwards about the hinge and the target asks for no more bend
    than it has (then the one nearer the current pose: an unedited pose is left as it is) and its backward bend
    is one the source itself makes (at most ``max_back``): a pose an edit bent backwards beyond the source's own
    hyperextension (an exaggerated straight knee), or folded past 180° (an exaggerated deep bend, which reads as
    bent backwards), gets the forward-bent branch on every frame, so the branch never toggles between
    neighbouring frames (a knee flip: a 30-140° one-frame pop measured with exaggerated poses).

    Parameters
    ----------
    a, b, c, t : ndarray, shape (n, 3)
        Upper joint, middle joint, effector, target (world).
    hinge : ndarray, shape (n, 3)
        The middle joint's hinge axis (world, unit), oriented so a positive turn bends the limb.
    d_max : ndarray, shape (n,)
        Largest upper-effector distance allowed (below the two bones' length).
    soft : ndarray, shape (n,), optional
        Where given (> 0), distances beyond ``d_max - soft`` approach ``d_max`` exponentially (a C1 soft limit,
        used while fading in and out of a plant so a far target straightens the leg gradually).
    max_back : float or ndarray, shape (n,), radians
        The largest backward bend kept on its own branch (:func:`_source_back`: the source's own, plus a margin).
    groups : ndarray, shape (n,), optional
        The plant of each row: the backward branch is taken on all rows of a plant or none (only where each of
        its backward-bent rows is asked to stay as it is), so a held knee does not switch branch inside a plant
        (a jump of twice its backward bend, e.g. at a plant's first frame, where the target is the current
        foot).

    Returns
    -------
    r_up, r_mid : ndarray, shape (n, 4)
        World rotations to pre-multiply: the upper joint's world rotation by ``r_up``, the middle joint's by
        ``r_up * r_mid`` (``r_mid`` about the middle joint, ``r_up`` about the upper joint).
    """
    x, y = b - a, c - b
    lx, ly = np.linalg.norm(x, axis=-1), np.linalg.norm(y, axis=-1)
    k = _unit(hinge)
    d = np.linalg.norm(t - a, axis=-1)
    if soft is not None:      # soft reach: C1 approach of d_max over the last ``soft`` of it (no knee snap)
        knee = d_max - soft
        over = (soft > 0) & (d > knee)
        d = np.where(over, knee + soft * -np.expm1(-(d - knee) / np.where(soft > 0, soft, 1.0)), d)
    d = np.clip(d, np.abs(lx - ly) * (1 + 1e-9) + 1e-12, d_max)
    # rotating y about k by theta: x . R y = A + B cos(theta) + C sin(theta)
    ypar = np.einsum("ni,ni->n", y, k)[:, None] * k
    yperp = y - ypar
    A = np.einsum("ni,ni->n", x, ypar)
    B = np.einsum("ni,ni->n", x, yperp)
    C = np.einsum("ni,ni->n", x, np.cross(k, yperp))
    D = 0.5 * (d * d - lx * lx - ly * ly)
    rho = np.hypot(B, C)
    phi = np.arctan2(C, B)                     # the straightest the hinge allows; < 0 for a forward bend
    delta = np.arccos(np.clip((D - A) / np.maximum(rho, 1e-300), -1.0, 1.0))
    back = (phi > 0) & (phi <= max_back) & (delta <= phi + 1e-6)   # bent backwards as the source may be
    if groups is not None:    # each plant on one branch, unless each of its backward rows is left as it is
        back &= ~np.isin(groups, groups[back & (delta < phi - 1e-6)])
    theta = np.where(back, phi - delta, phi + delta)
    theta = np.arctan2(np.sin(theta), np.cos(theta))
    r_mid = rotvec_to_quat(k * theta[:, None])
    c1 = b + quat_rotate(r_mid, y)
    r_up = quat_between_vectors(c1 - a, t - a)
    return r_up, r_mid


def _capped(q: np.ndarray, limit: float) -> np.ndarray:
    """Rotations ``q (n, 4)`` with their angle cut to ``limit`` radians (the axis kept)."""
    v = quat_to_rotvec(q)
    a = np.linalg.norm(v, axis=-1, keepdims=True)
    return rotvec_to_quat(v * np.minimum(1.0, limit / np.maximum(a, 1e-300)))


def _pivot(off: np.ndarray, to_hip: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Toe -> ankle vectors ``off (n, 3)`` turned (length kept) towards ``to_hip (n, 3)`` (toe -> hip) by the
    least angle that brings the ankle within ``reach (n,)`` of the hip (fully towards it if even that is not
    enough); rows already in reach are returned as they are."""
    f = np.linalg.norm(off, axis=-1)
    D = np.linalg.norm(to_hip, axis=-1)
    u = to_hip / np.maximum(D, 1e-300)[:, None]
    cos0 = np.einsum("ni,ni->n", off, u) / np.maximum(f, 1e-300)
    need = np.clip((D * D + f * f - reach * reach) / np.maximum(2.0 * D * f, 1e-300), -1.0, 1.0)
    turn = cos0 < need
    if not turn.any():
        return off
    w = off - (cos0 * f)[:, None] * u
    w = _unit(w)
    sin = np.sqrt(1.0 - need * need)
    return np.where(turn[:, None], f[:, None] * (need[:, None] * u + sin[:, None] * w), off)


def _hinge_local(src_pos, src_wq, limb: Limb) -> np.ndarray:
    """The middle joint's hinge axis in the upper joint's frame ``(3,)``, measured on the source: the mean
    bend-plane normal (``(b - a) x (c - b)``, weighted by the bend) over the clip; where the source never
    bends the limb, an axis normal to the upper bone."""
    a, b, c = src_pos[:, limb.upper], src_pos[:, limb.mid], src_pos[:, limb.eff]
    n = np.cross(b - a, c - b)
    local = quat_rotate(quat_conj(src_wq[:, limb.upper]), n).sum(axis=0)
    size = np.linalg.norm(local)
    bone = quat_rotate(quat_conj(src_wq[0, limb.upper]), b[0] - a[0])
    scale = float(np.linalg.norm(b - a, axis=-1).mean() * np.linalg.norm(c - b, axis=-1).mean())
    if size > 1e-3 * scale * max(len(a), 1):
        return local / size
    other = np.array([1.0, 0.0, 0.0]) if abs(_unit(bone)[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    return _unit(np.cross(bone, other))


BACK_MARGIN = np.radians(2.0)   # backward bend kept on its own branch beyond the source's largest


def _flex(pos, wq, rows, limb: Limb, hinge_local):
    """``(bend (n,), hinge (n, 3))``: the signed bend of the limb's middle joint about its hinge (radians, > 0
    forwards, < 0 backwards) on ``rows`` of positions ``pos`` / world rotations ``wq`` ``(F, J, ...)``, and the
    hinge axis there (world)."""
    x = pos[rows, limb.mid] - pos[rows, limb.upper]
    y = pos[rows, limb.eff] - pos[rows, limb.mid]
    k = quat_rotate(wq[rows, limb.upper], hinge_local)
    return np.arctan2(np.einsum("ni,ni->n", np.cross(x, y), k), np.einsum("ni,ni->n", x, y)), k


def _source_back(src_pos, src_wq, limb: Limb, hinge_local) -> float:
    """The largest backward bend (radians, >= 0) of the limb's middle joint about its hinge in the source,
    plus :data:`BACK_MARGIN`: the hyperextension :func:`_leg_ik` keeps on the backward branch."""
    flex, _ = _flex(src_pos, src_wq, slice(None), limb, hinge_local)
    return float(max(0.0, -float(flex.min(initial=0.0)))) + BACK_MARGIN


def _solve(sk, lim: Limb, fr, pos, wq, lq, target, q_target, reach, hinge_local, soft=None, max_back=np.pi,
           groups=None):
    """New local rotations ``(upper, mid, eff)`` on frames ``fr`` (of the plants ``groups``) putting the
    effector at ``target (n, 3)`` with world rotation ``q_target (n, 4)`` (positions ``pos`` already lowered
    with the root)."""
    p3 = pos[fr][:, [lim.upper, lim.mid, lim.eff]]
    return _solve_rows(sk, lim, fr, p3, wq, lq, target, q_target, reach, hinge_local, soft, max_back, groups)


def _solve_rows(sk, lim: Limb, fr, p3, wq, lq, target, q_target, reach, hinge_local, soft=None, max_back=np.pi,
                groups=None):
    """:func:`_solve` from the chain's positions ``p3 (n, 3, 3)`` (upper, mid, eff) and the world rotations
    ``wq (F, J, 4)`` / local rotations ``lq (F, J, 4)`` of the pose being changed."""
    pm, pe = int(sk.parents[lim.mid]), int(sk.parents[lim.eff])
    upw = wq[fr, lim.upper]
    hinge = quat_rotate(upw, hinge_local)
    r_up, r_mid = _leg_ik(p3[:, 0], p3[:, 1], p3[:, 2], target, hinge, reach, soft, max_back, groups)
    a_new = quat_mul(lq[fr, lim.upper], quat_mul(quat_conj(upw), quat_mul(r_up, upw)))
    m_new = quat_mul(quat_conj(wq[fr, pm]), quat_mul(r_mid, wq[fr, lim.mid]))
    e_new = quat_mul(quat_conj(quat_mul(quat_mul(r_up, r_mid), wq[fr, pe])), q_target)
    return a_new, m_new, e_new


def _no_hyperextension(sk, motion: Motion, lim: Limb, fr, out, lq, pos, wq, hinge_local) -> None:
    """Where a fade has bent the middle joint backwards about its hinge beyond what the edit itself does
    (its displacement composed with the edit's own straightening), turn it back to that (in place on
    ``out (F, J, 4)``, frames ``fr``; ``pos`` / ``wq``: the edit's world positions and rotations)."""
    pm = int(sk.parents[lim.mid])

    # only where the edit's own bend is smaller than the fade's turn of the knee can the sum bend backwards
    f_e, _ = _flex(pos, wq, fr, lim, hinge_local)
    turned = quat_angle(lq[fr, lim.mid], out[fr, lim.mid]) + quat_angle(lq[fr, lim.upper], out[fr, lim.upper])
    maybe = f_e < turned + 1e-6
    if not maybe.any():
        return
    fr, f_e = fr[maybe], f_e[maybe]
    p_o, w_o = _fk_rows(motion, {lim.upper, lim.mid, lim.eff, pm}, fr, out)
    f_o, k = _flex(p_o, w_o, slice(None), lim, hinge_local)
    excess = np.minimum(f_e, 0.0) - f_o                  # > 0: more backwards than the edit
    bad = excess > 1e-9
    if not bad.any():
        return
    turn = rotvec_to_quat(k[bad] * excess[bad, None])
    out[fr[bad], lim.mid] = quat_mul(quat_conj(w_o[bad, pm]), quat_mul(turn, w_o[bad, lim.mid]))


def _fk_rows(motion: Motion, joints, frames, local_quats):
    """World positions ``(n, J, 3)`` and rotations ``(n, J, 4)`` of ``joints`` (and ancestors; NaN elsewhere)
    on ``frames (n,)`` only, with the local rotations ``local_quats (F, J, 4)``."""
    sub, sub_par, _ = chain_subset(motion.skeleton.parents, joints)
    n = len(frames)
    Q = np.ascontiguousarray(local_quats[frames][:, sub].transpose(2, 1, 0))                   # (4, s, n)
    lt = motion.local_translations
    T = (motion.skeleton.offsets[sub].T[:, :, None] if lt is None
         else np.ascontiguousarray(lt[frames][:, sub].transpose(2, 1, 0)))
    W, P = _fk_component_major(Q, T, np.ascontiguousarray(motion.root_positions[frames].T), sub_par)
    pos = np.full((n, motion.num_joints, 3), np.nan)
    wq = np.full((n, motion.num_joints, 4), np.nan)
    pos[:, sub] = P.transpose(2, 1, 0)
    wq[:, sub] = W.transpose(2, 1, 0)
    return pos, wq


