"""Forward kinematics and body-frame joint positions."""
from __future__ import annotations

import numpy as np

from .motion import Motion
from .rotations import quat_conj, quat_mul, quat_rotate

__all__ = ["forward_kinematics", "fk_arrays", "positions_in_root_frame", "skeleton_height"]


def fk_arrays(local_quats: np.ndarray, translations: np.ndarray, parents: np.ndarray):
    """Forward kinematics on arrays.

    Parameters
    ----------
    local_quats : (F, J, 4) local rotations, (x, y, z, w)
    translations : (F, J, 3) or (J, 3) translation of each joint in its parent's frame
        (row 0: root world position)
    parents : (J,) parent indices, root -1, parents before children

    Returns
    -------
    positions : (F, J, 3) world joint positions
    world_quats : (F, J, 4) world rotations
    """
    local_quats = np.asarray(local_quats, dtype=float)
    F, J, _ = local_quats.shape
    translations = np.broadcast_to(np.asarray(translations, dtype=float), (F, J, 3))
    world_q = np.empty((F, J, 4))
    pos = np.empty((F, J, 3))
    world_q[:, 0] = local_quats[:, 0]
    pos[:, 0] = translations[:, 0]
    for j in range(1, J):
        p = parents[j]
        world_q[:, j] = quat_mul(world_q[:, p], local_quats[:, j])
        pos[:, j] = pos[:, p] + quat_rotate(world_q[:, p], translations[:, j])
    return pos, world_q


def forward_kinematics(motion: Motion):
    """World joint positions ``(F, J, 3)`` and world rotations ``(F, J, 4)`` of ``motion``."""
    if motion.local_translations is None:
        t = np.broadcast_to(motion.skeleton.offsets, (motion.num_frames, motion.num_joints, 3)).copy()
        t[:, 0] = motion.root_positions
    else:
        t = motion.translations()
    return fk_arrays(motion.local_quats, t, motion.skeleton.parents)


def positions_in_root_frame(motion: Motion, positions: np.ndarray | None = None,
                            world_quats: np.ndarray | None = None) -> np.ndarray:
    """Joint positions ``(F, J, 3)`` expressed in the root (torso) joint's moving coordinate frame:
    ``R_root(t)^-1 (p_j(t) - p_root(t))`` (guided time warping, §3.2)."""
    if positions is None or world_quats is None:
        positions, world_quats = forward_kinematics(motion)
    rel = positions - positions[:, :1]
    return quat_rotate(quat_conj(world_quats[:, :1]), rel)


def skeleton_height(motion: Motion) -> float:
    """Vertical extent of the first frame's joints (a length scale for tolerances)."""
    p, _ = forward_kinematics(motion.slice(0, 1))
    ext = p[0].max(axis=0) - p[0].min(axis=0)
    return float(max(ext.max(), 1e-9))
