"""ik_pose: an end effector moved to a world target at pose k's time, recorded as a staggered pose edit
(§5.1; issue 11 item 7). Checked by forward kinematics of ``evaluate(result.staggered)`` at t_k."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data, staggered
from stagger_nb.core.kinematics import forward_kinematics
from stagger_nb.staggered.limbs import _limb

MM = {"cm": 0.1, "cmu": 0.1 / (2.54 / 0.45)}   # 1 mm in file units (CMU's unit is 1/0.45 inch = 5.644 cm)


def pose_positions(sm, k):
    return forward_kinematics(staggered.evaluate(sm, [sm.pose_times[k]]))[0][0]


def reachable_target(sm, k, joint):
    """The effector pulled 20 % of the way toward its limb's upper joint and pushed sideways: inside reach."""
    p = pose_positions(sm, k)
    j = sm.skeleton.index(joint)
    up = _limb(sm.skeleton, j)[0]
    d = np.linalg.norm(p[up] - p[j])
    return p[j] + 0.2 * (p[up] - p[j]) + 0.05 * d * np.array([1.0, 0.0, 1.0])


@pytest.fixture(scope="module")
def walk_sm():
    return staggered.extract(data.load("walk"))


def check_reaches(sm, effectors, poses, mm):
    for joint in effectors:
        j = sm.skeleton.index(joint)
        for k in poses:
            tgt = reachable_target(sm, k, joint)
            for chain in (None, 3):            # two-bone (analytic) and a three-bone damped least squares
                r = staggered.ik_pose(sm, k, joint, tgt, chain=chain)
                got = pose_positions(r.staggered, k)[j]
                assert np.linalg.norm(got - tgt) <= mm, (joint, k, chain)
                assert r.reached and r.message == "" and r.error == pytest.approx(np.linalg.norm(got - tgt), abs=1e-12)


