"""exaggerate's per-pose offsets (§5.1, ``v̂ = v ⊕ w_r (v ⊖ vʳ)``) computed for every pose at once equal the
straightforward one-pose-at-a-time loop bit for bit, for every kind of reference."""
from __future__ import annotations

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import staggered
from stagger_nb.core.rotations import quat_conj, quat_exp, quat_hemisphere, quat_log, quat_mul
from stagger_nb.staggered.geometry import _apply_pose_offsets, mean_pose

IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])


def naive_offsets(sm, ks, w_r, reference, mode="staggered", joints=None):
    """The offsets table (K, J, 4), one pose at a time, in the most straightforward manner."""
    vals = sm.editing_knots if mode == "staggered" else sm.values
    K, J = sm.num_poses, sm.num_joints
    names = sm.skeleton.names
    mask = np.array([joints is None or n in joints for n in names])
    full = np.tile(IDENTITY, (K, J, 1))
    for k in ks:
        if reference == "previous":
            ref = vals[k - 1] if k > 0 else vals[k + 1]
        elif reference == "next":
            ref = vals[k + 1] if k < K - 1 else vals[k - 1]
        elif reference == "mean":
            ref = mean_pose(vals)
        elif isinstance(reference, int):
            ref = vals[reference]
        else:
            ref = np.array([reference.get(n, vals[k][j]) for j, n in enumerate(names)], dtype=float)
        delta = quat_exp(w_r * quat_log(quat_hemisphere(quat_mul(quat_conj(ref), vals[k]))))
        full[k] = np.where(mask[:, None], delta, IDENTITY)
    return full


@pytest.fixture(scope="module")
def sm():
    return staggered.cull(staggered.extract(sn.data.load("walk")), percent=60)


@pytest.mark.parametrize("ks, w_r, reference, mode, joints", [
    ("all", 0.73, "previous", "staggered", None),
    ("all", -0.4, "next", "staggered", None),
    ("all", 1.3, "mean", "unstaggered", None),
    ([0, 2, -1], 0.9, 1, "staggered", None),
    ([1, 3], 0.6, {"LeftUpLeg": [0.0, 0.0, 0.3826834323650898, 0.9238795325112867]}, "staggered", None),
    ([0], 0.8, "previous", "staggered", ["LeftUpLeg", "LeftLeg"]),
    ([2, 2, 4], 0.3, "previous", "unstaggered", None),
])
def test_exaggerate_equals_the_pose_by_pose_offsets(sm, ks, w_r, reference, mode, joints):
    K = sm.num_poses
    ks = list(range(K)) if ks == "all" else [k % K for k in ks]
    if isinstance(reference, dict):
        assert all(n in sm.skeleton.names for n in reference)
    got = staggered.exaggerate(sm, ks, w_r, reference=reference, mode=mode, joints=joints)
    want = _apply_pose_offsets(sm, naive_offsets(sm, ks, w_r, reference, mode, joints))
    for a, b in ((got.values, want.values), (got.tangents, want.tangents), (got.displacements, want.displacements)):
        assert np.array_equal(a, b)
