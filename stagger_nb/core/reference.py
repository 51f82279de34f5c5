"""Slow, straightforward reference implementations, for tests and benchmarks only.

They are written "in the most straightforward manner" (per joint, 4x4 homogeneous transforms built
from ``scipy.spatial.transform.Rotation`` matrices) so that the fast code can be checked against them.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from .motion import Motion

__all__ = ["forward_kinematics_reference"]


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
