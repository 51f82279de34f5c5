"""What a skeleton is drawn from: keyframe tracks, bones (cylinders or point-index pairs), world points of the
joints and End Sites, and the sizes the views scale by. Pure functions on arrays (see :mod:`stagger_nb.scene3d`
for the glossary)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.kinematics import forward_kinematics, skeleton_height
from ..core.motion import Motion
from ..core.rotations import quat_rotate

_STATIC_TOL = 1e-6


@dataclass(frozen=True)
class Tracks:
    """Keyframe tracks of one motion for a joint hierarchy (node j = joint j).

    times : (F,) float32 seconds
    root_position : (F, 3) float32, the root node's position
    quats : dict joint -> (F, 4) float32 local rotations (x, y, z, w), only joints that move
    static_quats : (J, 4) float32 rotation of every joint at frame 0 (used for joints without a track)
    translations : dict joint -> (F, 3) float32 local translations of non-root joints that are animated
    """
    times: np.ndarray
    root_position: np.ndarray
    quats: dict
    static_quats: np.ndarray
    translations: dict

    @property
    def nbytes(self) -> int:
        """Bytes of all arrays (what goes over the wire once per motion, binary)."""
        return int(self.times.nbytes + self.root_position.nbytes + sum(a.nbytes for a in self.quats.values())
                   + sum(a.nbytes for a in self.translations.values()))


def motion_tracks(motion: Motion) -> Tracks:
    """Split ``motion`` into keyframe tracks; joints whose rotation never changes (max |Δq| ≤ 1e-6) get none."""
    q = np.asarray(motion.local_quats, dtype=np.float32)
    moving = np.abs(q - q[:1]).max(axis=(0, 2)) > _STATIC_TOL
    quats = {j: np.ascontiguousarray(q[:, j]) for j in range(motion.num_joints) if moving[j]}
    trans = {}
    if motion.local_translations is not None:
        t = np.asarray(motion.local_translations, dtype=np.float32)
        for j in range(1, motion.num_joints):
            if np.abs(t[:, j] - t[:1, j]).max() > _STATIC_TOL:
                trans[j] = np.ascontiguousarray(t[:, j])
    return Tracks(times=(np.arange(motion.num_frames) * motion.frame_time).astype(np.float32),
                  root_position=np.ascontiguousarray(motion.root_positions, dtype=np.float32),
                  quats=quats, static_quats=np.ascontiguousarray(q[0]), translations=trans)


@dataclass(frozen=True)
class Bone:
    """A bone drawn as a cylinder in its parent joint's frame: from the joint origin to ``offset``.

    parent : joint index the cylinder hangs on; child : joint index at its far end, or -1 for an End Site;
    position (3,), quaternion (4,) (x, y, z, w), length : the unit-height cylinder's placement (y axis → offset).
    """
    parent: int
    child: int
    position: tuple
    quaternion: tuple
    length: float


def _y_to(v: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) rotating +y onto the direction of ``v (3,)`` (identity for ~zero v)."""
    n = float(np.linalg.norm(v))
    if n < 1e-12:
        return np.array([0.0, 0.0, 0.0, 1.0])
    d = v / n
    c = float(d[1])                       # cos of the angle between +y and d
    if c < -1 + 1e-9:                     # antipodal: half turn about x
        return np.array([1.0, 0.0, 0.0, 0.0])
    axis = np.array([d[2], 0.0, -d[0]])   # y × d
    q = np.array([axis[0], axis[1], axis[2], 1.0 + c])
    return q / np.linalg.norm(q)


def bones(motion: Motion) -> list[Bone]:
    """One bone per non-root joint (offset from the skeleton; an animated translation uses frame 0) and one per
    End Site; zero-length bones are skipped."""
    sk = motion.skeleton
    off = np.asarray(sk.offsets, dtype=float)
    if motion.local_translations is not None:
        off = np.asarray(motion.local_translations[0], dtype=float)
    out = []
    pairs = [(int(sk.parents[j]), j, off[j]) for j in range(1, sk.num_joints)]
    pairs += [(int(j), -1, np.asarray(e, dtype=float)) for j, e in sorted(sk.end_sites.items())]
    for p, c, v in pairs:
        length = float(np.linalg.norm(v))
        if length < 1e-9:
            continue
        out.append(Bone(p, c, tuple(float(x) for x in v / 2), tuple(float(x) for x in _y_to(v)), length))
    return out


def body_size(positions: np.ndarray) -> float:
    """The character's drawn height scale, file units: the median over frames of the vertical (y) extent of
    ``positions (F, J, 3)``."""
    ext = positions[..., 1].max(axis=1) - positions[..., 1].min(axis=1)
    return float(max(np.median(ext), 1e-9))


def world_positions(motion: Motion) -> np.ndarray:
    """(F, J, 3) float32 world joint positions (forward kinematics), for trails and framing."""
    p, _ = forward_kinematics(motion)
    return np.ascontiguousarray(p, dtype=np.float32)


def joint_radius(motion: Motion) -> float:
    """Sphere radius for joints: 2.2 % of the skeleton's rest extent."""
    return 0.022 * skeleton_height(motion)


def skeleton_points(motion: Motion) -> np.ndarray:
    """World positions of the joints and then the End Sites, ``(F, J + E, 3)`` float32, file units.

    End Site k (the k-th of ``sorted(skeleton.end_sites.items())``) is point ``J + k``: its joint's world
    position plus the joint's world rotation applied to the End Site offset."""
    p, wq = forward_kinematics(motion)
    ends = sorted(motion.skeleton.end_sites.items())
    if not ends:
        return np.ascontiguousarray(p, dtype=np.float32)
    idx = np.array([j for j, _ in ends], dtype=int)
    off = np.array([e for _, e in ends], dtype=float)
    out = np.empty((p.shape[0], p.shape[1] + len(ends), 3), dtype=np.float32)   # written once, as float32
    out[:, :p.shape[1]] = p
    out[:, p.shape[1]:] = p[:, idx] + quat_rotate(wq[:, idx], off)
    return out


def segments(motion: Motion) -> np.ndarray:
    """Bones as point-index pairs ``(B, 2)`` int (parent joint, child joint or End Site point ``J + k``), the
    order of :func:`bones` (non-root joints, then End Sites; zero-length ones skipped)."""
    sk = motion.skeleton
    J = sk.num_joints
    off = np.asarray(sk.offsets if motion.local_translations is None else motion.local_translations[0], float)
    pairs = [(int(sk.parents[j]), j, off[j]) for j in range(1, J)]
    pairs += [(int(j), J + k, np.asarray(e, float)) for k, (j, e) in enumerate(sorted(sk.end_sites.items()))]
    out = [(a, b) for a, b, v in pairs if np.linalg.norm(v) >= 1e-9]
    return np.array(out, dtype=int).reshape(-1, 2)
