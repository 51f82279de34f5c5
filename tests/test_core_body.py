"""Pelvis, vertical axis and heading on any rig (issue 13 items 9 and 10): a static root above the hips
must not leak global travel into torso-frame features."""
from __future__ import annotations

import numpy as np
import pytest
from rigs import static_root_rig

from stagger_nb import Motion, Skeleton, data, forward_kinematics
from stagger_nb.core.body import heading_quats, pelvis_joint, remove_heading, up_axis
from stagger_nb.core.rotations import quat_angle, quat_mul, rotvec_to_quat
from stagger_nb.timewarp import pose_features


def moved_root(m: Motion, seed: int = 0, tilt: float = 0.01, rise: float = 3.0) -> Motion:
    """``m`` with a time-varying rigid motion of joint 0 (turns about the vertical with a random ``tilt`` (rad)
    about every axis, and travels, rising ``rise`` over the clip)."""
    F = m.num_frames
    t = np.linspace(0.0, 1.0, F)
    rng = np.random.default_rng(seed)
    rot = rotvec_to_quat(np.outer(np.sin(3 * t) * 2.0, [0.0, 1.0, 0.0]) + tilt * rng.normal(size=(F, 3)))
    q = m.local_quats.copy()
    q[:, 0] = quat_mul(rot, q[:, 0])
    return m.replace(local_quats=q, root_positions=m.root_positions + np.outer(t, [500.0, rise, -200.0]))


@pytest.fixture(scope="module")
def walk():
    return data.load("walk")


def test_pelvis_of_known_rigs(walk, shared_motion):
    assert pelvis_joint(walk.skeleton) == 0
    assert static_root_rig(walk).skeleton.names[pelvis_joint(static_root_rig(walk).skeleton)] == "Hips"
    for name in ("bandai_walk.bvh", "bandai_run_cycle.bvh", "pymo_walk_turnaround.bvh", "xia_neutral_walk.bvh"):
        m = shared_motion(name)
        assert m.skeleton.names[pelvis_joint(m.skeleton)] == "Hips", name


def test_pelvis_of_small_rigs():
    sk = Skeleton(("a", "b", "c", "d"), np.array([-1, 0, 1, 2]), np.ones((4, 3)))
    assert pelvis_joint(sk) == 0    # a single chain: its root
    sk2 = Skeleton(("root", "hips", "l1", "l2", "r1", "r2"), np.array([-1, 0, 1, 2, 1, 4]), np.ones((6, 3)))
    assert pelvis_joint(sk2) == 1   # two chains only: the deepest common ancestor of the leaves


def test_torso_features_ignore_a_static_root(walk):
    """The same walk with and without a static root above the hips gives the same features."""
    np.testing.assert_allclose(pose_features(static_root_rig(walk)), pose_features(walk), atol=1e-9)


def test_torso_features_ignore_any_motion_of_the_static_root(walk):
    """Turning and translating the static root (the Bandai run cycle's moving joint_Root) changes nothing in the
    pelvis's frame (the paper's torso frame); the default features (+ the pelvis's height above the floor) are
    free of travel on the ground and of turns about the vertical, not of a rise or a tilt of the whole world."""
    rig = static_root_rig(walk)
    np.testing.assert_allclose(pose_features(moved_root(rig), frame="pelvis"), pose_features(rig, frame="pelvis"),
                               atol=1e-9)
    level = moved_root(rig, tilt=0.0, rise=0.0)
    np.testing.assert_allclose(pose_features(level), pose_features(rig), atol=1e-9)
    np.testing.assert_allclose(pose_features(level, frame="heading"), pose_features(rig, frame="heading"), atol=1e-9)
    lifted = rig.replace(root_positions=rig.root_positions + np.array([0.0, 40.0, 0.0]))   # a raised floor
    np.testing.assert_allclose(pose_features(lifted), pose_features(rig), atol=1e-9)
    # the height is in: a rise of the whole character over the clip changes the default features
    assert np.abs(pose_features(moved_root(rig, tilt=0.0)) - pose_features(rig)).max() > 1.0


