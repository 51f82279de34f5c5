"""The magic wand's default pose space is heading-invariant (issue 13 item 10): on a walk that turns, the same
phase one stride later gets w >= 0.8 and the opposite phase w <= 0.1; ``heading="keep"`` is the paper's form."""
from __future__ import annotations

import numpy as np
import pytest
from rigs import static_root_rig

from stagger_nb import data, wand
from stagger_nb.core.rotations import quat_mul, quat_rotate, rotvec_to_quat
from stagger_nb.wand.laplacian import pairwise_sq_distances


def turning(m, deg_per_s=60.0):
    """``m`` turning left at a constant rate: joint 0's rotation and the travel direction yaw progressively."""
    yaw = rotvec_to_quat(np.outer(np.radians(deg_per_s) * m.times, [0.0, 1.0, 0.0]))
    q = np.array(m.local_quats)
    q[:, 0] = quat_mul(yaw, q[:, 0])
    step = np.diff(m.root_positions, axis=0, prepend=m.root_positions[:1])
    return m.replace(local_quats=q, root_positions=m.root_positions[0] + np.cumsum(quat_rotate(yaw, step), axis=0))


def phases(m, i):
    """(same phase, opposite phase) of frame ``i``: the frame >= 0.4 s away whose heading-free pose is closest
    (one stride later or earlier on these clips), and halfway between the two."""
    X = wand.pose_vectors(m)
    d = np.sqrt(pairwise_sq_distances(X[[i]], X))[0]
    far = np.flatnonzero(np.abs(np.arange(m.num_frames) - i) >= round(0.4 / m.frame_time))
    j = int(far[np.argmin(d[far])])
    return j, (i + j) // 2


@pytest.fixture(scope="module")
def walk():
    return data.load("walk")


def test_pose_vectors_ignore_the_heading(walk):
    np.testing.assert_allclose(wand.pose_vectors(turning(walk)), wand.pose_vectors(walk), atol=1e-9)
    rig = static_root_rig(walk)   # the heading on a static root above the hips (Bandai layout) is removed too
    np.testing.assert_allclose(wand.pose_vectors(turning(rig)), wand.pose_vectors(rig), atol=1e-9)
    # ... but pitch and roll of the pelvis are kept (a varying pitch: the mean-relative log ignores a constant)
    q = np.array(walk.local_quats)
    q[:, 0] = quat_mul(rotvec_to_quat(np.outer(0.3 * np.sin(3.0 * walk.times), [1.0, 0.0, 0.0])), q[:, 0])
    assert np.abs(wand.pose_vectors(walk.replace(local_quats=q)) - wand.pose_vectors(walk)).max() > 0.05
    with pytest.raises(ValueError, match="heading"):
        wand.pose_vectors(walk, heading="yaw")


@pytest.mark.parametrize("frame", [30, 60, 100])
def test_turning_walk_same_phase_gets_the_edit(walk, frame):
    """Measured: w(same phase) = 1.00 / 1.00 / 1.00, w(opposite) = 0.03 / 0.04 / 0.00; with the heading kept
    (the paper's form) 0.03 / 0.01 / 0.48 at the same phase."""
    m = turning(walk)
    j, o = phases(walk, frame)
    w = wand.falloff(m, frame)
    assert w[j] >= 0.8 and w[o] <= 0.1, (j, w[j], o, w[o])
    if frame != 100:
        assert wand.falloff(m, frame, heading="keep")[j] < 0.5   # the paper's form fails here


def test_real_turning_walk(shared_motion):
    """pymo_walk_turnaround (120 Hz, walks, turns ~250 degrees, walks back). Frames of steady walking before,
    during and after the turn. (Scanning every 50th frame: 12 of 17 pass both bounds; the others sit in the
    turn-around steps, whose pose recurs nowhere else in the clip.)"""
    m = shared_motion("pymo_walk_turnaround.bvh")
    basis = wand.greens_basis(m)
    for i in (200, 450, 500, 600):
        j, o = phases(m, i)
        w = wand.greens_falloff(basis, i)
        assert w[j] >= 0.8 and w[o] <= 0.1, (i, j, w[j], o, w[o])


def _yaw_joint0(m, deg_per_s, axis):
    """Joint 0 yawing at a constant rate about ``axis`` (its own translation left as it is)."""
    q = np.array(m.local_quats)
    q[:, 0] = quat_mul(rotvec_to_quat(np.outer(np.radians(deg_per_s) * m.times, axis)), q[:, 0])
    return m.replace(local_quats=q)


def _z_up(m):
    """``m`` seen in a Z-up world (the whole motion turned +90 degrees about X)."""
    r = np.broadcast_to(rotvec_to_quat(np.array([np.pi / 2, 0.0, 0.0])), (m.num_frames, 4))
    q = np.array(m.local_quats)
    q[:, 0] = quat_mul(r, q[:, 0])
    return m.replace(local_quats=q, root_positions=quat_rotate(r, m.root_positions))


@pytest.mark.parametrize("rig, speed, period, rate", [("hips", 140.0, 1.0, 90.0), ("static_root", 70.0, 1.3, -45.0),
                                                       ("turning_static_root", 120.0, 0.9, 150.0),
                                                       ("z_up", 160.0, 1.2, -30.0)])
def test_turning_walks_of_other_strides_and_rates(speed, period, rate, rig):
    """Held-out style: procedural walks with strides (speed x period) and turn rates other than the tests
    above, left and right, on a CMU-style rig, on a Bandai-style rig (static joint_Root above the hips; the
    turn on the hips or on the root itself) and in a Z-up world. Every 1/5 cycle: the frame one gait cycle
    later gets w >= 0.8, the frame half a cycle later w <= 0.1. Measured (also on all twelve combinations of
    these walks and rigs): same phase 1.00 everywhere, opposite <= 0.06."""
    from stagger_nb.data.procedural import walk as make_walk
    base = make_walk(duration=6.0, speed=speed, period=period, seed=5)
    if rig == "hips":
        m = turning(base, rate)
    elif rig == "static_root":
        m = static_root_rig(turning(base, rate))
    elif rig == "turning_static_root":
        m = _yaw_joint0(static_root_rig(base), rate, [0.0, 1.0, 0.0])
    else:
        m = _z_up(turning(base, rate))
    P = int(round(period / m.frame_time))
    basis = wand.greens_basis(m)
    for i in range(P, m.num_frames - P, max(1, P // 5)):
        w = wand.greens_falloff(basis, i)
        assert w[i + P] >= 0.8 and w[i + P // 2] <= 0.1, (i, w[i + P], w[i + P // 2])
