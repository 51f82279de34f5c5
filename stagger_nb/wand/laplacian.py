"""Pose kernel and normalised graph Laplacian (Dean et al. 2018, §3.1, Eqs. 1-2).

``K_ij = exp(-d(p_i, p_j)^2 / (2 sigma^2))`` (Eq. 1), ``r = K 1``, ``A = D^-1/2 K D^-1/2`` with
``D = diag(r)`` (Eq. 2) and ``L = I - A`` (the symmetric normalised Laplacian: its degree matrix ``D_A``
is the identity as the paper states).  The diagonal ``K_ii = 1`` (self-similarity) is kept, as in Eq. 1.

Two kernels share these formulas:

* **dense** — all ``F x F`` pairs; for clips up to a few thousand frames.
* **sparse** — only the edges of a k-nearest-neighbour graph (made symmetric) plus the temporal chain
  ``(i, i + 1)`` (which keeps the graph connected); memory ``O(F k)``.  Entries left out are those with
  ``d`` beyond a frame's k-th neighbour distance, so with ``k`` large enough against ``sigma`` the two
  kernels agree to ``exp(-d_k^2 / 2 sigma^2)`` per entry.

Distances between pose vectors are Euclidean (see :mod:`.pose_space`).

**Temporal chain floor** (a choice of ours, not in the paper): consecutive frames ``i, i + 1`` get
``K = max(exp(-d^2 / 2 sigma^2), chain_floor)`` with default ``CHAIN_FLOOR = exp(-1/2)`` ("consecutive frames
are never treated as more than one sigma apart").  For normal mocap this changes nothing (consecutive
poses are far closer than sigma); it matters at glitches, e.g. a thumb whose Euler angles flip by 180
degrees for a few frames (CMU 131_01), which would otherwise nearly cut the graph.  Measured on CMU 131_01
(default sigma): without the floor the glitch runs (around frames 178-191, 237-242 and 810-814) give
eigenvalues 1.6e-10 and 2.1e-10, below ``greens.NULL_TOL``, so they count as separate components whose
Green's value is 0 and the falloff of frame 400 is an arbitrary 0.25 on those 12 frames (0.003 with
the floor, like their neighbours); elsewhere the two agree.  ``chain_floor=0`` is the plain Eq. 1.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

__all__ = ["pairwise_sq_distances", "KnnGraph", "KernelPattern", "kernel_pattern", "knn_graph", "default_sigma",
           "dense_kernel",
           "sparse_kernel", "normalized_adjacency", "normalized_laplacian", "DEFAULT_SIGMA_NEIGHBOURS",
           "DEFAULT_SIGMA_PERCENTILE", "CHAIN_FLOOR", "KERNEL_CUTOFF", "symmetric_edges", "quotient_pattern",
           "distinct_poses"]

# Default sigma = this percentile over frames of the distance to the k-th nearest neighbour (see default_sigma).
DEFAULT_SIGMA_NEIGHBOURS = 8
DEFAULT_SIGMA_PERCENTILE = 50.0
KERNEL_CUTOFF = 6.0  # sparse kernel: neighbours farther than this many sigmas are left out (K < 1.6e-8)
CHAIN_FLOOR = float(np.exp(-0.5))  # minimum kernel value between consecutive frames (see the module docstring)
_WORKERS = 2  # threads of the k-d tree query


def pairwise_sq_distances(X: np.ndarray, Y: np.ndarray | None = None) -> np.ndarray:
    """Squared Euclidean distances ``(F, G)`` between rows of ``X (F, D)`` and ``Y (G, D)`` (default ``X``),
    by ``|x|^2 + |y|^2 - 2 x.y`` (one BLAS product), clipped at 0; the diagonal is exactly 0 when ``Y`` is None."""
    X = np.asarray(X, dtype=float)
    same = Y is None
    Y = X if same else np.asarray(Y, dtype=float)
    xx = np.einsum("ij,ij->i", X, X)
    yy = xx if same else np.einsum("ij,ij->i", Y, Y)
    D2 = xx[:, None] + yy[None, :] - 2.0 * (X @ Y.T)
    np.maximum(D2, 0.0, out=D2)
    if same:
        np.fill_diagonal(D2, 0.0)
    return D2


@dataclass(frozen=True, eq=False)
class KnnGraph:
    """The k nearest neighbours of every frame (itself excluded).

    Attributes
    ----------
    indices : ndarray, shape (F, k), int
        Neighbour frame indices, nearest first.
    sq_distances : ndarray, shape (F, k)
        Their squared pose distances.
    chain_sq : ndarray, shape (F - 1,)
        Squared distance between consecutive frames ``i`` and ``i + 1`` (the temporal chain).
    """

    indices: np.ndarray
    sq_distances: np.ndarray
    chain_sq: np.ndarray

    @property
    def num_frames(self) -> int:
        return int(self.indices.shape[0])

    @property
    def k(self) -> int:
        return int(self.indices.shape[1])


def knn_graph(X: np.ndarray, k: int) -> KnnGraph:
    """Exact k nearest neighbours of each row of ``X (F, D)`` (a k-d tree, ``scipy.spatial.cKDTree``;
    memory ``O(F k)``, never ``O(F^2)``).  Pose data lie near a low-dimensional manifold, where the tree is
    fast even for D ~ 100.  Ties (repeated poses) are broken by the tree, deterministically."""
    X = np.asarray(X, dtype=float)
    F = X.shape[0]
    k = int(k)
    if k < 1 or k > F - 1:
        raise ValueError(f"k must be in [1, F - 1] = [1, {F - 1}], got {k}")
    d, idx = cKDTree(X).query(X, k + 1, workers=_WORKERS)
    # drop each frame itself: it is column 0 unless an exact duplicate pose came first
    self_col = np.argmax(idx == np.arange(F)[:, None], axis=1)
    has_self = idx[np.arange(F), self_col] == np.arange(F)
    drop = np.where(has_self, self_col, k)
    keep = np.ones_like(idx, dtype=bool)
    keep[np.arange(F), drop] = False
    idx = idx[keep].reshape(F, k)
    d = d[keep].reshape(F, k)
    chain = np.sum((X[1:] - X[:-1]) ** 2, axis=1)
    return KnnGraph(idx.astype(np.int64), d * d, chain)


DISTINCT_TOL = 1e-6   # poses closer than this times the median step between consecutive frames count as one


def distinct_poses(X: np.ndarray, tol: float = DISTINCT_TOL) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Classes of equal poses among the rows of ``X (F, D)``: ``(first (C,), inverse (F,), counts (C,))`` -- the
    first frame of each class (ascending), each frame's class, the class sizes.

    "Equal" is to ``tol`` times the median distance between consecutive frames (snapped to a grid of that
    size, so float noise of a repeated take's copies merges and a real pose change never does; a static clip
    is one class).  A clip without repeated poses has ``C = F`` and ``inverse = arange(F)``."""
    X = np.asarray(X, dtype=float)
    F = X.shape[0]
    if F < 2:
        return np.arange(F), np.arange(F), np.ones(F, dtype=np.int64)
    step = float(np.median(np.linalg.norm(np.diff(X, axis=0), axis=1)))
    scale = float(np.abs(X).max()) if X.size else 0.0
    q = max(tol * step, 1e-12 * max(scale, 1.0))
    grid = np.round(X / q).astype(np.int64)
    # one int64 hash per row (wrapping products: 1-D unique is ~20x faster than rows), checked exactly after
    coef = np.random.default_rng(0x5EED).integers(1, 2 ** 62, size=grid.shape[1], dtype=np.int64)
    with np.errstate(over="ignore"):
        h = grid @ coef
    _, first, inverse, counts = np.unique(h, return_index=True, return_inverse=True, return_counts=True)
    if first.size < F and not np.array_equal(grid, grid[first[inverse.reshape(-1)]]):   # a hash collision
        _, first, inverse, counts = np.unique(grid, axis=0, return_index=True, return_inverse=True,
                                              return_counts=True)
    order = np.argsort(first, kind="stable")          # classes in order of first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return first[order], rank[inverse.reshape(-1)], counts[order]


