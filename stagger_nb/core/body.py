"""Body landmarks found on any rig: the pelvis, the vertical axis, and heading-free root rotations.

Joint 0 is not always the pelvis: the Bandai files put a static ``joint_Root`` (at the origin, or translating
on its own) above the walking ``Hips``.  Techniques that need the character's torso frame (guided time
warping, §3.2 of Hsu et al. 2007) or its heading (the magic wand's pose space) find the pelvis here.

Glossary: F frames, J joints; quaternions (x, y, z, w).
"""
from __future__ import annotations

import re

import numpy as np

from .kinematics import forward_kinematics
from .motion import Motion
from .rotations import quat_conj, quat_mul, quat_normalize, quat_rotate
from .skeleton import Skeleton

__all__ = ["pelvis_joint", "subtree", "up_axis", "heading_quats", "remove_heading", "joint_sides", "limb_groups"]


def subtree(skeleton: Skeleton, j: int) -> np.ndarray:
    """Joint ``j`` and all its descendants, ascending indices, shape (n,) int."""
    inside = np.zeros(skeleton.num_joints, dtype=bool)
    inside[j] = True
    for c in range(j + 1, skeleton.num_joints):     # parents come before children
        if inside[skeleton.parents[c]]:
            inside[c] = True
    return np.flatnonzero(inside)


def pelvis_joint(skeleton: Skeleton) -> int:
    """Index of the pelvis: the joint where the legs' and the spine's chains branch.

    The shallowest joint with at least three child *chains* (children that have children of their own, so
    an End Site or a one-joint prop does not count): ``Hips`` on CMU-style, Bandai and PyMO rigs (below
    Bandai's static ``joint_Root``), the CMU ASF root; or, where that joint is the chest because the legs
    hang off a joint of their own, the ancestor where the legs' and the spine's chains meet.
    A rig without such a joint but with several leaves (a two-legged toy) gets the deepest common ancestor of
    its leaves; a single chain gets joint 0.
    """
    parents = skeleton.parents
    J = skeleton.num_joints
    has_child = np.zeros(J, dtype=bool)
    has_child[parents[1:]] = True
    chains = np.zeros(J, dtype=int)
    for c in range(1, J):
        if has_child[c]:
            chains[parents[c]] += 1
    depth = skeleton.depth()
    branching = np.flatnonzero(chains >= 3)
    if branching.size:
        return _legs_above(skeleton, int(branching[np.argmin(depth[branching])]), has_child)
    # deepest common ancestor of the leaves
    leaves = np.flatnonzero(~has_child)
    if leaves.size < 2:
        return 0
    ancestors = None
    for leaf in leaves:
        path, a = set(), int(leaf)
        while a >= 0:
            path.add(a)
            a = int(parents[a])
        ancestors = path if ancestors is None else ancestors & path
    common = sorted(ancestors or {0}, key=lambda a: depth[a])
    return int(common[-1])


def _legs_above(skeleton: Skeleton, c: int, has_child: np.ndarray) -> int:
    """``c`` (the shallowest joint with three child chains: the pelvis on most rigs, the chest where the legs
    hang off a separate joint), or the nearest ancestor of ``c`` that also holds another chain with two or more
    leaves (the legs: ``Root -> {Pelvis -> legs, Spine -> Chest -> arms, neck}``), where spine and legs meet."""
    parents = skeleton.parents
    child, a = c, int(parents[c])
    while a >= 0:
        for other in skeleton.children(a):
            if other != child and has_child[other] and int(np.count_nonzero(~has_child[subtree(skeleton, other)])) >= 2:
                return a
        child, a = a, int(parents[a])
    return c


