"""Pose vectors of the magic wand: log map about a per-joint reference, q / -q invariance, weights."""
import numpy as np
import pytest
from wand_motions import cyclic_motion

from stagger_nb.core.rotations import quat_angle, quat_hemisphere, quat_log, quat_mul, rotvec_to_quat
from stagger_nb.wand import mean_rotations, pose_exps, pose_logs, pose_vectors


def test_q_and_minus_q_give_the_same_pose_vector(rng):
    m = cyclic_motion(F=50, noise=0.1, seed=1)
    signs = rng.choice([-1.0, 1.0], size=m.local_quats.shape[:2])[..., None]
    flipped = m.local_quats * signs
    for ref in (None, mean_rotations(m.local_quats)):
        # exact: the canonical sign is chosen before the log is taken
        assert np.array_equal(pose_logs(flipped, ref), pose_logs(m.local_quats, ref))
    # a Motion re-signs its quaternions on construction; the vectors must not notice
    m2 = m.replace(local_quats=flipped)
    assert np.allclose(pose_vectors(m2), pose_vectors(m), atol=1e-15)  # identical up to the last bit


def test_log_exp_round_trip_about_a_reference(rng):
    q = rotvec_to_quat(rng.normal(size=(20, 5, 3)))
    ref = rotvec_to_quat(rng.normal(size=(5, 3)))
    back = pose_exps(pose_logs(q, ref), ref)
    # same rotation up to sign; 1e-12 = a few ulps of the trig round trip
    assert np.allclose(np.abs(np.sum(back * q, axis=-1)), 1.0, atol=1e-12)


def test_identity_reference_is_the_plain_log(rng):
    q = rotvec_to_quat(rng.normal(size=(10, 3, 3)))
    assert np.allclose(pose_logs(q, None), quat_log(quat_hemisphere(q)), atol=0)
    m = cyclic_motion(F=10, J=3, seed=2)
    X = pose_vectors(m, reference="identity", heading="keep")
    assert np.allclose(X, quat_log(quat_hemisphere(m.local_quats)).reshape(10, -1), atol=0)


def test_mean_rotation_recovers_a_known_centre(rng):
    centre = rotvec_to_quat(np.array([[0.3, -1.2, 2.0], [2.9, 0.1, 0.0]]))
    # symmetric perturbations (+e and -e) around each centre: the chordal mean is the centre itself
    e = rotvec_to_quat(0.2 * rng.normal(size=(15, 2, 3)))
    einv = e * np.array([-1.0, -1.0, -1.0, 1.0])
    q = quat_mul(centre[None], np.concatenate([e, einv]))
    q *= rng.choice([-1.0, 1.0], size=q.shape[:2])[..., None]  # signs must not matter
    got = mean_rotations(q)
    assert np.all(got[:, 3] >= 0)
    # 1e-9 rad: eigenvector of a 4x4 matrix with a clear gap, to rounding
    assert np.all(quat_angle(got, centre) < 1e-9)


def test_joint_weights_and_time_term():
    m = cyclic_motion(F=30, J=4, seed=3)
    X = pose_vectors(m)
    Xw = pose_vectors(m, joint_weights={"j1": 0.0, "j2": 2.0})
    assert np.array_equal(Xw[:, 3:6], np.zeros((30, 3)))
    assert np.allclose(Xw[:, 6:9], 2 * X[:, 6:9], atol=0)
    assert np.allclose(pose_vectors(m, joint_weights=[1, 0, 2, 1]), Xw, atol=0)
    Xt = pose_vectors(m, time_weight=3.0)
    assert Xt.shape == (30, 13)
    assert np.allclose(Xt[:, -1], 3.0 * m.times, atol=0)
    with pytest.raises(ValueError, match="joint_weights"):
        pose_vectors(m, joint_weights={"nope": 1.0})
    with pytest.raises(ValueError, match="joint_weights"):
        pose_vectors(m, joint_weights=[1, 2])
    with pytest.raises(ValueError, match="time_weight"):
        pose_vectors(m, time_weight=-1)
    with pytest.raises(ValueError, match="reference"):
        pose_vectors(m, reference="median")


@pytest.mark.shared
def test_mean_reference_avoids_the_log_cut_near_pi(shared_motion):
    # Bandai's upper legs sit at ~179 degrees: about the identity their log jumps by ~pi between
    # consecutive frames; about the per-joint mean the trajectory is continuous.
    m = shared_motion("bandai_run_cycle.bvh")
    step_id = np.linalg.norm(np.diff(pose_vectors(m, reference="identity"), axis=0), axis=1).max()
    step_mean = np.linalg.norm(np.diff(pose_vectors(m), axis=0), axis=1).max()
    assert step_id > 2.0      # a ~pi jump (a half-turn of the log, |log| = angle / 2 on each side)
    assert step_mean < 0.6    # the largest real frame-to-frame change of this 30 Hz run
