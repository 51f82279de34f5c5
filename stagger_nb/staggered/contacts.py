"""Environmental contact constraints (Coleman et al. 2008, Appendix B, after Bindiganavale & Badler 1998).

Search forward in time for end effectors whose world positions stay within a tolerance for at least a
minimum time (0.25 s); each such window becomes a contact, expanded over the further frames that stay within
the tolerance. Hands additionally have to be near the feet's level (a supporting contact), see
:func:`detect_contacts`. Contacts are ``(joint_name, start_frame, stop_frame)`` with half-open frame ranges.
"""
from __future__ import annotations

import re

import numpy as np
from scipy.ndimage import maximum_filter1d, minimum_filter1d

from ..core.kinematics import _fk_component_major, skeleton_height
from ..core.motion import Motion

__all__ = ["detect_contacts", "end_effectors", "contact_events", "DEFAULT_TOLERANCE", "DEFAULT_HAND_SUPPORT"]

DEFAULT_TOLERANCE = 0.02   # fraction of the skeleton height (~3.4 cm for 1.7 m): above marker noise, below a step
# fraction of the skeleton height (~17 cm): a hand this close to the feet's level bears weight
DEFAULT_HAND_SUPPORT = 0.1
_FOOT = re.compile(r"foot|toe|ankle|heel", re.I)
_HAND = re.compile(r"hand|wrist", re.I)
_FINGER = re.compile(r"thumb|index|middle|ring|pinky|finger|end", re.I)


def end_effectors(skeleton) -> list[int]:
    """Feet and hands of a skeleton: joints named like feet/toes/ankles/heels/hands/wrists (finger joints
    excluded); when no name matches, the leaf joints."""
    idx = [j for j, n in enumerate(skeleton.names)
           if (_FOOT.search(n) or _HAND.search(n)) and not _FINGER.search(n)]
    if not idx:
        idx = [int(j) for j in np.flatnonzero(skeleton.is_leaf())]
    return idx


def chain_subset(parents: np.ndarray, joints):
    """The joints ``joints`` and all their ancestors, as a sub-skeleton.

    Returns ``sub (n,)`` their indices ascending (parents before children, the root first), ``sub_par (n,)``
    the parent of each within ``sub`` (-1 for the root) and ``where (J,)`` each joint's place in ``sub``
    (-1 if not kept)."""
    keep = np.zeros(parents.size, bool)
    for j in joints:
        j = int(j)
        while j >= 0 and not keep[j]:
            keep[j] = True
            j = int(parents[j])
    sub = np.flatnonzero(keep)
    where = np.full(parents.size, -1)
    where[sub] = np.arange(sub.size)
    return sub, np.where(parents[sub] >= 0, where[np.maximum(parents[sub], 0)], -1), where


def _chain_positions(motion: Motion, joints) -> dict[int, np.ndarray]:
    """World positions ``{j: (F, 3)}`` of ``joints``, by forward kinematics of their chains only (the same
    products in the same order as :func:`~stagger_nb.core.kinematics.forward_kinematics`, so bit-identical;
    no (F, J) outputs are built for the joints nobody reads)."""
    sub, sub_par, where = chain_subset(motion.skeleton.parents, joints)
    Q = np.ascontiguousarray(np.moveaxis(motion.local_quats[:, sub], 0, -1).transpose(1, 0, 2))   # (4, n, F)
    lt = motion.local_translations
    T = (motion.skeleton.offsets[sub].T[:, :, None] if lt is None
         else np.ascontiguousarray(np.moveaxis(lt[:, sub], 0, -1).transpose(1, 0, 2)))
    _, P = _fk_component_major(Q, T, np.ascontiguousarray(motion.root_positions.T), sub_par)
    return {int(j): np.ascontiguousarray(P[:, where[j]].T) for j in set(joints)}


def _box_extent(p: np.ndarray, length: int) -> np.ndarray:
    """Diagonal of the bounding box of ``p[s : s + length]`` for every start ``s`` (F - length + 1,)."""
    half = length // 2
    hi = maximum_filter1d(p, length, axis=0, origin=-half, mode="nearest")
    lo = minimum_filter1d(p, length, axis=0, origin=-half, mode="nearest")
    return np.linalg.norm(hi - lo, axis=-1)[: p.shape[0] - length + 1]


def _grow_box(p: np.ndarray, s: int, e: int, tolerance: float, block: int = 64) -> int:
    """Largest ``e' >= e`` such that the bounding box of ``p[s:e']`` (positions (F, 3)) has a diagonal
    ``<= tolerance`` (the box of ``p[s:e]`` must already fit): frames are added one at a time, tested in
    blocks of ``block`` with running minima and maxima."""
    F = p.shape[0]
    lo, hi = p[s:e].min(axis=0), p[s:e].max(axis=0)
    while e < F:
        seg = p[e:e + block]
        nlo = np.minimum(np.minimum.accumulate(seg, axis=0), lo)
        nhi = np.maximum(np.maximum.accumulate(seg, axis=0), hi)
        bad = np.flatnonzero(np.linalg.norm(nhi - nlo, axis=1) > tolerance)
        if bad.size:
            return e + int(bad[0])
        lo, hi = nlo[-1], nhi[-1]
        e += seg.shape[0]
    return e


