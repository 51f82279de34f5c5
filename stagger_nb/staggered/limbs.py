"""Two-bone limbs of a skeleton (upper joint, middle joint, effector: hip-knee-ankle, shoulder-elbow-wrist),
the chain that holds a contact on a joint (a toe through its ankle), the limb's length, and forward kinematics of
just those chains (the constraint layer reads a few legs' joints, not the whole body).
"""
from __future__ import annotations

import numpy as np

from ..core.kinematics import _fk_component_major
from ..core.motion import Motion
from .contacts import chain_subset


def _fk_joints(motion: Motion, joints, local_quats=None, root_positions=None) -> tuple[np.ndarray, np.ndarray]:
    """``forward_kinematics(motion)`` computed only for ``joints`` and their ancestors (the chains the
    constraint layer reads: a few legs' joints of a 30-joint body, about a third of the work);
    ``local_quats`` (F, J, 4) / ``root_positions`` (F, 3) replace the motion's (no new Motion to validate).

    Returns full-shaped ``(F, J, 3)`` positions and ``(F, J, 4)`` world rotations, equal (bit for bit: the
    same products in the same order) to :func:`forward_kinematics` on the computed joints and NaN on the
    others, so a read of a joint that was not asked for cannot pass unnoticed."""
    sub, sub_par, _ = chain_subset(motion.skeleton.parents, joints)   # parents before children, root first
    F = motion.num_frames
    # component-major (C, joints, F) in and out, as forward_kinematics does, without its (F, J, C) round trips
    lq = motion.local_quats if local_quats is None else local_quats
    Q = np.empty((4, sub.size, F))
    for c in range(4):
        Q[c] = lq[:, sub, c].T
    if motion.local_translations is None:
        T = motion.skeleton.offsets[sub].T[:, :, None]              # the same offsets every frame
    else:
        T = np.empty((3, sub.size, F))
        for c in range(3):
            T[c] = motion.local_translations[:, sub, c].T
    rp = motion.root_positions if root_positions is None else root_positions
    W, P = _fk_component_major(Q, T, np.ascontiguousarray(rp.T), sub_par)
    pos = np.full((F, motion.num_joints, 3), np.nan)
    wq = np.full((F, motion.num_joints, 4), np.nan)
    for c in range(3):
        pos[:, sub, c] = P[c].T
    for c in range(4):
        wq[:, sub, c] = W[c].T
    return pos, wq


def _chain_length(p: np.ndarray, up: int, mid: int, eff: int) -> float:
    """Length of the two bones up -> mid -> eff from world positions ``p (J, 3)`` of one frame."""
    a, b = p[mid] - p[up], p[eff] - p[mid]
    return float(np.sqrt(a @ a) + np.sqrt(b @ b))


def _chain(skeleton, j: int) -> tuple[int, int, int]:
    """(upper, middle, effector) joints that carry a contact on ``j``: toe contacts go through the ankle,
    and zero-length bones are skipped so both IK bones have a length (e.g. CMU's ``lhand`` sits on
    ``LeftWrist``; ``upper`` is the first ancestor not co-located with ``middle``). ``upper`` is -1 when the
    chain would reach the root."""
    par = skeleton.parents
    return _limb(skeleton, int(par[j]) if "toe" in skeleton.names[j].lower() and par[j] > 0 else j)


def _limb(skeleton, eff: int) -> tuple[int, int, int]:
    """(upper, middle, effector) two-bone limb ending at joint ``eff`` (zero-length bones skipped, see
    :func:`_chain`); ``upper`` is -1 when the limb would reach the root."""
    par, offsets = skeleton.parents, skeleton.offsets

    def zero(j):   # a zero-length bone (only the few joints visited are measured)
        o = offsets[j]
        return float(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]) < 1e-18

    eff = int(eff)
    while eff > 0 and zero(eff):
        eff = int(par[eff])
    mid = int(par[eff]) if eff > 0 else -1
    c = mid
    while c > 0 and zero(c):
        c = int(par[c])
    up = int(par[c]) if c > 0 else -1
    return up, mid, eff
