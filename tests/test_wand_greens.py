"""Green's function of the pose Laplacian (Dean et al. 2018, §3.1-3.2): known answers and dense vs sparse."""
import numpy as np
import pytest
from wand_motions import cyclic_motion

from stagger_nb import wand
from stagger_nb.wand import PoseGraph, knn_graph
from stagger_nb.wand.laplacian import pairwise_sq_distances, sparse_kernel


def _graph(X, method="dense", k=None):
    F = X.shape[0]
    D2 = pairwise_sq_distances(X) if method == "dense" else None
    return PoseGraph(X, D2, knn_graph(X, k or min(8, F - 1)), method)


def _naive_laplacian(X, sigma):
    """Eqs. 1-2 written out entry by entry (no chain floor)."""
    F = len(X)
    K = np.empty((F, F))
    for i in range(F):
        for j in range(F):
            K[i, j] = np.exp(-np.sum((X[i] - X[j]) ** 2) / (2 * sigma ** 2))
    r = K.sum(axis=1)
    A = np.array([[K[i, j] / np.sqrt(r[i] * r[j]) for j in range(F)] for i in range(F)])
    return np.eye(F) - A, r


@pytest.fixture
def small_points(rng):
    return rng.normal(size=(14, 3))


def test_all_eigenpairs_give_the_pseudo_inverse(small_points):
    X, F, sigma = small_points, len(small_points), 0.9
    L, r = _naive_laplacian(X, sigma)
    Lp = np.linalg.pinv(L, rcond=1e-10, hermitian=True)
    g = _graph(X)
    # Eq. 3 with phi_k as printed: G = L^+ on the complement of the null space
    sym = g.basis(sigma, num_eigs=F, self_term=True, normalization="symmetric", chain_floor=0.0)
    assert sym.null_dim == 1 and sym.num_eigs == F - 1
    scale = np.abs(Lp).max()
    # 1e-10 relative: two eigendecompositions of a 14x14 matrix agree to ~1e-13 times cond(L^+)
    assert np.allclose(sym.matrix(), Lp, atol=1e-10 * scale)
    # random-walk eigenvectors psi = D^-1/2 phi: G = D^-1/2 L^+ D^-1/2
    rw = g.basis(sigma, num_eigs=F, self_term=True, chain_floor=0.0)
    Grw = Lp / np.sqrt(np.outer(r, r))
    assert np.allclose(rw.matrix(), Grw, atol=1e-10 * scale)
    # dropping the self term: exactly G - D^-1 + 1 1^T / vol
    reg = g.basis(sigma, num_eigs=F, chain_floor=0.0)
    assert np.allclose(reg.matrix(), Grw - np.diag(1 / r) + 1 / r.sum(), atol=1e-10 * scale)
    # off the diagonal the two agree: the regular part changes Eq. 3 only by the diagonal and a constant
    off = ~np.eye(F, dtype=bool)
    assert np.allclose((reg.matrix() - rw.matrix())[off], 1 / r.sum(), atol=1e-10 * scale)


def test_null_space_of_a_disconnected_graph(rng):
    # two clusters 1e3 sigma apart: the kernel between them underflows to exactly 0 -> two components
    X = np.concatenate([rng.normal(size=(6, 2)), 1e3 + rng.normal(size=(5, 2))])
    L, _ = _naive_laplacian(X, 1.0)
    assert np.count_nonzero(np.abs(np.linalg.eigvalsh(L)) < 1e-9) == 2
    b = _graph(X).basis(1.0, num_eigs=len(X), self_term=True, normalization="symmetric", chain_floor=0.0)
    assert b.null_dim == 2 and b.num_eigs == len(X) - 2
    # 1e-10: see above
    assert np.allclose(b.matrix(), np.linalg.pinv(L, rcond=1e-10, hermitian=True), atol=1e-10)
    # the chain floor joins the clusters through the consecutive frames 5 and 6
    assert _graph(X).basis(1.0, num_eigs=len(X)).null_dim == 1


