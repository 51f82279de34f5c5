"""Two-bone limbs of a skeleton (upper joint, middle joint, effector: hip-knee-ankle, shoulder-elbow-wrist),
the chain that holds a contact on a joint (a toe through its ankle), the limb's length, and forward kinematics of
just those chains (the constraint layer reads a few legs' joints, not the whole body).

:func:`find_limb` is the contact layer's (``plants``) limb discovery on any rig: foot / hand parts by name, helper
bones (twist, roll, share bones) and zero-length bones skipped; ``_chain`` / ``_limb`` are the older, simpler
rule :func:`~stagger_nb.staggered.ik.ik_pose` uses.
"""
from __future__ import annotations

import re
import weakref
from dataclasses import dataclass, field

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


_FOOT = re.compile(r"foot|toe|ankle|heel", re.I)
_FOOT_ROOT = re.compile(r"foot|ankle", re.I)
_HAND = re.compile(r"hand|wrist", re.I)
_INLINE = re.compile(r"twist|roll|share", re.I)     # helper bones along a limb (CC_Base_*Twist*, *ShareBone)
_MIN_BONE = 0.02      # a limb bone shorter than this share of the body is not a limb bone


# -- limbs of the contact layer -----------------------------------------------------------------

@dataclass(frozen=True)
class Limb:
    """A two-bone limb holding a contact.

    Attributes
    ----------
    upper, mid, eff : int
        Hip (shoulder), knee (elbow), ankle (wrist) joints: the IK turns ``upper`` and ``mid``; ``eff`` takes
        the plant's world orientation.
    foot : tuple of int
        Every joint below ``eff`` (toes, heel, their children): they take the source's local rotations.
    leg : bool
        A leg (its effector or a joint below it is named like a foot): its knee bends to keep the foot where
        the edit put it where the root is lowered and the foot is in the air.
    """

    upper: int
    mid: int
    eff: int
    foot: tuple = field(default=())
    leg: bool = True


def _rest(skeleton) -> np.ndarray:
    rest = np.zeros((skeleton.num_joints, 3))
    for j in range(1, skeleton.num_joints):
        rest[j] = rest[skeleton.parents[j]] + skeleton.offsets[j]
    return rest


_LIMBS = weakref.WeakKeyDictionary()


def find_limb(skeleton, joint) -> Limb | None:
    """The limb that holds a contact on ``joint`` (name or index), or None when there is none.

    A joint named like a foot part (foot/toe/ankle/heel) belongs to the foot whose top is the highest joint of
    its run of foot-named ancestors named foot or ankle (a run named only toe/heel: its parent); a hand part
    (hand/wrist) likewise; any other joint is its own effector. Zero-length bones are skipped (the effector
    and the upper joint are the first joints not co-located with their child), and so are helper bones named
    like twist/roll/share bones (``CC_Base_L_CalfTwist01``). None when the upper joint would be the root or a
    bone is shorter than 2 % of the body (no two-bone limb)."""
    j = skeleton.index(joint) if isinstance(joint, str) else int(joint)
    per = _LIMBS.setdefault(skeleton, {})
    if j not in per:
        per[j] = _find_limb(skeleton, j)
    return per[j]


def _find_limb(skeleton, j: int) -> Limb | None:
    names, par = skeleton.names, skeleton.parents
    rest = _rest(skeleton)
    H = max(float(np.ptp(rest, axis=0).max()), 1e-12)

    def co(k):   # k sits where its parent does
        return float(np.sum(skeleton.offsets[k] ** 2)) <= (1e-9 * H) ** 2

    kind = _FOOT if _FOOT.search(names[j]) else _HAND if _HAND.search(names[j]) else None
    eff = j
    if kind is not None:
        while par[eff] > 0 and kind.search(names[par[eff]]) and not _INLINE.search(names[par[eff]]):
            eff = int(par[eff])
        if kind is _FOOT and not _FOOT_ROOT.search(names[eff]) and par[eff] > 0:
            eff = int(par[eff])                     # toes named, the foot not: the toes' parent is the ankle
    while eff > 0 and co(eff):
        eff = int(par[eff])
    if eff <= 0:
        return None
    mid = int(par[eff])
    while mid > 0 and _INLINE.search(names[mid]):
        mid = int(par[mid])
    c = mid
    while c > 0 and co(c):
        c = int(par[c])
    up = int(par[c]) if c > 0 else -1
    while up > 0 and _INLINE.search(names[up]):
        up = int(par[up])
    if up <= 0:
        return None
    if min(np.linalg.norm(rest[mid] - rest[up]), np.linalg.norm(rest[eff] - rest[mid])) < _MIN_BONE * H:
        return None
    below = np.zeros(skeleton.num_joints, bool)
    below[eff] = True
    for k in range(eff + 1, skeleton.num_joints):
        below[k] = below[par[k]]
    foot = tuple(int(k) for k in np.flatnonzero(below) if k != eff)
    leg = bool(_FOOT.search(names[eff])) or any(_FOOT.search(names[k]) for k in foot)
    return Limb(up, mid, eff, foot, leg)