def up_axis(motion: Motion, positions: np.ndarray | None = None) -> np.ndarray:
    """The world's vertical axis for ``motion``, a unit coordinate axis, shape (3,).

    The mean over frames of (spine subtree centre - leg subtrees centre), the pelvis's child chains split by
    size (the largest chain, which holds the arms and the head, is the spine), snapped to the nearest
    coordinate axis (±X, ±Y or ±Z).  Falls back to +Y (the BVH convention) when the rig has a single chain.
    ``positions`` (F, J, 3) from :func:`.kinematics.forward_kinematics` may be given to reuse them.
    """
    skel = motion.skeleton
    p = skel.children(pelvis_joint(skel))
    chains = [subtree(skel, c) for c in p if skel.children(c)]
    if len(chains) < 2:
        return np.array([0.0, 1.0, 0.0])
    if positions is None:
        positions, _ = forward_kinematics(motion)
    chains.sort(key=len)
    spine = chains[-1]
    legs = np.concatenate(chains[:-1])
    v = (positions[:, spine].mean(axis=(0, 1)) - positions[:, legs].mean(axis=(0, 1)))
    if not np.all(np.isfinite(v)) or not np.any(v):
        return np.array([0.0, 1.0, 0.0])
    a = int(np.argmax(np.abs(v)))
    up = np.zeros(3)
    up[a] = np.sign(v[a])
    return up


def heading_quats(world_quats: np.ndarray, up: np.ndarray) -> np.ndarray:
    """The heading (twist about the vertical ``up``) of rotations ``(..., 4)`` -> ``(..., 4)``.

    Swing-twist: ``q = h s`` with ``h`` a rotation about ``up`` (the heading, yaw) and ``s`` a swing about a
    horizontal axis (pitch and roll).  ``h = normalize((v . up) up, w)`` for ``q = (v, w)``; where both are 0
    (a half-turn about a horizontal axis, where the heading is undefined) ``h`` is the identity.
    """
    q = np.asarray(world_quats, dtype=float)
    u = np.asarray(up, dtype=float)
    proj = np.sum(q[..., :3] * u, axis=-1, keepdims=True)
    h = np.concatenate([proj * u, q[..., 3:]], axis=-1)
    n = np.linalg.norm(h, axis=-1, keepdims=True)
    bad = n[..., 0] < 1e-12
    h = np.where(bad[..., None], np.array([0.0, 0.0, 0.0, 1.0]), h / np.where(n < 1e-12, 1.0, n))
    return h


def remove_heading(world_quats: np.ndarray, up: np.ndarray) -> np.ndarray:
    """``h^-1 q``: rotations ``(..., 4)`` with their heading about ``up`` removed, pitch and roll kept."""
    q = np.asarray(world_quats, dtype=float)
    return quat_normalize(quat_mul(quat_conj(heading_quats(q, up)), q))


def positions_in_pelvis_frame(motion: Motion, fk=None) -> tuple[np.ndarray, np.ndarray]:
    """Positions of the pelvis's subtree in the pelvis's moving frame: ``R_p(t)^-1 (x_j(t) - x_p(t))``.

    Returns ``(positions (F, n, 3), joints (n,))`` with ``joints`` the subtree's indices (the pelvis first,
    its row zero).  Joints above the pelvis (a static root) are left out: they carry the global travel.
    ``fk`` = ``forward_kinematics(motion)`` may be given to reuse it.
    """
    pos, wq = forward_kinematics(motion) if fk is None else fk
    pelvis = pelvis_joint(motion.skeleton)
    joints = subtree(motion.skeleton, pelvis)
    rel = pos[:, joints] - pos[:, pelvis:pelvis + 1]
    return quat_rotate(quat_conj(wq[:, pelvis:pelvis + 1]), rel), joints


FLOOR_PERCENTILE = 5.0   # the floor: this percentile over frames of the lowest joint's height