def test_reachable_targets_procedural_walk(walk_sm):
    K = walk_sm.num_poses
    check_reaches(walk_sm, ["LeftHand", "RightHand", "LeftFoot", "RightFoot"], [0, 3, K // 2, K - 1], MM["cm"])


@pytest.mark.parametrize("clip, effectors, unit", [
    ("xia_neutral_walk.bvh", ["LeftHand", "RightFoot"], "cmu"),
    ("bandai_walk.bvh", ["Hand_L", "Foot_R"], "cm"),
])
def test_reachable_targets_real_clips(shared_motion, clip, effectors, unit):
    sm = staggered.extract(shared_motion(clip))
    check_reaches(sm, effectors, [2, sm.num_poses // 2], MM[unit])


def test_two_bone_keeps_the_knee_side_and_the_rest_of_the_clip(walk_sm):
    sm, k = walk_sm, 4
    j = sm.skeleton.index("LeftFoot")
    up, mid, _ = _limb(sm.skeleton, j)
    r = staggered.ik_pose(sm, k, "LeftFoot", reachable_target(sm, k, "LeftFoot"))
    before, after = pose_positions(sm, k), pose_positions(r.staggered, k)

    def knee_out(p):        # knee's offset from the hip-ankle line
        a, c = p[up], p[j]
        u = (c - a) / np.linalg.norm(c - a)
        v = p[mid] - a
        return v - u * (v @ u)

    assert knee_out(before) @ knee_out(after) > 0.9 * np.linalg.norm(knee_out(before)) * np.linalg.norm(knee_out(after))
    # the foot keeps its world orientation (only the limb moves it)
    wq0 = forward_kinematics(staggered.evaluate(sm, [sm.pose_times[k]]))[1][0, j]
    wq1 = forward_kinematics(staggered.evaluate(r.staggered, [sm.pose_times[k]]))[1][0, j]
    assert abs(abs(wq0 @ wq1) - 1.0) < 1e-9
    # a pose edit: frames outside the neighbouring poses' knots do not change
    m0, m1 = staggered.evaluate(sm), staggered.evaluate(r.staggered)
    T = sm.knot_times()
    far = (m0.times < T[k - 1].min() - 1e-9) | (m0.times > T[k + 1].max() + 1e-9)
    assert far.any() and np.allclose(m0.local_quats[far], m1.local_quats[far], atol=1e-12)


def test_unreachable_target_stretches_toward_it(walk_sm):
    sm, k = walk_sm, 5
    j = sm.skeleton.index("LeftHand")
    up, mid, _ = _limb(sm.skeleton, j)
    p = pose_positions(sm, k)
    reach = np.linalg.norm(p[mid] - p[up]) + np.linalg.norm(p[j] - p[mid])
    direction = np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
    tgt = p[up] + 2.5 * reach * direction
    r = staggered.ik_pose(sm, k, "LeftHand", tgt)
    q = pose_positions(r.staggered, k)
    assert not r.reached
    assert "LeftHand" in r.message and "reach" in r.message and r.message.endswith(".")
    # fully stretched along the target's direction: the nearest reachable point, 1.5 reach short
    assert np.linalg.norm(q[j] - q[up]) == pytest.approx(reach, rel=1e-6)
    assert r.error == pytest.approx(1.5 * reach, rel=1e-6)
    assert np.allclose((q[j] - q[up]) / np.linalg.norm(q[j] - q[up]), direction, atol=1e-6)
    # damped least squares (shoulder, arm, forearm) also reports it, and gets near the stretched limb (the
    # damping keeps it from the singular, fully straight pose: within 10 % of the chain's reach)
    r3 = staggered.ik_pose(sm, k, "LeftHand", tgt, chain=3)
    top = sm.skeleton.index("LeftShoulder")
    reach3 = reach + np.linalg.norm(p[up] - p[top])
    dist3 = np.linalg.norm(tgt - p[top])
    assert not r3.reached and "LeftHand" in r3.message
    assert dist3 - reach3 - 1e-6 <= r3.error < dist3 - 0.9 * reach3


def test_succession_after_ik_pose_keeps_the_edit(walk_sm):
    sm, k = walk_sm, 6
    tgt = reachable_target(sm, k, "LeftHand")
    r = staggered.ik_pose(sm, k, "LeftHand", tgt)
    ch = list(_limb(sm.skeleton, sm.skeleton.index("LeftHand")))
    # the other arm's timing: the target is still met at t_k
    other = staggered.succession(r.staggered, root="RightShoulder", s=0.03, l=1.0)
    assert np.linalg.norm(pose_positions(other, k)[ch[-1]] - tgt) <= MM["cm"]
    # the edited arm's timing: the edited knots keep their values and move with the refined times
    stag = staggered.succession(r.staggered, root="LeftShoulder", s=0.03, l=1.0)
    assert np.allclose(stag.values[k, ch], r.staggered.values[k, ch])
    assert not np.allclose(stag.knot_times()[k, ch], r.staggered.knot_times()[k, ch])
    plain = staggered.succession(sm, root="LeftShoulder", s=0.03, l=1.0)
    for i in ch:
        T = stag.knot_times()[k, i]
        q = staggered.evaluate(stag, [T]).local_quats[0, i]
        assert abs(abs(q @ stag.values[k, i]) - 1.0) < 1e-9            # the knot passes through the edit
        q0 = staggered.evaluate(plain, [T]).local_quats[0, i]
        assert abs(abs(q0 @ q) - 1.0) > 1e-6                           # which differs from the unedited one


def test_ik_pose_bad_input(walk_sm):
    sm = walk_sm
    with pytest.raises(ValueError, match="target"):
        staggered.ik_pose(sm, 2, "LeftHand", [1.0, 2.0])
    with pytest.raises(ValueError, match="pose"):
        staggered.ik_pose(sm, sm.num_poses, "LeftHand", [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="joint"):
        staggered.ik_pose(sm, 2, "Tail", [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="chain"):
        staggered.ik_pose(sm, 2, "LeftHand", [0.0, 0.0, 0.0], chain=["RightArm", "LeftHand"])
    with pytest.raises(ValueError, match="sm"):
        staggered.ik_pose(data.load("walk"), 2, "LeftHand", [0.0, 0.0, 0.0])


def test_ik_pose_on_a_timing_edited_motion(walk_sm):
    """After succession and an off-frame retime (t_k off the displacement grid), the solve-record-check
    rounds still meet the target within 1 mm."""
    k = 5
    sm = staggered.succession(walk_sm, root="LeftShoulder", s=0.03, l=1.0)
    sm = staggered.retime(sm, {k: sm.pose_times[k] + 0.071})
    for joint in ("LeftHand", "RightFoot"):
        tgt = reachable_target(sm, k, joint)
        r = staggered.ik_pose(sm, k, joint, tgt)
        assert r.reached and np.linalg.norm(pose_positions(r.staggered, k)[sm.skeleton.index(joint)] - tgt) <= MM["cm"]
