"""Forward kinematics and body-frame joint positions.

Forward kinematics composes each joint's local rotation with its parent's world rotation,
``R_j = R_parent(j) * q_j`` and ``p_j = p_parent(j) + R_parent(j) t_j`` (the usual BVH/ASF hierarchy
semantics).  It is evaluated level by level (all joints at the same depth at once) on a
component-major ``(4, J, F)`` layout, so every arithmetic step is one contiguous numpy operation over
frames; the result equals a joint-by-joint quaternion product to rounding (~1e-14 relative).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .motion import Motion
from .rotations import quat_conj, quat_mul_components, quat_rotate

__all__ = ["forward_kinematics", "fk_arrays", "positions_in_root_frame", "skeleton_height"]


@lru_cache(maxsize=64)
def _levels(parents: tuple) -> tuple:
    """Joint indices grouped by depth (level 1, 2, ...) with their parents, for a parents tuple."""
    J = len(parents)
    depth = np.zeros(J, dtype=int)
    for j in range(1, J):
        depth[j] = depth[parents[j]] + 1
    out = []
    for level in range(1, int(depth.max(initial=0)) + 1):
        idx = np.flatnonzero(depth == level)
        par = np.asarray([parents[i] for i in idx], dtype=np.int64)
        # contiguous runs index faster as slices than as fancy indices
        if idx.size and np.all(np.diff(idx) == 1):
            idx = slice(int(idx[0]), int(idx[-1]) + 1)
        out.append((idx, par))
    return tuple(out)


def _fk_component_major(Q: np.ndarray, T: np.ndarray, root: np.ndarray, parents: np.ndarray):
    """FK on component-major arrays.

    Q : (4, J, F) local quaternion components x, y, z, w
    T : (3, J, F) or (3, J, 1) joint translations in the parent frame (row 0 unused)
    root : (3, F) or (3, 1) root world positions
    Returns W (4, J, F) world quaternions and P (3, J, F) world positions.
    """
    _, J, F = Q.shape
    W = np.empty((4, J, F))
    P = np.empty((3, J, F))
    W[:, 0] = Q[:, 0]
    P[:, 0] = root
    for idx, par in _levels(tuple(int(p) for p in parents)):
        A = W[:, par]
        ax, ay, az, aw = A
        prod = np.empty(A.shape)
        W[:, idx] = quat_mul_components(A, Q[:, idx], prod, np.empty(A.shape[1:]))   # parent * local
        # p_j = p_parent + v + w t + u x t with t = 2 u x v (u = parent's vector part): quat_rotate
        vx, vy, vz = T[:, idx]
        tx = 2.0 * (ay * vz - az * vy)
        ty = 2.0 * (az * vx - ax * vz)
        tz = 2.0 * (ax * vy - ay * vx)
        Pp = P[:, par]
        P[0, idx] = Pp[0] + vx + aw * tx + (ay * tz - az * ty)
        P[1, idx] = Pp[1] + vy + aw * ty + (az * tx - ax * tz)
        P[2, idx] = Pp[2] + vz + aw * tz + (ax * ty - ay * tx)
    return W, P


def _to_component_major(a: np.ndarray) -> np.ndarray:
    """``(F, J, C)`` -> C-contiguous ``(C, J, F)``, one 2-D transpose per component (numpy's 3-D
    transposed copy is ~4x slower: its innermost loop strides across the whole array)."""
    F, J, C = a.shape
    out = np.empty((C, J, F))
    for c in range(C):
        out[c] = a[:, :, c].T
    return out


def _to_frame_major(a: np.ndarray) -> np.ndarray:
    """``(C, J, F)`` -> C-contiguous ``(F, J, C)`` (the inverse of :func:`_to_component_major`)."""
    C, J, F = a.shape
    out = np.empty((F, J, C))
    for c in range(C):
        out[:, :, c] = a[c].T
    return out


def _validate_parents(parents, J: int) -> np.ndarray:
    parents = np.asarray(parents, dtype=np.int64).reshape(-1)
    if parents.shape != (J,):
        raise ValueError(f"parents must have shape ({J},), got {parents.shape}")
    if J and (parents[0] != -1 or np.any(parents[1:] < 0) or np.any(parents[1:] >= np.arange(1, J))):
        raise ValueError("parents: root must be joint 0 (parent -1) and every parent must come before its child")
    return parents


def fk_arrays(local_quats: np.ndarray, translations: np.ndarray, parents: np.ndarray):
    """Forward kinematics on arrays.

    Parameters
    ----------
    local_quats : (F, J, 4) unit local rotations, (x, y, z, w)
    translations : (F, J, 3) or (J, 3) translation of each joint in its parent's frame
        (row 0: root world position)
    parents : (J,) parent indices, root -1, parents before children

    Returns
    -------
    positions : (F, J, 3) world joint positions (units of ``translations``)
    world_quats : (F, J, 4) world rotations, (x, y, z, w)
    """
    local_quats = np.asarray(local_quats, dtype=float)
    if local_quats.ndim != 3 or local_quats.shape[-1] != 4:
        raise ValueError(f"local_quats must have shape (F, J, 4), got {local_quats.shape}")
    F, J, _ = local_quats.shape
    translations = np.asarray(translations, dtype=float)
    if translations.shape not in ((F, J, 3), (J, 3)):
        raise ValueError(f"translations must have shape ({F}, {J}, 3) or ({J}, 3), got {translations.shape}")
    parents = _validate_parents(parents, J)
    Q = _to_component_major(local_quats)
    T = translations.T[:, :, None] if translations.ndim == 2 else _to_component_major(translations)
    W, P = _fk_component_major(Q, T, T[:, 0], parents)
    return _to_frame_major(P), _to_frame_major(W)


def forward_kinematics(motion: Motion):
    """World joint positions and rotations of ``motion``.

    Returns
    -------
    positions : (F, J, 3) world joint positions, file units
    world_quats : (F, J, 4) world rotations, (x, y, z, w)
    """
    Q = _to_component_major(motion.local_quats)
    if motion.local_translations is None:
        T = motion.skeleton.offsets.T[:, :, None]  # (3, J, 1): the same offsets every frame
    else:
        T = _to_component_major(motion.local_translations)
    W, P = _fk_component_major(Q, T, motion.root_positions.T, motion.skeleton.parents)
    return _to_frame_major(P), _to_frame_major(W)


def positions_in_root_frame(motion: Motion, positions: np.ndarray | None = None,
                            world_quats: np.ndarray | None = None) -> np.ndarray:
    """Joint positions expressed in the root (torso) joint's moving coordinate frame.

    ``R_root(t)^-1 (p_j(t) - p_root(t))`` (guided time warping, §3.2).

    Parameters
    ----------
    motion : Motion with F frames, J joints
    positions, world_quats : optional (F, J, 3) / (F, J, 4) from :func:`forward_kinematics`, to reuse

    Returns
    -------
    (F, J, 3) positions in the root frame, file units (root row is zero)
    """
    if positions is None or world_quats is None:
        positions, world_quats = forward_kinematics(motion)
    rel = positions - positions[:, :1]
    return quat_rotate(quat_conj(world_quats[:, :1]), rel)


def skeleton_height(motion: Motion) -> float:
    """A length scale for tolerances, file units: the largest extent of the rest pose (identity rotations,
    ``skeleton.offsets``, End Sites included).

    The rest pose, not an animated frame, so animated translations cannot inflate it: the Bandai files'
    static ``joint_Root`` sits metres away from the walking Hips, which made a first-frame extent ~3x the
    body's size.
    """
    skel = motion.skeleton
    rest = np.zeros((skel.num_joints, 3))
    for j in range(1, skel.num_joints):
        rest[j] = rest[skel.parents[j]] + skel.offsets[j]
    points = [rest] + [rest[j] + off for j, off in skel.end_sites.items()]
    pts = np.vstack(points)
    ext = pts.max(axis=0) - pts.min(axis=0)
    return float(max(ext.max(), 1e-9))