def test_random_walk_rows_peak_at_their_own_frame(rng):
    # the maximum principle of the random-walk Green's function (Eq. 3 with all eigenpairs): off its
    # source a column is below the weighted mean of its neighbours, (I - D^-1 K) g = -1/vol
    X = np.cumsum(0.3 * rng.normal(size=(40, 3)), axis=0)  # a random-walk "motion" in pose space
    b = _graph(X).basis(1.0, num_eigs=39, self_term=True)
    assert b.null_dim == 1 and b.num_eigs == 39
    P = b.matrix()
    assert np.array_equal(np.argmax(P, axis=1), np.arange(40))
    # the symmetric (phi as printed) rows are modulated by sqrt(degree) and need not peak there
    sym = _graph(X).basis(1.0, num_eigs=39, self_term=True, normalization="symmetric").matrix()
    r = b.degrees
    assert np.allclose(sym, P * np.sqrt(np.outer(r, r)), atol=1e-10 * np.abs(sym).max())  # same pinv, rescaled


def test_row_rows_and_matrix_agree(small_points):
    b = _graph(small_points).basis(0.8, num_eigs=5)
    P = b.matrix()
    assert np.allclose(b.row(3), P[3], atol=1e-13)  # same products in another order
    assert np.allclose(b.rows([0, 7]), P[[0, 7]], atol=1e-13)
    assert np.allclose(wand.greens_rows(b, [2]), P[[2]], atol=1e-13)
    assert b.eigenvectors.shape == (14, 5) and np.all(np.diff(b.eigenvalues) >= 0)
    for bad in (-1, 14, 2.5):
        with pytest.raises(ValueError, match="frame"):
            b.row(bad)


def test_bad_parameters_name_themselves(small_points):
    g = _graph(small_points)
    with pytest.raises(ValueError, match="sigma"):
        g.basis(-1.0)
    with pytest.raises(ValueError, match="num_eigs"):
        g.basis(1.0, num_eigs=0)
    with pytest.raises(ValueError, match="normalization"):
        g.basis(1.0, normalization="lazy")
    with pytest.raises(ValueError, match="chain_floor"):
        g.basis(1.0, chain_floor=2.0)
    with pytest.raises(ValueError, match="method"):
        wand.pose_graph(cyclic_motion(F=10), method="fast")


def test_sparse_with_all_neighbours_equals_dense():
    m = cyclic_motion(F=60, period=20, noise=0.05, seed=4)
    gd = wand.pose_graph(m, method="dense")
    gs = wand.pose_graph(m, method="sparse", knn=59)
    s = gd.default_sigma
    bd, bs = gd.basis(s, num_eigs=20), gs.basis(s, num_eigs=20)
    assert gs.sq_distances is None
    # 1e-7: the 6-sigma kernel cut-off drops entries < 1.6e-8; shift-invert Lanczos converges to ~1e-10
    assert np.allclose(bd.eigenvalues, bs.eigenvalues, atol=1e-7)
    for f in (0, 17, 59):
        assert np.abs(wand.greens_falloff(bd, f) - wand.greens_falloff(bs, f)).max() < 1e-4


def test_sparse_kernel_memory_is_linear_in_frames():
    m = cyclic_motion(F=300, period=37, noise=0.02, seed=5)
    g = wand.pose_graph(m, method="sparse", knn=10)
    K = sparse_kernel(g.knn, g.default_sigma)
    assert K.nnz <= 300 * (2 * 10 + 3)  # kNN edges both ways + chain + diagonal, never F^2
    assert abs(K - K.T).max() == 0  # exactly symmetric
    b = g.basis(num_eigs=12)
    assert b.eigenvectors.shape == (300, 12)


