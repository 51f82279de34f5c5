"""Reads of a clip the time-warp tests share."""
from __future__ import annotations

import numpy as np

from stagger_nb.core.kinematics import forward_kinematics


def airborne(m):
    """Frames where both toes are more than 5 cm above the ground level (5th percentile of the lower toe)."""
    p, _ = forward_kinematics(m)
    names = m.skeleton.names
    toes = p[:, [names.index("LeftToeBase"), names.index("RightToeBase")], 1].min(axis=1)
    return toes > np.percentile(toes, 5) + 5.0