def positions_in_heading_frame(motion: Motion, up=None, fk=None) -> tuple[np.ndarray, np.ndarray]:
    """Positions of the pelvis's subtree in its *heading* frame, with heights above the clip's floor.

    ``H(t)^-1 (x_j(t) - g(t))`` where ``H(t)`` is the pelvis's heading (its world rotation's twist about the
    vertical ``up``, :func:`heading_quats`) and ``g(t)`` the pelvis's ground point: its position with the
    vertical component replaced by the floor level (the :data:`FLOOR_PERCENTILE`-th percentile over frames of
    the lowest subtree joint's height).  So the horizontal coordinates follow the character (no travel, no
    heading), while the vertical coordinate is each joint's height above the floor: pitch and roll of the
    pelvis and the body's vertical motion (a flight's parabola) stay in.  Invariant to travel on the ground,
    to turning about the vertical and to a constant vertical offset of the whole clip; not to a tilt of the
    world (gravity defines the vertical).

    Returns ``(positions (F, n, 3), joints (n,))`` like :func:`positions_in_pelvis_frame` (``fk`` likewise).
    """
    pos, wq = forward_kinematics(motion) if fk is None else fk
    pelvis = pelvis_joint(motion.skeleton)
    joints = subtree(motion.skeleton, pelvis)
    u = up_axis(motion, pos) if up is None else np.asarray(up, dtype=float)
    p = pos[:, joints]
    heights = p @ u                                                   # (F, n)
    floor = float(np.percentile(heights.min(axis=1), FLOOR_PERCENTILE))
    ground = pos[:, pelvis] - (pos[:, pelvis] @ u - floor)[:, None] * u[None, :]   # (F, 3)
    h = heading_quats(wq[:, pelvis], u)
    return quat_rotate(quat_conj(h[:, None]), p - ground[:, None]), joints


AIRBORNE_CLEARANCE = 0.06   # airborne_frames: lowest point of each leg above the floor, x the pelvis's height


def leg_chains(skeleton: Skeleton) -> list[np.ndarray]:
    """The legs: the pelvis's child chains (subtrees with children) other than the largest (the spine, which
    holds the arms and the head), each as its joint indices; ``[]`` on a single-chain rig."""
    p = pelvis_joint(skeleton)
    chains = sorted((subtree(skeleton, c) for c in skeleton.children(p) if skeleton.children(c)), key=len)
    return chains[:-1] if len(chains) >= 2 else []


def airborne_frames(motion: Motion, clearance: float = AIRBORNE_CLEARANCE, positions=None) -> np.ndarray:
    """Frames where both feet are off the ground, shape (F,) bool.

    A leg is off the ground when its lowest joint is more than ``clearance`` times the pelvis's median height
    above the floor (the :data:`FLOOR_PERCENTILE`-th percentile over frames of the lower leg's lowest joint):
    scale-free, so the same on a clip in cm, m or inches (6 % is 5.5 cm on CMU 01_01).  A rig without two
    legs (:func:`leg_chains`) is never airborne.  ``positions`` (F, J, 3) from forward kinematics may be given.
    """
    legs = leg_chains(motion.skeleton)
    if len(legs) < 2:
        return np.zeros(motion.num_frames, dtype=bool)
    if positions is None:
        positions, _ = forward_kinematics(motion)
    u = up_axis(motion, positions)
    h = positions @ u                                                        # (F, J) heights
    low = np.stack([h[:, leg].min(axis=1) for leg in legs], axis=1)         # (F, legs)
    floor = float(np.percentile(low.min(axis=1), FLOOR_PERCENTILE))
    pelvis = float(np.median(h[:, pelvis_joint(motion.skeleton)])) - floor
    return np.all(low > floor + float(clearance) * max(pelvis, 1e-12), axis=1)


__all__ += ["positions_in_pelvis_frame", "positions_in_heading_frame", "FLOOR_PERCENTILE", "leg_chains",
            "airborne_frames", "AIRBORNE_CLEARANCE"]

__all__ += ["positions_in_pelvis_frame"]


_CMU_SIDED = ("hip", "femur", "tibia", "foot", "toes", "clavicle", "humerus", "radius", "wrist", "hand", "fingers",
              "thumb", "shoulder", "elbow", "knee", "ankle")


