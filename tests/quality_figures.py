"""The hand-built 170 cm figure (Y up, cm) the quality tests share, standing on both feet."""
from __future__ import annotations

import numpy as np

from stagger_nb.core.motion import Motion
from stagger_nb.core.skeleton import Skeleton

# a standing figure, Y up, cm: hips at 90, head at 170, feet at 0 (body height 170 exactly: scale 1)
NAMES = ("Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "RightUpLeg", "RightLeg", "RightFoot", "Spine", "Chest",
         "Neck", "Head")


PARENTS = (-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 9)


OFFSETS = [(0, 0, 0), (10, 0, 0), (0, -45, 0), (0, -45, 0), (-10, 0, 0), (0, -45, 0), (0, -45, 0),
           (0, 20, 0), (0, 20, 0), (0, 20, 0), (0, 20, 0)]


F, FT = 60, 1 / 30


FEET = [("LeftFoot", 0, F), ("RightFoot", 0, F)]


def standing(root=None, quats=None) -> Motion:
    sk = Skeleton(NAMES, PARENTS, np.array(OFFSETS, float))
    rp = np.tile([0.0, 90.0, 0.0], (F, 1)) if root is None else root
    q = np.tile([0.0, 0.0, 0.0, 1.0], (F, len(NAMES), 1)) if quats is None else quats
    return Motion(sk, FT, rp, q)