def detect_contacts(motion: Motion, tolerance: float | None = None, min_duration: float = 0.25,
                    joints=None, positions: np.ndarray | None = None, *,
                    hand_support: float | None = DEFAULT_HAND_SUPPORT) -> list[tuple[str, int, int]]:
    """Contact constraints of end effectors that stay still (Appendix B).

    Appendix B tests every candidate joint for stillness alone. A hand that is still in the air (arms
    hanging while the subject stands, the turn of an arm swing) is not an environmental contact, and
    planting it with the constraint layer would undo arm edits; so by default a still window of a hand
    (name like hand/wrist) counts only where the hand is low, near the feet, i.e. supporting the body
    (crawls, handstands, push-ups). ``hand_support=None`` is the paper's plain test.

    Parameters
    ----------
    motion : Motion
    tolerance : float, file units, optional
        Largest extent (bounding-box diagonal) of a still effector's positions; default
        ``DEFAULT_TOLERANCE * skeleton height``.
    min_duration : float, seconds
        Minimum time an effector must stay within the tolerance (paper: 0.25 s).
    joints : iterable of names or indices, optional
        Effectors to test (default :func:`end_effectors`).
    positions : (F, J, 3), optional
        World joint positions if already computed (only the tested effectors' and the feet's rows are
        read). Default: forward kinematics of those joints' chains only (bit-identical to full FK there).
    hand_support : float or None
        A hand's still window is a contact only if its mean height (+Y, the BVH up axis) is at most
        ``hand_support * skeleton height`` above the lowest foot joint over that window. Applies when
        the skeleton has feet (names like foot/toe/ankle/heel); None disables the test.

    Returns
    -------
    list of ``(joint_name, start_frame, stop_frame)``, half-open ``[start, stop)``, sorted by start.
    """
    if min_duration <= 0:
        raise ValueError(f"detect_contacts: min_duration must be > 0 seconds, got {min_duration}")
    sk = motion.skeleton
    if tolerance is None:
        tolerance = DEFAULT_TOLERANCE * skeleton_height(motion)
    if not tolerance > 0:
        raise ValueError(f"detect_contacts: tolerance must be > 0, got {tolerance}")
    if joints is None:
        joints = end_effectors(sk)
    joints = [sk.index(j) if isinstance(j, str) else int(j) for j in joints]
    F = motion.num_frames
    L = max(int(np.ceil(min_duration / motion.frame_time - 1e-9)) + 1, 2)   # frames spanning min_duration
    out = []
    if F < L:
        return out
    feet = [j for j, n in enumerate(sk.names) if _FOOT.search(n) and not _FINGER.search(n)]
    if positions is None:            # the effectors' and feet's chains only
        pos = _chain_positions(motion, joints + feet)
    else:
        pos = {j: positions[:, j] for j in set(joints + feet)}
    support = None
    if hand_support is not None:
        if not hand_support >= 0:
            raise ValueError(f"detect_contacts: hand_support must be >= 0 or None, got {hand_support}")
        if feet:
            support = hand_support * skeleton_height(motion)
            floor = np.min([pos[f][:, 1] for f in feet], axis=0)      # (F,) lowest foot joint per frame
    for j in joints:
        is_hand = support is not None and bool(_HAND.search(sk.names[j])) and j not in feet
        p = pos[j]
        ok = _box_extent(p, L) <= tolerance                    # window [s, s + L) is still
        starts = np.flatnonzero(ok)
        s = 0
        while s <= F - L:
            if not ok[s]:
                i = np.searchsorted(starts, s)                 # the next still window
                if i == starts.size:
                    break
                s = int(starts[i])
                continue
            e = _grow_box(p, s, s + L, tolerance)
            if not is_hand or p[s:e, 1].mean() - floor[s:e].min() <= support:
                out.append((sk.names[j], s, e))
            s = e
    out.sort(key=lambda c: (c[1], c[0]))
    return out


def contact_events(contacts, num_frames: int) -> np.ndarray:
    """Binary global evidence (§4.1): 1 at frames where a contact starts or ends (its stop frame, clamped),
    shape (num_frames,)."""
    ev = np.zeros(num_frames)
    for _, a, b in contacts:
        ev[min(max(int(a), 0), num_frames - 1)] = 1.0
        ev[min(max(int(b), 0), num_frames - 1)] = 1.0
    return ev
