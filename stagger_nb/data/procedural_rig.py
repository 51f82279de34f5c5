"""The rig of the procedural clips (:mod:`.procedural`): a CMU-like 31-joint skeleton in centimetres, Y up,
facing +Z (:func:`cmu_skeleton`), and the measures the clips are built from (leg bones, ankle height, hips,
feet, reach, the arms' hang, the frame rate and gravity)."""
from __future__ import annotations

import numpy as np

from ..core.skeleton import Skeleton

__all__ = ["cmu_skeleton", "FPS", "GRAVITY", "THIGH", "SHIN", "ANKLE_HEIGHT"]

FPS = 60.0             # frames per second of every clip
GRAVITY = 981.0        # cm / s^2
THIGH = 42.0           # cm, hip to knee
SHIN = 42.0            # cm, knee to ankle
ANKLE_HEIGHT = 8.0     # cm, ankle above the ground when the foot is flat
_HIP = (9.0, -8.0, 0.0)    # cm, left hip joint from the pelvis centre
_FOOT_X = 10.0             # cm, lateral position of a planted ankle from the travel line
_REACH = 0.99 * (THIGH + SHIN)  # cm, the farthest a planted ankle may be from its hip
_ARM_HANG = 75.0           # degrees, arms from T-pose down to the sides

# (name, parent name, offset cm, end-site offset cm or None), CMU / MotionBuilder-friendly layout; the right
# side is the left one mirrored (:func:`_mirrored`)
_LEFT_LEG = [
    ("LHipJoint", "Hips", (0, 0, 0), None),
    ("LeftUpLeg", "LHipJoint", _HIP, None),
    ("LeftLeg", "LeftUpLeg", (0, -THIGH, 0), None),
    ("LeftFoot", "LeftLeg", (0, -SHIN, 0), None),
    ("LeftToeBase", "LeftFoot", (0, -6.5, 13.0), (0, 0, 6.0)),
]
_SPINE = [
    ("LowerBack", "Hips", (0, 0, 0), None),
    ("Spine", "LowerBack", (0, 12.0, -1.0), None),
    ("Spine1", "Spine", (0, 12.0, 0.5), None),
    ("Neck", "Spine1", (0, 0, 0), None),
    ("Neck1", "Neck", (0, 21.0, 1.0), None),
    ("Head", "Neck1", (0, 10.0, 0.5), (0, 15.0, 0)),
]
_LEFT_ARM = [
    ("LeftShoulder", "Spine1", (0, 0, 0), None),
    ("LeftArm", "LeftShoulder", (17.0, 19.0, -1.0), None),
    ("LeftForeArm", "LeftArm", (28.0, 0, 0), None),
    ("LeftHand", "LeftForeArm", (25.0, 0, 0), None),
    ("LeftFingerBase", "LeftHand", (0, 0, 0), None),
    ("LeftHandIndex1", "LeftFingerBase", (8.0, 0, 0), (4.0, 0, 0)),
    ("LThumb", "LeftHand", (2.0, 0, 2.5), (3.0, 0, 3.0)),
]


def _mirrored(rows):
    """The right side's rows from the left side's: ``Left*`` -> ``Right*`` and ``L<Upper>*`` -> ``R<Upper>*``
    (LHipJoint, LThumb), x of each offset negated as ``0 - x`` (a zero stays +0.0)."""
    def side(name):
        if name is None or name.startswith("Left"):
            return name and "Right" + name[4:]
        return "R" + name[1:] if name[0] == "L" and name[1].isupper() else name

    def flip(v):
        return None if v is None else (0 - v[0], v[1], v[2])
    return [(side(n), side(p), flip(o), flip(e)) for n, p, o, e in rows]


_LAYOUT = [("Hips", None, (0, 0, 0), None), *_LEFT_LEG, *_mirrored(_LEFT_LEG), *_SPINE, *_LEFT_ARM,
           *_mirrored(_LEFT_ARM)]


def cmu_skeleton() -> Skeleton:
    """The 31-joint CMU-like skeleton (joint names of the CMU MotionBuilder-friendly BVH files), in cm,
    Y up, facing +Z, T-pose at rest. Root channels ``X/Y/Zposition Z/Y/Xrotation``, the others ``Z/Y/X``."""
    names = [r[0] for r in _LAYOUT]
    parents = [-1 if r[1] is None else names.index(r[1]) for r in _LAYOUT]
    offsets = np.array([r[2] for r in _LAYOUT], dtype=float)
    rot = ("Zrotation", "Yrotation", "Xrotation")
    channels = [("Xposition", "Yposition", "Zposition") + rot] + [rot] * (len(names) - 1)
    end_sites = {j: np.array(r[3], dtype=float) for j, r in enumerate(_LAYOUT) if r[3] is not None}
    return Skeleton(tuple(names), np.array(parents), offsets, tuple(channels), end_sites)

