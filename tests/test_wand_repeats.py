"""Takes that repeat their poses exactly (issue 25, "long takes"): the magic wand's graph on distinct poses.

A take concatenated with itself gives every frame equal poses: the 8th-nearest-neighbour sigma collapsed to its
floor and the kNN graphs linked frames to their copies instead of their neighbours, so the landmark graph and
the graph of every frame disagreed (mean 0.26-0.34, max 1.0 on 20,000 frames).  Built here from the procedural
walk; each test fails with ``distinct=False`` (the previous behaviour)."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import concatenate, data, wand
from stagger_nb.wand.laplacian import distinct_poses, kernel_pattern, knn_graph, quotient_pattern, sparse_kernel


@pytest.fixture(scope="module")
def walk():
    return data.load("walk").resample(1 / 30)          # 181 frames, a little over five strides


def _falloffs(basis, frames):
    return np.stack([wand.greens_falloff(basis, f) for f in frames])


def test_distinct_poses_classes(walk):
    X = wand.pose_vectors(walk)
    rep = np.concatenate([X, X + 1e-13, X[:50]])       # float noise of a copy merges, real poses never do
    first, inverse, counts = distinct_poses(rep)
    np.testing.assert_array_equal(first, np.arange(X.shape[0]))
    np.testing.assert_array_equal(inverse, np.r_[np.arange(181), np.arange(181), np.arange(50)])
    np.testing.assert_array_equal(counts, np.r_[np.full(50, 3), np.full(131, 2)])
    f1, i1, c1 = distinct_poses(X)
    assert f1.size == 181 and np.all(c1 == 1)
    static = np.zeros((20, 6))
    assert distinct_poses(static)[0].tolist() == [0]


def test_quotient_pattern_with_single_frames_is_the_kernel_pattern(walk):
    X = wand.pose_vectors(walk)
    table = knn_graph(X, 16)
    F = X.shape[0]
    q = quotient_pattern(table, np.ones(F), np.arange(F - 1), np.arange(1, F), table.chain_sq)
    for sigma in (0.1, 0.3):
        a, b = sparse_kernel(kernel_pattern(table), sigma), sparse_kernel(q, sigma)
        assert abs(a - b).max() <= 1e-15


def test_a_repeated_take_on_the_sparse_path_matches_the_dense_graph(walk):
    """Six copies (1,086 frames): the dense kernel (every pair, Eq. 1 as written) is the ground truth."""
    m = concatenate([walk] * 6)
    dense = wand.pose_graph(m, method="dense").basis()
    assert dense.sigma == pytest.approx(wand.pose_graph(walk, method="dense").basis().sigma, rel=1e-12)
    frames = range(0, m.num_frames, 97)
    truth = _falloffs(dense, frames)
    err = np.abs(_falloffs(wand.pose_graph(m, method="sparse").basis(dense.sigma), frames) - truth)
    assert err.max() <= 0.03, err.max()
    before = np.abs(_falloffs(wand.pose_graph(m, method="sparse", distinct=False).basis(dense.sigma), frames) - truth)
    assert before.max() > 0.1                          # the frames' kNN graph links each frame to its copies


def test_a_20000_frame_repeated_take_landmarks_agree_with_every_frame(walk):
    m = concatenate([walk] * 111).slice(0, 20000)
    full = wand.pose_graph(m, method="sparse")
    lm = wand.pose_graph(m, method="landmarks")
    assert full.default_sigma == pytest.approx(wand.pose_graph(walk).default_sigma, rel=0.05)
    assert wand.pose_graph(m, method="sparse", distinct=False).default_sigma < 1e-6      # the floor, before
    bf = full.basis()
    err = np.abs(_falloffs(lm.basis(bf.sigma), range(0, 20000, 1000)) - _falloffs(bf, range(0, 20000, 1000)))
    assert err.mean() <= 0.02 and np.percentile(err, 99) <= 0.1
    # an edit at frame 5000 reaches the same phase of every copy (Fig. 4's propagation)
    w = wand.greens_falloff(bf, 5000)
    assert np.all(w[5000 % 181::181] >= 0.9)