def default_sigma(X: np.ndarray | None = None, knn: KnnGraph | None = None,
                  neighbours: int = DEFAULT_SIGMA_NEIGHBOURS, percentile: float = DEFAULT_SIGMA_PERCENTILE) -> float:
    """The data-derived default kernel width (§3.1: "sigma should be adjusted so that all large distances
    are near zero under the kernel").

    ``sigma`` = the ``percentile``-th percentile (default the median) over frames of the distance from each
    frame to its ``neighbours``-th nearest other frame (default 8).  So a typical frame has about
    ``neighbours`` others within one sigma, while poses many sigmas away are cut off, and the value scales
    with the data (units, frame rate, amount of motion).  Give ``knn`` (with ``k >= neighbours``) to reuse a
    computed neighbour table, else ``X (F, D)`` pose vectors.  Never below a tiny floor (static clips).
    """
    if knn is None:
        if X is None:
            raise ValueError("default_sigma: give X or knn")
        F = np.asarray(X).shape[0]
        knn = knn_graph(X, min(int(neighbours), F - 1))
    n = min(int(neighbours), knn.k)
    d = np.sqrt(knn.sq_distances[:, n - 1])
    s = float(np.percentile(d, percentile))
    return max(s, 1e-9)


MIN_SIGMA = 1e-150  # below this 1 / (2 sigma^2) overflows double precision


