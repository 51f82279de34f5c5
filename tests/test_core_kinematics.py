"""Forward kinematics: a hand-computed fixture, an independent 4x4-matrix implementation on the real
clips, and the torso-frame positions of guided time warping."""
import numpy as np
import pytest
from conftest import SHARED_CLIPS
from references import forward_kinematics_reference
from scipy.spatial.transform import Rotation

from stagger_nb.core import Motion, Skeleton, fk_arrays, forward_kinematics, positions_in_root_frame, skeleton_height
from stagger_nb.core.rotations import quat_to_matrix

ALL_CLIPS = ["bandai_kick.bvh", "bandai_run_cycle.bvh", "bandai_walk.bvh", "cmu_131_01_walk_startstop.bvh",
             "iclone_cmu_02_03_run.bvh", "iclone_cmu_07_01_walk.bvh", "pymo_walk_turnaround.bvh",
             "xia_angry_run.bvh", "xia_depressed_run.bvh", "xia_neutral_walk.bvh", "xia_sexy_walk.bvh"]


def three_joint_motion():
    """Root at (1, 2, 3) turned 90 deg about Z; child 1 unit along x, turned 90 deg about X;
    grandchild 1 unit along y."""
    skel = Skeleton(["root", "a", "b"], [-1, 0, 1], [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    s = np.sqrt(0.5)
    q = np.array([[[0, 0, s, s], [s, 0, 0, s], [0, 0, 0, 1]]], dtype=float)
    return Motion(skel, 1 / 30, [[1.0, 2.0, 3.0]], q)


def test_hand_computed_three_joint_chain():
    m = three_joint_motion()
    pos, wq = forward_kinematics(m)
    # a: (1,2,3) + Rz90 (1,0,0) = (1,3,3); b: a + Rz90 Rx90 (0,1,0) = a + Rz90 (0,0,1) = (1,3,4)
    assert np.allclose(pos[0], [[1, 2, 3], [1, 3, 3], [1, 3, 4]], atol=1e-15)
    # world rotation of b = Rz90 Rx90 maps x -> y, y -> z, z -> x
    assert np.allclose(quat_to_matrix(wq[0, 2]), [[0, 0, 1], [1, 0, 0], [0, 1, 0]], atol=1e-15)
    # in the root frame: Rz(-90) (p - p_root)
    assert np.allclose(positions_in_root_frame(m)[0], [[0, 0, 0], [1, 0, 0], [1, 0, 1]], atol=1e-15)


def test_animated_translations_replace_offsets():
    m = three_joint_motion()
    lt = np.array([[[9, 9, 9], [2, 0, 0], [0, 1, 0]]], dtype=float)
    pos, _ = forward_kinematics(m.replace(local_translations=lt))
    assert np.allclose(pos[0], [[1, 2, 3], [1, 4, 3], [1, 4, 4]], atol=1e-15)  # row 0 of lt is ignored


def random_tree_motion(F=40, J=12, seed=0):
    rng = np.random.default_rng(seed)
    parents = [-1] + [int(rng.integers(0, j)) for j in range(1, J)]
    skel = Skeleton([f"j{j}" for j in range(J)], parents, rng.normal(size=(J, 3)))
    q = Rotation.random(F * J, random_state=seed).as_quat().reshape(F, J, 4)
    return Motion(skel, 0.01, rng.normal(size=(F, 3)), q)


def test_matches_reference_on_random_trees():
    for seed in range(3):
        m = random_tree_motion(seed=seed)
        pos, wq = forward_kinematics(m)
        rpos, rmat = forward_kinematics_reference(m)
        assert np.allclose(pos, rpos, rtol=0, atol=1e-12)  # rounding over <= 12 composed transforms
        assert np.allclose(quat_to_matrix(wq), rmat, atol=1e-12)


def test_fk_arrays_forms_agree_and_validate():
    m = random_tree_motion(F=5)
    t = m.translations()
    p1, q1 = fk_arrays(m.local_quats, t, m.skeleton.parents)
    p2, q2 = forward_kinematics(m)
    assert np.array_equal(p1, p2) and np.array_equal(q1, q2)
    const = t[0]  # (J, 3): the root's row is then a fixed world position
    p3, _ = fk_arrays(m.local_quats, const, m.skeleton.parents)
    p4, _ = fk_arrays(m.local_quats, np.broadcast_to(const, t.shape), m.skeleton.parents)
    assert np.array_equal(p3, p4)
    with pytest.raises(ValueError, match="local_quats"):
        fk_arrays(np.zeros((5, 12)), t, m.skeleton.parents)
    with pytest.raises(ValueError, match="translations"):
        fk_arrays(m.local_quats, np.zeros((5, 11, 3)), m.skeleton.parents)
    bad = np.array(m.skeleton.parents)
    bad[1] = 5  # a parent after its child
    with pytest.raises(ValueError, match="parents"):
        fk_arrays(m.local_quats, t, bad)
    with pytest.raises(ValueError, match="parents"):
        fk_arrays(m.local_quats, t, bad[:-1])


def test_outputs_are_fresh_contiguous_arrays():
    m = random_tree_motion(F=5)
    pos, wq = forward_kinematics(m)
    assert pos.shape == (5, 12, 3) and wq.shape == (5, 12, 4)
    assert pos.flags.c_contiguous and wq.flags.c_contiguous and pos.flags.writeable


@pytest.mark.shared
@pytest.mark.parametrize("name", ALL_CLIPS)
def test_matches_scipy_composed_transforms_on_real_clips(name, shared_motion):
    m = shared_motion(name)
    pos, wq = forward_kinematics(m)
    rpos, rmat = forward_kinematics_reference(m)
    scale = np.abs(rpos).max()
    assert np.abs(pos - rpos).max() <= 1e-6 * scale  # the 1e-6 relative; actual ~1e-15
    assert np.abs(quat_to_matrix(wq) - rmat).max() <= 1e-9  # rotation entries, rounding over ~10 levels
    # root frame: the root row is zero and the distances to the root are preserved
    rf = positions_in_root_frame(m, pos, wq)
    assert np.abs(rf[:, 0]).max() == 0.0
    assert np.allclose(np.linalg.norm(rf, axis=-1), np.linalg.norm(pos - pos[:, :1], axis=-1), atol=1e-9 * scale)


def test_shared_clip_list_is_what_we_test():
    if not SHARED_CLIPS:
        pytest.skip("../shared/mocap not present")
    assert sorted(ALL_CLIPS) == SHARED_CLIPS


def test_skeleton_height_is_rest_pose_extent():
    m = three_joint_motion()
    assert skeleton_height(m) == pytest.approx(1.0)  # rest joints (0,0,0), (1,0,0), (1,1,0): largest extent 1
    # animated root translation and rotations do not change it
    far = m.replace(root_positions=[[500.0, -40.0, 9.0]])
    assert skeleton_height(far) == skeleton_height(m)
    # End Sites count: one 3 units above b stretches y to 4
    skel = Skeleton(m.skeleton.names, m.skeleton.parents, m.skeleton.offsets, end_sites={2: [0.0, 3.0, 0.0]})
    assert skeleton_height(m.replace(skeleton=skel)) == pytest.approx(4.0)


def test_skeleton_height_of_bandai_walk_is_body_sized(shared_motion):
    # joint_Root stays at the origin while the Hips walk away: the rest pose gives the body's size (cm)
    h = skeleton_height(shared_motion("bandai_walk.bvh"))
    assert 120 < h < 220