def test_sparse_kernel_entry_by_entry_and_its_pattern_stays_put():
    """The kernel from the graph's precomputed CSR pattern equals Eq. 1 written out pair by pair on the edge set
    (kNN either way + the floored chain + the unit diagonal, pairs beyond KERNEL_CUTOFF sigmas left out), for
    a sigma small enough to drop entries and a large one; building it never changes the pattern."""
    from stagger_nb.wand.laplacian import CHAIN_FLOOR, KERNEL_CUTOFF, normalized_adjacency
    m = cyclic_motion(F=120, period=23, noise=0.05, seed=2)
    g = wand.pose_graph(m, method="sparse", knn=6)
    before = [np.array(a) for a in (g.pattern.indptr, g.pattern.indices, g.pattern.sq_distances)]
    X, F = g.pose_vectors, 120
    pairs = {(i, int(j)) for i in range(F) for j in g.knn.indices[i]}
    pairs |= {(j, i) for i, j in pairs} | {(i, i + 1) for i in range(F - 1)} | {(i + 1, i) for i in range(F - 1)}
    for sigma in (0.05 * g.default_sigma, 2.0 * g.default_sigma):
        naive = np.eye(F)
        for i, j in pairs:
            d2 = np.sum((X[i] - X[j]) ** 2)
            v = np.exp(-d2 / (2 * sigma ** 2))
            if abs(i - j) == 1:
                naive[i, j] = max(v, CHAIN_FLOOR)
            elif d2 <= (KERNEL_CUTOFF * sigma) ** 2:
                naive[i, j] = v
        K = sparse_kernel(g.pattern, sigma)
        np.testing.assert_allclose(K.toarray(), naive, rtol=1e-12, atol=0)   # exp of the same d2 up to round-off
        r = naive.sum(axis=1)
        A, _ = normalized_adjacency(K)
        np.testing.assert_allclose(A.toarray(), naive / np.sqrt(np.outer(r, r)), rtol=1e-12, atol=0)
        assert (sparse_kernel(g.knn, sigma) != K).nnz == 0              # from the kNN table: the same matrix
    after = (g.pattern.indptr, g.pattern.indices, g.pattern.sq_distances)
    assert all(np.array_equal(a, b) for a, b in zip(before, after))
    assert sparse_kernel(g.pattern, 0.05 * g.default_sigma).nnz < sparse_kernel(g.pattern, g.default_sigma).nnz


@pytest.mark.shared
def test_dense_and_sparse_agree_on_a_1000_frame_clip(shared_motion):
    m = shared_motion("cmu_131_01_walk_startstop.bvh")  # 994 frames at 120 Hz
    N = 50
    bd = wand.greens_basis(m, num_eigs=N, method="dense")
    # 400 neighbours cover nearly every pair within 5 sigma of this clip (at most 408, median 201); the
    # entries left out are below exp(-12.5) = 4e-6
    bs = wand.greens_basis(m, num_eigs=N, method="sparse", knn=400)
    assert bd.sigma == bs.sigma
    diff = max(np.abs(wand.greens_falloff(bd, f) - wand.greens_falloff(bs, f)).max()
               for f in range(0, m.num_frames, 37))
    assert diff <= 1e-3


def test_pose_graph_has_no_hidden_cache():
    """Issue 11 item 2: the graph is immutable; each basis() call computes (identically)."""
    m = cyclic_motion(F=40, period=13, seed=6)
    g = wand.pose_graph(m)
    b1 = g.basis(0.3)
    b2 = g.basis(0.3)
    assert b2 is not b1 and np.array_equal(b2.eigenvalues, b1.eigenvalues)
    with pytest.raises(AttributeError):
        g.method = "sparse"