def _check_sigma(sigma) -> float:
    try:
        s = float(sigma)
    except (TypeError, ValueError):
        raise ValueError(f"sigma must be a finite number > 0, got {sigma!r}") from None
    if isinstance(sigma, bool) or not np.isfinite(s) or s <= 0:
        raise ValueError(f"sigma must be a finite number > 0, got {sigma!r}")
    if s < MIN_SIGMA:
        raise ValueError(f"sigma={sigma!r} is too small: the kernel exp(-d^2 / 2 sigma^2) needs sigma >= "
                         f"{MIN_SIGMA:g}; use sigma=None for the clip's default or a value near it")
    return s


def _check_floor(chain_floor) -> float:
    f = float(chain_floor)
    if not 0.0 <= f <= 1.0:
        raise ValueError(f"chain_floor must be in [0, 1], got {chain_floor!r}")
    return f


def dense_kernel(D2: np.ndarray, sigma: float, chain_floor: float = CHAIN_FLOOR) -> np.ndarray:
    """Eq. 1 on all pairs: ``K (F, F) = exp(-D2 / (2 sigma^2))`` from squared distances ``D2 (F, F)``,
    consecutive frames floored at ``chain_floor``."""
    s = _check_sigma(sigma)
    f = _check_floor(chain_floor)
    K = np.exp(D2 * (-0.5 / (s * s)))
    if f > 0 and K.shape[0] > 1:
        i = np.arange(K.shape[0] - 1)
        K[i, i + 1] = np.maximum(K[i, i + 1], f)
        K[i + 1, i] = K[i, i + 1]
    return K


def symmetric_edges(knn: KnnGraph):
    """The edge set of the sparse kernel: kNN pairs in both directions plus the temporal chain, each
    ordered pair ``(row, col)`` once (no self pairs).

    Returns
    -------
    rows, cols : ndarray, shape (E,), int
    sq_distances : ndarray, shape (E,)
    is_chain : ndarray, shape (E,), bool
        True where ``|row - col| = 1``.
    """
    F, k = knn.indices.shape
    rows = np.concatenate([np.arange(F - 1), np.repeat(np.arange(F), k)])
    cols = np.concatenate([np.arange(1, F), knn.indices.reshape(-1)])
    d2 = np.concatenate([knn.chain_sq, knn.sq_distances.reshape(-1)])
    # each unordered pair once (the first of its duplicates), then both directions with the same value
    lo, hi = np.minimum(rows, cols), np.maximum(rows, cols)
    _, first = np.unique(lo * F + hi, return_index=True)
    lo, hi, d2 = lo[first], hi[first], d2[first]
    r, c, d_all = np.concatenate([lo, hi]), np.concatenate([hi, lo]), np.concatenate([d2, d2])
    return r, c, d_all, np.abs(r - c) == 1


@dataclass(frozen=True, eq=False)
class KernelPattern:
    """The sigma-independent CSR structure of the sparse kernel (:func:`kernel_pattern`): the symmetric kNN +
    temporal-chain edge set and the diagonal, rows sorted, so a new sigma only recomputes the values.

    Attributes (E entries, diagonal included)
    ----------
    indptr : (F + 1,) int; indices : (E,) int32 column of each entry; rows : (E,) int row of each entry
    sq_distances : (E,) squared pose distance of each entry (0 on the diagonal)
    chain : (E,) bool, ``|row - col| = 1``; diagonal : (E,) bool
    multiplicity, chain_count : (E,) float or None (:func:`quotient_pattern`, a graph on distinct poses): how
        many frame pairs each entry stands for, and how many of them are consecutive frames (floored)
    """

    indptr: np.ndarray
    indices: np.ndarray
    rows: np.ndarray
    sq_distances: np.ndarray
    chain: np.ndarray
    diagonal: np.ndarray
    multiplicity: np.ndarray | None = None
    chain_count: np.ndarray | None = None

    @property
    def num_frames(self) -> int:
        return int(self.indptr.shape[0] - 1)


