"""Inverse kinematics: the analytic two-bone solver (:func:`two_bone_ik`, also the constraint layer's) and IK
posing of a staggered pose: move an end effector to a world target at pose k's time, recorded as a geometric
pose edit (Coleman et al. 2008, §5.1; issue 11 item 7).

The limb is solved on the pose the motion passes through at ``t_k`` (the editing knots ``v⁰_k``): a
two-bone chain (upper joint, middle joint, effector: shoulder-elbow-wrist, hip-knee-ankle) analytically,
keeping the bend plane so the elbow/knee keeps pointing where it pointed; a longer chain by damped least
squares. The new local rotations become an :func:`~stagger_nb.staggered.geometry.edit_pose` in staggered
mode (``v̂⁰ = target``, the extreme knots get the same change, §5.1 first approach), so the edit is part of
the staggered pose: succession and random timing applied afterwards move it with the pose's timing.

Units: positions in the clip's file units; up axis irrelevant (no ground is assumed).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.kinematics import forward_kinematics, skeleton_height
from ..core.rotations import quat_conj, quat_exp, quat_mul, quat_rotate, rotvec_to_quat
from ._checks import _finite, _pose_index, _pose_weights
from .evaluation import evaluate
from .geometry import _apply_pose_offsets, edit_pose, spread_offsets
from .limbs import _limb
from .representation import StaggeredMotion

__all__ = ["IKPoseResult", "ik_pose", "solve_limb", "two_bone_ik"]

_DLS_DAMPING = 0.05     # damping λ of the least-squares steps, as a fraction of the chain length
_DLS_MAX_STEP = 0.1     # largest effector move asked of one step, fraction of the chain length
_DLS_ITERATIONS = 200   # per round; a reachable target converges in ~20-40 (each a 3x3 solve)
_ROUNDS = 4             # solve, record, re-evaluate: the recorded edit is exact on the displacement grid only


_EPS_LEN = 1e-6  # keeps the IK triangle strictly non-degenerate (file units; far below any bone length)


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0), n[..., 0]


def _angle_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.arccos(np.clip(np.sum(_unit(u)[0] * _unit(v)[0], axis=-1), -1.0, 1.0))


def two_bone_ik(a, b, c, target, a_world, b_world, a_local, fallback_axis=None, b_parent_world=None):
    """Analytic two-bone IK, vectorised over N samples.

    Rotates the upper joint ``a`` and the middle joint ``b`` so that the effector ``c`` reaches
    ``target`` (clamped to the reachable annulus ``|l_ab - l_bc| < d < l_ab + l_bc``). The bend stays in
    the current a-b-c plane (the knee keeps pointing where it pointed).

    Parameters
    ----------
    a, b, c, target : ndarray, shape (N, 3)
        World positions of the upper joint, middle joint, effector, and the effector's target.
    a_world, b_world : ndarray, shape (N, 4), (x, y, z, w)
        World rotations of the upper and middle joints.
    a_local : ndarray, shape (N, 4)
        Local rotation of the upper joint (relative to its parent).
    fallback_axis : ndarray, shape (N, 3), optional
        Bend axis used where the chain is exactly straight (no bend plane); default: the middle
        joint's local x axis in world space (the knee/elbow hinge in common BVH rigs).
    b_parent_world : ndarray, shape (N, 4), optional
        World rotation of the middle joint's parent when that is not the upper joint (zero-length bones
        in between, which move rigidly with the upper joint); default ``a_world``.

    Returns
    -------
    a_local_new, b_local_new : ndarray, shape (N, 4)
        New local rotations of the upper and middle joints.
    b_world_new : ndarray, shape (N, 4)
        New world rotation of the middle joint (to re-express the effector's local rotation).
    """
    a, b, c, t = (np.asarray(x, dtype=float) for x in (a, b, c, target))
    lab = np.linalg.norm(b - a, axis=-1)
    lbc = np.linalg.norm(c - b, axis=-1)
    lat = np.clip(np.linalg.norm(t - a, axis=-1), np.abs(lab - lbc) + _EPS_LEN, lab + lbc - _EPS_LEN)

    ac_ab_0 = _angle_between(c - a, b - a)
    ba_bc_0 = _angle_between(a - b, c - b)
    ac_at_0 = _angle_between(c - a, t - a)
    # law of cosines for the wanted triangle
    ac_ab_1 = np.arccos(np.clip((lbc ** 2 - lab ** 2 - lat ** 2) / (-2.0 * lab * lat), -1.0, 1.0))
    ba_bc_1 = np.arccos(np.clip((lat ** 2 - lab ** 2 - lbc ** 2) / (-2.0 * lab * lbc), -1.0, 1.0))

    axis0, n0 = _unit(np.cross(c - a, b - a))
    straight = n0 < 1e-9
    if np.any(straight):   # the fallback axis only where it is used (the same values there)
        s_ = np.flatnonzero(straight)
        fb = (quat_rotate(np.asarray(b_world, dtype=float)[s_], np.array([1.0, 0.0, 0.0])) if fallback_axis is None
              else np.broadcast_to(np.asarray(fallback_axis, dtype=float), axis0.shape)[s_])
        axis0 = np.array(axis0)
        axis0[s_] = _unit(fb)[0]
    axis1, n1 = _unit(np.cross(c - a, t - a))
    axis1 = np.where((n1 < 1e-12)[:, None], axis0, axis1)  # c-a already points at t: no swing needed

    r0 = rotvec_to_quat(axis0 * (ac_ab_1 - ac_ab_0)[:, None])   # swing the upper bone about a
    r1 = rotvec_to_quat(axis0 * (ba_bc_1 - ba_bc_0)[:, None])   # open/close the middle joint
    r2 = rotvec_to_quat(axis1 * ac_at_0[:, None])               # aim a->c at the target
    r20 = quat_mul(r2, r0)
    a_world_new = quat_mul(r20, a_world)
    b_world_new = quat_mul(r20, quat_mul(r1, b_world))
    a_local_new = quat_mul(a_local, quat_mul(quat_conj(a_world), a_world_new))
    if b_parent_world is None:
        b_parent_new = a_world_new
    else:
        b_parent_new = quat_mul(a_world_new, quat_mul(quat_conj(a_world), b_parent_world))
    b_local_new = quat_mul(quat_conj(b_parent_new), b_world_new)
    return a_local_new, b_local_new, b_world_new


@dataclass(frozen=True)
class IKPoseResult:
    """Result of :func:`ik_pose`.

    Attributes
    ----------
    staggered : StaggeredMotion
        The motion with the pose edit recorded (the input itself when nothing had to move).
    reached : bool
        The effector is within ``tolerance`` of the target at ``t_k``.
    error : float
        Distance left between the effector at ``t_k`` and the target, file units.
    message : str
        '' when reached; otherwise one plain sentence saying why (out of reach) and what happened.
    """

    staggered: StaggeredMotion
    reached: bool
    error: float
    message: str


def solve_limb(positions, world_quats, local_quats, parents, chain, target, *, damping=None,
               iterations: int = _DLS_ITERATIONS, tolerance: float = 0.0):
    """New local rotations of a chain so that its last joint reaches ``target`` (one pose).

    Parameters
    ----------
    positions, world_quats : ndarray, shape (J, 3), (J, 4)
        World positions and rotations of the pose (forward kinematics).
    local_quats : ndarray, shape (J, 4), (x, y, z, w)
    parents : ndarray, shape (J,)
    chain : list of int
        Joints from the upper joint down to the effector (the effector last; at least 3). Three joints
        with parent links (``chain[1]`` below ``chain[0]``): analytic two-bone IK with the bend plane
        kept (:func:`two_bone_ik`; zero-length bones in between are
        allowed). More: damped least squares on the rotations of ``chain[:-1]``.
    target : ndarray, shape (3,)

    Returns
    -------
    dict {joint index: new local rotation (4,)} for the chain joints that rotate.
    """
    p, wq, lq = (np.asarray(x, dtype=float) for x in (positions, world_quats, local_quats))
    target = np.asarray(target, dtype=float)
    if len(chain) == 3:
        up, mid, eff = chain
        pm = parents[mid]
        a_new, b_new, b_world = two_bone_ik(p[[up]], p[[mid]], p[[eff]], target[None], wq[[up]], wq[[mid]],
                                            lq[[up]], b_parent_world=None if pm == up else wq[[pm]])
        # the effector keeps its world orientation (a hand or foot is not twisted by moving the limb)
        c_new = quat_mul(quat_conj(b_world), wq[[eff]])
        return {up: a_new[0], mid: b_new[0], eff: c_new[0]}
    joints = list(chain[:-1])
    eff = chain[-1]
    length = sum(np.linalg.norm(p[b] - p[a]) for a, b in zip(chain[:-1], chain[1:]))
    lam = (_DLS_DAMPING if damping is None else float(damping)) * max(length, 1e-12)
    q = lq.copy()
    moved = False
    for _ in range(iterations):
        P, W = _chain_fk(p, wq, lq, q, parents, chain)
        err = target - P[eff]
        if np.linalg.norm(err) <= tolerance:
            break
        # d(effector) / d(world rotation vector of joint i) = -[e - p_i]x
        Jm = np.zeros((3, 3 * len(joints)))
        for n, j in enumerate(joints):
            r = P[eff] - P[j]
            Jm[:, 3 * n:3 * n + 3] = -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        n_err = np.linalg.norm(err)
        if n_err > _DLS_MAX_STEP * length:        # clamped target error (Buss & Kim 2005): no overshoot
            err = err * (_DLS_MAX_STEP * length / n_err)
        step = Jm.T @ np.linalg.solve(Jm @ Jm.T + lam ** 2 * np.eye(3), err)
        for n, j in enumerate(joints):
            dw = quat_exp(0.5 * step[3 * n:3 * n + 3])                  # world-frame rotation
            qj = quat_mul(q[j], quat_mul(quat_conj(W[j]), quat_mul(dw, W[j])))
            q[j] = qj / np.linalg.norm(qj)                               # no drift off the unit sphere
        moved = True
    if not moved:
        return {}
    P, W = _chain_fk(p, wq, lq, q, parents, chain)
    out = {j: q[j] for j in joints}
    out[eff] = quat_mul(quat_conj(W[parents[eff]]), wq[eff])     # the effector keeps its world orientation
    return out


def _chain_fk(p, wq, lq, q, parents, chain):
    """World positions/rotations of the chain joints (dicts) after replacing local rotations by ``q``; joints
    above ``chain[0]`` keep ``p``/``wq``; bone vectors come from the current pose (so animated translations
    are respected)."""
    P, W = {}, {}
    top = chain[0]
    P[top] = p[top]
    W[top] = quat_mul(wq[parents[top]], q[top]) if parents[top] >= 0 else q[top]
    for j in _path(parents, chain):
        if j == top:
            continue
        pj = parents[j]
        local_off = quat_rotate(quat_conj(wq[pj]), p[j] - p[pj])        # bone in the parent's frame
        P[j] = P[pj] + quat_rotate(W[pj], local_off)
        W[j] = quat_mul(W[pj], q[j])
    return P, W


def _path(parents, chain):
    """Every joint from ``chain[0]`` down to ``chain[-1]`` (including zero-length ones), top first."""
    out = [chain[-1]]
    while out[-1] != chain[0]:
        out.append(int(parents[out[-1]]))
    return out[::-1]


def _parse_chain(sm: StaggeredMotion, joint, chain):
    sk = sm.skeleton
    try:
        eff = sk.index(joint) if isinstance(joint, str) else int(joint)
    except KeyError as e:
        raise ValueError(f"joint: {e.args[0]}") from None
    if not 0 <= eff < sk.num_joints:
        raise ValueError(f"joint: index {joint} outside [0, {sk.num_joints})")
    if chain is None or isinstance(chain, (int, np.integer)) and int(chain) == 2:
        up, mid, e = _limb(sk, eff)
        if up < 0:
            raise ValueError(f"joint: {sk.names[eff]!r} has no two-bone limb below the root")
        return [up, mid, e]
    if isinstance(chain, (int, np.integer)):        # number of bones: the effector's ancestors
        n = int(chain)
        if n < 2:
            raise ValueError(f"chain must be >= 2 bones, got {chain}")
        out = [eff]
        for _ in range(n):
            pj = int(sk.parents[out[-1]])
            if pj < 0:
                raise ValueError(f"chain: {sk.names[eff]!r} has fewer than {n} bones above it")
            out.append(pj)
        return out[::-1]
    names = [sk.index(c) if isinstance(c, str) else int(c) for c in chain]
    if names[-1] != eff:
        names.append(eff)
    for a, b in zip(names[:-1], names[1:]):
        x = b
        while x >= 0 and x != a:
            x = int(sk.parents[x])
        if x != a:
            raise ValueError(f"chain: {sk.names[a]!r} is not an ancestor of {sk.names[b]!r}")
    if len(names) < 3:
        raise ValueError("chain needs at least an upper joint, a middle joint and the effector")
    return names


def ik_pose(sm: StaggeredMotion, pose, joint, target, *, chain=None, tolerance: float | None = None,
            damping: float | None = None, weights=None) -> IKPoseResult:
    """Move an end effector to a world ``target`` at pose ``pose``'s time and record it as a pose edit.

    Parameters
    ----------
    sm : StaggeredMotion
    pose : int
        Pose index k; the target is met at ``t_k = sm.pose_times[k]``.
    joint : str or int
        The effector (a hand, a foot, any joint with two bones above it).
    target : array_like (3,), file units, world frame
    chain : None, int or list of joint names, optional
        None (default): the two-bone limb above ``joint`` (zero-length bones skipped), solved analytically
        with the knee/elbow's bend plane kept. An int n: the n bones above the effector, damped least
        squares (n = 2 is the two-bone solve). A list: those joints, top first (each an ancestor of the
        next), three joints -> two-bone, more -> damped least squares.
    tolerance : float, file units, optional
        Distance at which the target counts as reached; default ``1e-4 * skeleton height`` (0.17 mm on a
        1.7 m body in cm, 0.14 mm on a CMU skeleton).
    damping : float, optional
        Damped least squares λ as a fraction of the chain length (default 0.05); unused by two-bone.
    weights : array_like (K,), optional
        Propagate the limb's change to the other poses: pose ``j != k`` gets ``exp(weights[j] log δ)`` of the
        offset ``δ = v_k⁻¹ v̂_k`` the solve gave each limb joint at pose ``k``, in its own knots (as
        :func:`~.geometry.edit_pose` with ``weights``; ``weights[k]`` is not read: pose ``k`` keeps its solve). The
        effectors of the other poses move with their limbs, they are not solved for the target.

    Returns
    -------
    IKPoseResult(staggered, reached, error, message). An unreachable target (beyond the stretched limb,
    or nearer the upper joint than the folded limb allows) is approached as far as the limb goes (the
    nearest reachable point in the target's direction) and ``message`` says so.
    """
    if not isinstance(sm, StaggeredMotion):
        raise ValueError(f"sm must be a StaggeredMotion, got {type(sm).__name__}")
    k = _pose_index(sm, pose, "pose")
    spread = _pose_weights(sm, weights)
    tgt = np.asarray(target, dtype=float).reshape(-1)
    if tgt.shape != (3,) or not np.all(np.isfinite(tgt)):
        raise ValueError(f"target must be 3 finite numbers (world x, y, z), got {target!r}")
    ch = _parse_chain(sm, joint, chain)
    tk = float(sm.pose_times[k])
    tol = 1e-4 * skeleton_height(evaluate(sm, [tk])) if tolerance is None else _finite(tolerance, "tolerance")
    if tol <= 0:
        raise ValueError(f"tolerance must be > 0, got {tol}")
    parents = np.asarray(sm.skeleton.parents)
    eff = ch[-1]                     # the requested joint, or the joint it sits on (zero-length bone)
    names = sm.skeleton.names

    def miss(motion):
        return float(np.linalg.norm(forward_kinematics(evaluate(motion, [tk]))[0][0, eff] - tgt))

    out, error = sm, miss(sm)
    for _ in range(_ROUNDS):
        if error <= tol:
            break
        m1 = evaluate(out, [tk])
        pos, wq = (x[0] for x in forward_kinematics(m1))
        new = solve_limb(pos, wq, m1.local_quats[0], parents, ch, tgt, damping=damping, tolerance=0.1 * tol)
        if not new:
            break
        trial = edit_pose(out, k, target={names[j]: q for j, q in new.items()}, mode="staggered",
                          joints=[names[j] for j in new])
        e = miss(trial)
        if e >= error - 0.01 * tol:                 # no further progress (out of reach): keep the best
            if e < error:
                out, error = trial, e
            break
        out, error = trial, e
    if spread is not None and out is not sm:
        rest = np.array(spread)
        rest[k] = 0.0                  # pose k keeps its solve; the others get their share of its change
        delta = quat_mul(quat_conj(sm.values[k]), out.values[k])
        out = _apply_pose_offsets(out, spread_offsets(delta[None], rest[None]))
        error = miss(out)              # (the neighbours' ramps end at pose k's plateau: t_k keeps the solve)
    pos = forward_kinematics(evaluate(out, [tk]))[0][0]
    reached = error <= tol
    message = ""
    if not reached:
        top = ch[0]
        reach = sum(np.linalg.norm(pos[b] - pos[a]) for a, b in zip(_path(parents, ch)[:-1], _path(parents, ch)[1:]))
        dist = float(np.linalg.norm(tgt - pos[top]))
        why = (f"it is {dist:.3g} units from the {names[top]}, farther than the stretched limb reaches ({reach:.3g})"
               if dist > reach - tol else "the limb cannot bend that far (the target is too close to the "
               f"{names[top]})" if dist < 0.5 * reach else "the limb could not get closer")
        asked = joint if isinstance(joint, str) else names[int(joint)]
        message = (f"{asked} cannot reach the target at pose {k} ({tk:.2f} s): {why}; it stops at the "
                   f"nearest point it can reach, {error:.3g} units away.")
    return IKPoseResult(out, reached, error, message)