def joint_sides(names) -> list[str]:
    """'left' / 'right' / 'centre' for each joint name, from its words: ``Left…`` / ``Right…``, ``L…`` / ``R…``
    followed by a capital (``LHipJoint``), a word ``L`` / ``R`` (``CC_Base_L_Thigh``, ``hand_r``, ``Hand.L``),
    the CMU ASF names (``lfemur``); a namespace (``mixamorig:``) is ignored."""
    out = []
    for n in names:
        base = n.rsplit(":", 1)[-1] if isinstance(n, str) else str(n)
        words = [w.lower() for w in re.split(r"[_.\-\s|]+", base) if w]
        low = base.lower()
        side = "centre"
        for s, word in (("left", "l"), ("right", "r")):
            if low.startswith(s) or low.endswith(s) or s in words or word in words or \
                    (len(base) > 1 and base[0] == word.upper() and base[1].isupper()) or \
                    low.startswith(tuple(word + x for x in _CMU_SIDED)):
                side = s
                break
        out.append(side)
    return out


def _shape(skeleton: Skeleton) -> list:
    """A canonical signature of each joint's subtree (equal for mirror-image limbs, whatever the child order)."""
    sig: list = [None] * skeleton.num_joints
    for j in range(skeleton.num_joints - 1, -1, -1):   # children come after their parents
        sig[j] = "(" + "".join(sorted(sig[c] for c in skeleton.children(j))) + ")"
    return sig


_KINDS = (("arm", ("arm", "shoulder", "clavicle", "hand", "humerus", "radius", "wrist", "elbow", "finger",
                   "thumb", "collar")),
          ("leg", ("leg", "thigh", "hip", "femur", "tibia", "foot", "knee", "calf", "ankle", "toe", "shin")))


def limb_groups(skeleton: Skeleton) -> list[tuple[str, tuple[int, ...]]]:
    """The joints grouped by limb, for a view with one row per joint (the dope sheet): ``[(label, joints), ...]``,
    every joint in exactly one group, ascending indices inside a group.

    The trunk is every joint reached from joint 0 without entering a *limb*: a child with children of its own
    whose subtree has the same shape as one of its siblings' (mirror-image legs and arms, found from the
    hierarchy alone; single end joints such as eyes stay with their parent). Each limb is a group, labelled by
    its side and kind from the joint names (``left leg``, ``right arm``), or by its side and first joint's
    last word where the names do not say the kind (``left RibsTwist``), or that joint's name. Order: the trunk,
    then the arms, the legs and the rest, left before right.
    """
    J = skeleton.num_joints
    sig = _shape(skeleton)
    limb_of = np.full(J, -1)
    roots = []
    for j in range(1, J):
        p = int(skeleton.parents[j])
        if limb_of[p] >= 0:
            limb_of[j] = limb_of[p]
        elif sig[j] != "()" and any(sig[c] == sig[j] for c in skeleton.children(p) if c != j):
            limb_of[j] = len(roots)
            roots.append(j)
    sides = joint_sides(skeleton.names)
    groups = []
    for i, r in enumerate(roots):
        members = tuple(int(j) for j in np.flatnonzero(limb_of == i))
        words = " ".join(skeleton.names[j].lower() for j in members)
        kind = next((k for k, keys in _KINDS if any(x in words for x in keys)), None)
        side = sides[r]
        if side == "centre":
            label = skeleton.names[r]
        else:   # "left leg", or the side and the first joint's last word ("left RibsTwist")
            label = f"{side} {kind or re.split(r'[_.:|]+', skeleton.names[r])[-1]}"
        order = ({"arm": 0, "leg": 1}.get(kind, 2), {"left": 0, "right": 1}.get(side, 2), r)
        groups.append((order, label, members))
    groups.sort()
    labels = [g[1] for g in groups]
    out = [("trunk", tuple(int(j) for j in np.flatnonzero(limb_of < 0)))]
    for (_, label, members) in groups:   # two limbs of one label (two pairs of arms): add the first joint's name
        out.append((label if labels.count(label) == 1 else f"{label} ({skeleton.names[members[0]]})", members))
    return out