def kernel_pattern(knn: KnnGraph) -> KernelPattern:
    """The CSR structure of :func:`sparse_kernel` for ``knn`` (computed once per pose graph)."""
    F = knn.num_frames
    rows, cols, d2, chain = symmetric_edges(knn)
    diag = np.arange(F)
    r = np.concatenate([rows, diag])
    c = np.concatenate([cols, diag])
    order = np.lexsort((c, r))
    indptr = np.zeros(F + 1, dtype=np.int64)
    np.cumsum(np.bincount(r, minlength=F), out=indptr[1:])
    is_diag = np.concatenate([np.zeros(rows.size, dtype=bool), np.ones(F, dtype=bool)])
    arrays = (indptr, c[order].astype(np.int32), r[order], np.concatenate([d2, np.zeros(F)])[order],
              np.concatenate([chain, np.zeros(F, dtype=bool)])[order], is_diag[order])
    for a in arrays:
        a.setflags(write=False)
    return KernelPattern(*arrays)


def quotient_pattern(knn: KnnGraph, counts: np.ndarray, chain_rows: np.ndarray, chain_cols: np.ndarray,
                     chain_sq: np.ndarray) -> KernelPattern:
    """The sparse kernel's CSR structure on *distinct poses* (nodes), each standing for ``counts[A]`` frames
    that share its pose: the quotient of the frames' graph (issue 25, repeated takes).

    Frames with the same pose have the same kernel row, so the eigenvectors of the frames' graph that are
    constant on each class of equal poses are those of the graph on the classes with weights
    ``W_AB = sum over frame pairs (f in A, f' in B) of K_ff'`` (and their degrees ``sum_B W_AB``): an entry
    of a kNN pair ``(A, B)`` stands for ``c_A c_B`` frame pairs, the diagonal for ``c_A^2`` (equal poses:
    K = 1), and the consecutive frames (``chain_rows[i] -> chain_cols[i]``, squared distance ``chain_sq[i]``,
    node indices, repeats allowed) add their chain floor.  ``knn`` is the kNN table of the distinct poses
    (itself excluded).  With all counts 1 and the chain the consecutive nodes this is :func:`kernel_pattern`
    (the same kernel values)."""
    F = knn.num_frames
    counts = np.asarray(counts, dtype=float)
    k = knn.k
    # pairs: kNN both directions, chain both directions, one entry per unordered pair
    kr = np.repeat(np.arange(F), k)
    kc = knn.indices.reshape(-1)
    kd = knn.sq_distances.reshape(-1)
    cr, cc = np.asarray(chain_rows, dtype=np.int64), np.asarray(chain_cols, dtype=np.int64)
    cd = np.asarray(chain_sq, dtype=float)
    off = cr != cc                                    # consecutive equal poses: inside the diagonal's c^2
    lo_k, hi_k = np.minimum(kr, kc), np.maximum(kr, kc)
    lo_c, hi_c = np.minimum(cr[off], cc[off]), np.maximum(cr[off], cc[off])
    key_k, key_c = lo_k * F + hi_k, lo_c * F + hi_c
    uk, first = np.unique(key_k, return_index=True)
    uc, inv_c, n_c = np.unique(key_c, return_inverse=True, return_counts=True)
    d_c = np.zeros(uc.size)
    d_c[inv_c] = cd[off]                              # equal pose pairs have equal distances: any of them
    keys = np.union1d(uk, uc)
    d2 = np.empty(keys.size)
    mult = np.zeros(keys.size)
    chain_n = np.zeros(keys.size)
    ik = np.searchsorted(keys, uk)
    ic = np.searchsorted(keys, uc)
    d2[ic] = d_c
    d2[ik] = kd[first]
    a, b = keys // F, keys % F
    mult[ic] = n_c                                    # chain-only pairs: just the consecutive frames
    mult[ik] = counts[a[ik]] * counts[b[ik]]          # kNN pairs: every frame pair of the two classes
    chain_n[ic] = n_c
    rows = np.concatenate([a, b, np.arange(F)])
    cols = np.concatenate([b, a, np.arange(F)])
    d_all = np.concatenate([d2, d2, np.zeros(F)])
    m_all = np.concatenate([mult, mult, counts * counts])
    c_all = np.concatenate([chain_n, chain_n, np.zeros(F)])
    is_diag = np.concatenate([np.zeros(2 * keys.size, dtype=bool), np.ones(F, dtype=bool)])
    order = np.lexsort((cols, rows))
    indptr = np.zeros(F + 1, dtype=np.int64)
    np.cumsum(np.bincount(rows, minlength=F), out=indptr[1:])
    arrays = (indptr, cols[order].astype(np.int32), rows[order], d_all[order], c_all[order] > 0, is_diag[order],
              m_all[order], c_all[order])
    for x in arrays:
        x.setflags(write=False)
    return KernelPattern(*arrays)


