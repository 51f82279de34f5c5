"""Features (§3.2) and the kNN local score (eq. 2) against a per-triple linear search."""
from __future__ import annotations

import numpy as np
import pytest
from timewarp_reference import knn_scores_loop

import stagger_nb.timewarp.objective as objective
from stagger_nb.core.rotations import euler_to_quat, quat_mul
from stagger_nb.timewarp.features import pose_features, reference_blocks, reference_features, triple_features
from stagger_nb.timewarp.objective import knn_scores


def _walks(rng, n, r, d, scale=1.0):
    X = np.cumsum(rng.standard_normal((n, d)), axis=0) * scale + 50.0   # offset: centring must not matter
    R = np.cumsum(rng.standard_normal((r, d)), axis=0) * scale + 50.0
    return X, R


def _finite_close(a, b, rtol, atol):
    assert np.array_equal(np.isinf(a), np.isinf(b))
    fin = np.isfinite(a)
    np.testing.assert_allclose(a[fin], b[fin], rtol=rtol, atol=atol)


@pytest.mark.parametrize("n,r,d,s,k", [(30, 25, 6, 4, 3), (17, 40, 9, 8, 1), (25, 12, 3, 3, 5), (9, 5, 4, 2, 3)])
def test_scores_equal_linear_search_float64(n, r, d, s, k):
    X, R = _walks(np.random.default_rng(n + r), n, r, d)
    fast = knn_scores(X, R, s, k, dtype=np.float64)
    slow = knn_scores_loop(X, R, s, k)
    # |phi|^2 + |z|^2 - 2 phi.z in float64 after centring: ~1e-12 relative round-off on O(100) distances
    _finite_close(fast, slow, rtol=1e-9, atol=1e-9)


def test_scores_float32_close_to_linear_search():
    X, R = _walks(np.random.default_rng(0), 40, 35, 12, scale=5.0)
    fast = knn_scores(X, R, 5, 3)                 # float32 neighbour search
    slow = knn_scores_loop(X, R, 5, 3)
    # float32 squared distances: absolute error ~1e-7 * |features|^2 (~1e4 here), i.e. ~1e-3 in d^2
    _finite_close(fast, slow, rtol=1e-4, atol=0.05)


def test_inadmissible_triples_are_inf_and_the_rest_finite():
    X, R = _walks(np.random.default_rng(1), 20, 10, 3)
    sc = knn_scores(X, R, 4, 2)
    j, a, b = np.meshgrid(np.arange(20), np.arange(1, 5), np.arange(1, 5), indexing="ij")
    admissible = (j - a >= 0) & (j + b <= 19)
    assert np.all(np.isfinite(sc[admissible])) and np.all(np.isinf(sc[~admissible]))


def test_chunking_does_not_change_the_result(monkeypatch):
    X, R = _walks(np.random.default_rng(2), 50, 33, 5)
    whole = knn_scores(X, R, 6, 3, dtype=np.float64)
    monkeypatch.setattr(objective, "_CHUNK_BYTES", 8 * 33 * 7)   # chunks of 7 middle frames ...
    monkeypatch.setattr(objective, "_BLOCK_ELEMS", 16 * 5)       # ... and reference blocks of a few rows
    pieces = knn_scores(X, R, 6, 3, dtype=np.float64)
    _finite_close(whole, pieces, rtol=1e-12, atol=1e-12)  # same arithmetic, other grouping of the minima


def test_weights_scale_the_feature_blocks():
    X, R = _walks(np.random.default_rng(3), 15, 12, 4)
    w = (0.5, 2.0, 3.0)
    _finite_close(knn_scores(X, R, 3, 2, weights=w, dtype=np.float64), knn_scores_loop(X, R, 3, 2, weights=w),
                  rtol=1e-9, atol=1e-9)  # float64 round-off
    # pose-only weights: the score ignores the skips entirely
    sc = knn_scores(X, R, 3, 1, weights=(1, 0, 0), dtype=np.float64)
    fin = np.isfinite(sc)
    ref = np.broadcast_to(sc[:, :1, :1], sc.shape)
    np.testing.assert_allclose(sc[fin], ref[fin], rtol=1e-9, atol=1e-6)  # sqrt of round-off near 0


def test_self_reference_scores_zero_at_unit_steps():
    X, _ = _walks(np.random.default_rng(4), 30, 1, 6)
    sc = knn_scores(X, X, 4, 1, dtype=np.float64)
    # the feature of (j-1, j, j+1) is exactly reference feature j: distance 0 (sqrt of round-off)
    np.testing.assert_allclose(sc[1:-1, 0, 0], 0.0, atol=1e-5)
    assert np.all(sc[1:-1, 1:, :][np.isfinite(sc[1:-1, 1:, :])] > 1e-3)


def test_reference_features_are_triple_features_of_consecutive_frames():
    R = np.random.default_rng(5).standard_normal((10, 3))
    Z = reference_features(R, (1.0, 2.0, 3.0))
    t = np.arange(1, 9)
    np.testing.assert_array_equal(Z, triple_features(R, t - 1, t, t + 1, (1.0, 2.0, 3.0)))
    np.testing.assert_allclose(Z[0], np.concatenate([R[1], 2.0 * (R[2] - R[0]) / 2, 3.0 * (R[2] - 2 * R[1] + R[0])]))