@pytest.mark.parametrize("name", ["bandai_walk.bvh", "bandai_run_cycle.bvh"])
def test_bandai_torso_features_carry_no_travel(shared_motion, name):
    m = shared_motion(name)
    pos, _ = forward_kinematics(m)
    travel = np.linalg.norm(pos[-1, 1] - pos[0, 1])            # the hips travel (bandai_walk: ~800 cm)
    X = pose_features(m, prefilter=0.0, frame="pelvis").reshape(m.num_frames, -1, 3)
    assert travel > 100.0
    # in the torso frame every joint stays within a body length of the pelvis, and moves little over the clip
    assert np.linalg.norm(X, axis=-1).max() < 120.0
    assert np.ptp(X.mean(axis=1), axis=0).max() < 20.0
    np.testing.assert_allclose(pose_features(moved_root(m), frame="pelvis"), pose_features(m, frame="pelvis"),
                               atol=1e-7)
    np.testing.assert_allclose(pose_features(moved_root(m, tilt=0.0, rise=0.0)), pose_features(m), atol=1e-7)


def test_up_axis_and_heading(walk, shared_motion):
    np.testing.assert_array_equal(up_axis(walk), [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(up_axis(shared_motion("bandai_walk.bvh")), [0.0, 1.0, 0.0])
    rng = np.random.default_rng(3)
    up = np.array([0.0, 1.0, 0.0])
    tilt = rotvec_to_quat(rng.normal(size=(50, 3)) * [0.3, 0.0, 0.3])      # pitch/roll only
    yaw = rotvec_to_quat(np.outer(rng.uniform(-3, 3, 50), up))
    q = quat_mul(yaw, tilt)
    assert quat_angle(heading_quats(q, up), yaw).max() < 1e-9
    assert quat_angle(remove_heading(q, up), tilt).max() < 1e-9


def _groups_by_label(sk):
    from stagger_nb.core.body import limb_groups
    groups = limb_groups(sk)
    members = sorted(j for _, js in groups for j in js)
    assert members == list(range(sk.num_joints)), "every joint in exactly one group"
    assert all(list(js) == sorted(js) for _, js in groups)
    return {label: [sk.names[j] for j in js] for label, js in groups}


@pytest.mark.parametrize("name", ["cmu_131_01_walk_startstop.bvh", "bandai_walk.bvh", "pymo_walk_turnaround.bvh",
                                  "xia_neutral_walk.bvh", "iclone_cmu_07_01_walk.bvh"])
def test_limb_groups_of_real_rigs(shared_motion, name):
    """Trunk, two arms, two legs on every rig (found from the hierarchy's mirror-image subtrees; the names give
    only the labels); each limb's joints are one subtree and the legs hold the feet, the arms the hands."""
    sk = shared_motion(name).skeleton
    g = _groups_by_label(sk)
    assert list(g)[:5] == ["trunk", "left arm", "right arm", "left leg", "right leg"], list(g)
    from stagger_nb.core.body import subtree
    for label in ("left arm", "right arm", "left leg", "right leg"):
        first = sk.index(g[label][0])
        assert sorted(g[label]) == sorted(sk.names[j] for j in subtree(sk, first))
    assert any(w in n.lower() for n in g["left leg"] for w in ("foot", "ankle")), g["left leg"]
    assert any(w in n.lower() for n in g["right arm"] for w in ("hand", "wrist")), g["right arm"]
    assert sk.names[0] in g["trunk"] and len(g["left arm"]) == len(g["right arm"])


def test_limb_groups_of_small_rigs():
    # no mirror-image subtrees: one group; single end joints (eyes) stay in the trunk
    chain = Skeleton(("a", "b", "c"), np.array([-1, 0, 1]), np.ones((3, 3)))
    assert _groups_by_label(chain) == {"trunk": ["a", "b", "c"]}
    eyes = Skeleton(("root", "head", "LeftEye", "RightEye"), np.array([-1, 0, 1, 1]), np.ones((4, 3)))
    assert _groups_by_label(eyes) == {"trunk": ["root", "head", "LeftEye", "RightEye"]}
    # unnamed mirror limbs: labelled by their first joint; sides from any naming scheme
    toy = Skeleton(("root", "a1", "a2", "b1", "b2"), np.array([-1, 0, 1, 0, 3]), np.ones((5, 3)))
    assert _groups_by_label(toy) == {"trunk": ["root"], "a1": ["a1", "a2"], "b1": ["b1", "b2"]}
    from stagger_nb.core.body import joint_sides
    assert joint_sides(["mixamorig:LeftUpLeg", "CC_Base_R_Thigh", "Hand.L", "lhumerus", "LowerBack", "RThumb",
                        "Head", "root"]) == ["left", "right", "left", "left", "centre", "right", "centre", "centre"]