def sparse_kernel(knn, sigma: float, chain_floor: float = CHAIN_FLOOR) -> sp.csr_matrix:
    """Eq. 1 on the symmetric kNN + temporal-chain edge set (plus the unit diagonal), ``(F, F)`` CSR.

    ``K_ij = exp(-d_ij^2 / 2 sigma^2)`` where ``j`` is among ``i``'s k nearest, or ``i`` among ``j``'s, or
    ``|i - j| = 1`` (floored at ``chain_floor`` there, as in :func:`dense_kernel`); kNN pairs farther than
    ``KERNEL_CUTOFF * sigma`` are left out.  Memory ``O(F k)``.  ``knn`` is a :class:`KnnGraph` or its
    precomputed :class:`KernelPattern` (then only the values are computed: no sorting)."""
    s = _check_sigma(sigma)
    fl = _check_floor(chain_floor)
    p = knn if isinstance(knn, KernelPattern) else kernel_pattern(knn)
    F = p.num_frames
    vals = np.exp(p.sq_distances * (-0.5 / (s * s)))
    if p.multiplicity is None:
        vals[p.chain] = np.maximum(vals[p.chain], fl)
    else:   # a quotient pattern: every frame pair an entry stands for, the consecutive ones floored
        e = vals
        vals = p.multiplicity * e
        low = p.chain & (e < fl)
        vals[low] = (p.multiplicity[low] - p.chain_count[low]) * e[low] + p.chain_count[low] * fl
    # entries beyond KERNEL_CUTOFF sigmas are dropped (K < 1.6e-8): a sparser L factorises faster
    far = (p.sq_distances > (KERNEL_CUTOFF * s) ** 2) & ~p.chain
    if far.any():
        keep = ~far
        indptr = np.zeros(F + 1, dtype=np.int64)
        np.cumsum(np.bincount(p.rows[keep], minlength=F), out=indptr[1:])
        K = sp.csr_matrix((vals[keep], p.indices[keep], indptr), shape=(F, F))
    else:   # copies: scipy may sort or prune a matrix's index arrays in place, the pattern must not change
        K = sp.csr_matrix((vals, p.indices.copy(), p.indptr.copy()), shape=(F, F))
    K.has_sorted_indices = True
    return K


def normalized_adjacency(K):
    """Eq. 2: ``A = D^-1/2 K D^-1/2`` with ``D = diag(K 1)``; dense ndarray or scipy sparse in, same out.
    Also returns the degrees ``r (F,)``."""
    if sp.issparse(K):
        K = K.tocsr()
        r = np.asarray(K.sum(axis=1)).reshape(-1)
        s = 1.0 / np.sqrt(r)
        rows = np.repeat(np.arange(K.shape[0]), np.diff(K.indptr))
        return sp.csr_matrix((K.data * s[rows] * s[K.indices], K.indices, K.indptr), shape=K.shape), r
    r = K.sum(axis=1)
    s = 1.0 / np.sqrt(r)
    return K * s[:, None] * s[None, :], r


def normalized_laplacian(K):
    """``L = I - A`` (§3.1) for a dense ``(F, F)`` or sparse kernel; eigenvalues in [0, 2], the null
    vector (per connected component) is ``sqrt(r)``."""
    A, _ = normalized_adjacency(K)
    F = A.shape[0]
    if sp.issparse(A):
        return (sp.identity(F, format="csr") - A).tocsr()
    L = -A
    L[np.diag_indices(F)] += 1.0
    return L