def test_one_call_falloff_reuses_the_graph_by_content(monkeypatch):
    """A new sigma through wand.falloff does not rebuild the pose graph; equal content hits, other content
    or options miss; the cache is bounded."""
    from stagger_nb.wand import graph_cache as greens
    greens.clear_graph_cache()
    built = []
    real = greens.pose_graph
    monkeypatch.setattr(greens, "pose_graph", lambda *a, **k: built.append(1) or real(*a, **k))
    m = cyclic_motion(F=40, period=13, seed=6)
    for s in (0.3, 0.4, 0.5):
        wand.falloff(m, 3, sigma=s)
    assert len(built) == 1
    wand.falloff(m.replace(local_quats=np.array(m.local_quats)), 3, sigma=0.6)   # a copy: same content
    assert len(built) == 1
    wand.falloff(m, 3, sigma=0.6, heading="keep")                               # other options: a new graph
    assert len(built) == 2
    for seed in range(greens.GRAPH_CACHE + 1):
        wand.falloff(cyclic_motion(F=30, period=11, seed=seed), 3)
    wand.falloff(m, 3, sigma=0.3)
    assert len(built) == 2 + greens.GRAPH_CACHE + 1 + 1                       # m was evicted
    greens.clear_graph_cache()


def test_paper_formula_is_reachable_through_the_one_call_falloff():
    # Eq. 1-3 as printed (plain log map, no chain floor, phi_k of L, weight 1/lambda_k): every deviation
    # of the defaults is an opt-in flag of wand.falloff, and with all eigenpairs the row is L^+'s row
    from stagger_nb.core.rotations import quat_hemisphere, quat_log
    from stagger_nb.wand import normalize_row
    m = cyclic_motion(F=30, period=11, noise=0.05, seed=8)
    X = quat_log(quat_hemisphere(m.local_quats)).reshape(30, -1)   # the plain log map of §3
    sigma = 0.7
    L, _ = _naive_laplacian(X, sigma)
    Lp = np.linalg.pinv(L, rcond=1e-10, hermitian=True)
    paper = dict(self_term=True, normalization="symmetric", chain_floor=0.0, reference="identity", heading="keep")
    for f in (0, 13, 29):
        w = wand.falloff(m, f, sigma=sigma, num_eigs=29, **paper)
        # 1e-8: the normalisation divides the 1e-10-relative agreement above by g_f - min g (~1e-2 of max)
        assert np.allclose(w, normalize_row(Lp[f], f), atol=1e-8)
        assert not np.allclose(w, wand.falloff(m, f, sigma=sigma, num_eigs=29), atol=1e-3)  # the defaults differ


def test_landmark_graph_interpolates_a_subsampled_graph():
    """Long takes (method="landmarks"): the graph of every stride-th frame, eigenvectors interpolated in time.
    With stride 1 it is the sparse graph itself. With stride 2 it is an approximation whose error is NOT small
    on every clip (here: mean |dw| 0.28, because the temporal chain's diffusion depends on the sampling; on the
    20,000-frame benchmark clip mean 0.009, max 0.07; benchmarks/bench_wand.py case D): only its form is
    checked here."""
    m = cyclic_motion(F=400, period=37, noise=0.01, seed=4)
    gs = wand.pose_graph(m, method="sparse", knn=30)
    g1 = wand.pose_graph(m, method="landmarks", knn=30, max_landmarks=400)
    g2 = wand.pose_graph(m, method="landmarks", knn=30, max_landmarks=200)
    assert g1.landmarks.size == 400 and g2.landmarks[1] == 2 and g2.landmarks[-1] == 399
    s = gs.default_sigma
    bs, b1, b2 = gs.basis(s, num_eigs=20), g1.basis(s, num_eigs=20), g2.basis(s, num_eigs=20)
    assert b2.eigenvectors.shape == (400, 20) and b2.method == "landmarks"
    for f in (0, 101, 250):
        np.testing.assert_allclose(wand.greens_falloff(b1, f), wand.greens_falloff(bs, f), atol=1e-9)
        w2 = wand.greens_falloff(b2, f)
        assert w2[f] == 1.0 and w2.min() >= 0.0 and w2.max() <= 1.0 and np.isclose(w2.min(), 0.0)
    assert wand.pose_graph(m, method="landmarks", knn=30).landmarks.size == 400     # the default, 8,000, keeps all
    for bad in (1, 2.5, True, "400"):
        with pytest.raises(ValueError, match="max_landmarks must be an integer >= 2"):
            wand.pose_graph(m, method="landmarks", knn=30, max_landmarks=bad)
