"""Hand-built rigs the tests share."""
from __future__ import annotations

import numpy as np

from stagger_nb import Motion, Skeleton


def static_root_rig(m: Motion) -> Motion:
    """``m`` with a static ``joint_Root`` at the origin inserted above joint 0, which keeps the motion as its
    own animated translation (the Bandai layout)."""
    sk = m.skeleton
    J = sk.num_joints
    skel = Skeleton(("joint_Root",) + sk.names, np.concatenate([[-1], np.where(sk.parents < 0, 0, sk.parents + 1)]),
                    np.vstack([np.zeros(3), sk.offsets]))
    F = m.num_frames
    lt = np.empty((F, J + 1, 3))
    lt[:, 1:] = m.local_translations if m.local_translations is not None else sk.offsets
    lt[:, 0] = 0.0
    lt[:, 1] = m.root_positions
    q = np.concatenate([np.tile([0.0, 0.0, 0.0, 1.0], (F, 1, 1)), m.local_quats], axis=1)
    return Motion(skel, m.frame_time, np.zeros((F, 3)), q, lt)