def test_reference_blocks_with_a_longer_step():
    R = np.random.default_rng(8).standard_normal((21, 3))
    P, V, A = reference_blocks(R, 2.0)
    P2, V2, A2 = reference_blocks(R[::2], 1.0)          # integer step 2 = step 1 on every other frame
    np.testing.assert_allclose(P[::2], P2, atol=0)
    np.testing.assert_allclose(V[::2], V2, atol=1e-15)
    np.testing.assert_allclose(A[::2], A2, atol=1e-15)
    P, V, A = reference_blocks(R, 1.5)                  # fractional: linear interpolation between frames
    t = 2                                               # first usable frame: ceil(1.5)
    np.testing.assert_allclose(V[0], 0.5 * (0.5 * (R[3] + R[4]) - 0.5 * (R[0] + R[1])), atol=1e-15)
    assert P.shape[0] == 21 - 2 * t
    X = np.cumsum(np.random.default_rng(9).standard_normal((15, 3)), axis=0)
    _finite_close(knn_scores(X, R, 3, 2, dtype=np.float64, ref_step=1.5), knn_scores_loop(X, R, 3, 2, ref_step=1.5),
                  rtol=1e-9, atol=1e-9)  # float64 round-off


def test_pose_features_ignore_global_position_and_heading(shared_motion):
    m = shared_motion("bandai_walk.bvh").slice(0, 40)
    turn = euler_to_quat(np.array([0.0, 70.0, 0.0]), "xyz")    # a yaw about the vertical axis
    q = np.array(m.local_quats)
    q[:, 0] = quat_mul(np.broadcast_to(turn, q[:, 0].shape), q[:, 0])
    moved = m.replace(local_quats=q, root_positions=m.root_positions + np.array([300.0, 0.0, -120.0]))
    # FK round-off on cm-sized coordinates
    for frame in ("pelvis_height", "heading", "pelvis"):
        np.testing.assert_allclose(pose_features(moved, frame=frame), pose_features(m, frame=frame), atol=1e-9)


def test_joint_weights_and_prefilter(shared_motion):
    m = shared_motion("bandai_walk.bvh").slice(0, 30)
    J = m.num_joints
    n = J - 1                                           # the static joint_Root above the pelvis is left out
    raw = pose_features(m, prefilter=0.0, frame="pelvis").reshape(30, n, 3)
    w = np.linspace(0.0, 2.0, J)
    weighted = pose_features(m, joint_weights=w, prefilter=0.0, frame="pelvis").reshape(30, n, 3)
    np.testing.assert_allclose(weighted, raw * np.sqrt(w[1:])[None, :, None], atol=1e-12)  # one product each
    # the default appends the pelvis's height, weighted by sqrt(sum of the weights)
    hw, h = pose_features(m, joint_weights=w, prefilter=0.0)[:, -1], pose_features(m, prefilter=0.0)[:, -1]
    np.testing.assert_allclose(hw, h * np.sqrt(w[1:].sum() / n), atol=1e-9)
    smooth = pose_features(m, prefilter=3 * m.frame_time, frame="pelvis").reshape(30, n, 3)
    np.testing.assert_allclose(smooth[5], raw[4:7].mean(axis=0), atol=1e-9)    # a 3-frame box, round-off
    with pytest.raises(ValueError, match="joint_weights"):
        pose_features(m, joint_weights=np.ones(J + 1))
    with pytest.raises(ValueError, match="prefilter"):
        pose_features(m, prefilter=-1.0)
    with pytest.raises(ValueError, match="frame"):
        pose_features(m, frame="torso")


@pytest.mark.parametrize("kwargs,match", [
    (dict(skip=0), "skip"), (dict(skip=200), "skip"), (dict(k=0), "k must"), (dict(weights=(1, -1, 1)), "weights"),
])
def test_bad_arguments_raise(kwargs, match):
    X, R = _walks(np.random.default_rng(6), 10, 10, 3)
    args = dict(skip=3, k=2)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        knn_scores(X, R, **args)


def test_reference_too_short_raises():
    X, R = _walks(np.random.default_rng(7), 10, 4, 3)
    with pytest.raises(ValueError, match="reference"):
        knn_scores(X, R, 3, k=3)


def test_threads_give_the_same_table_and_report_progress():
    X, R = _walks(np.random.default_rng(10), 60, 40, 6)
    seen = []
    one = knn_scores(X, R, 5, 3, workers=1)
    two = knn_scores(X, R, 5, 3, workers=2, progress=seen.append)
    np.testing.assert_array_equal(one, two)            # the same arithmetic per work unit, in any order
    assert seen[-1] == 1.0 and np.all(np.diff(seen) > 0)
    with pytest.raises(ValueError, match="workers"):
        knn_scores(X, R, 5, 3, workers=0)


@pytest.mark.parametrize("n,r,d,s,k", [(30, 25, 6, 4, 3), (17, 40, 9, 8, 1), (25, 12, 3, 3, 5)])
def test_candidate_scores_with_every_candidate_are_exact(n, r, d, s, k):
    """The long-take search (objective.candidate_scores) with C = all reference frames is the linear search."""
    X, R = _walks(np.random.default_rng(n * r), n, r, d)
    slow = knn_scores_loop(X, R, s, k, weights=(1.0, 2.0, 3.0))
    full = objective.candidate_scores(X, R, s, k, weights=(1.0, 2.0, 3.0), candidates=r, chunk=7)
    _finite_close(full, slow, rtol=1e-9, atol=1e-9)       # float64 round-off
    few = objective.candidate_scores(X, R, s, k, weights=(1.0, 2.0, 3.0), candidates=k + 1)
    fin = np.isfinite(slow)
    assert np.array_equal(fin, np.isfinite(few))
    assert np.all(few[fin] >= slow[fin] - 1e-9)            # fewer candidates can only miss neighbours
    step = objective.candidate_scores(X, R, s, k, candidates=r, ref_step=1.5)
    _finite_close(step, knn_scores_loop(X, R, s, k, ref_step=1.5), rtol=1e-9, atol=1e-9)
