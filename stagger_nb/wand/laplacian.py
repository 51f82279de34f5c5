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
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

__all__ = ["pairwise_sq_distances", "KnnGraph", "knn_graph", "default_sigma", "dense_kernel",
           "sparse_kernel", "normalized_adjacency", "normalized_laplacian", "DEFAULT_SIGMA_NEIGHBOURS",
           "DEFAULT_SIGMA_PERCENTILE"]

# Default sigma = this percentile over frames of the distance to the k-th nearest neighbour (see default_sigma).
DEFAULT_SIGMA_NEIGHBOURS = 8
DEFAULT_SIGMA_PERCENTILE = 50.0
_CHUNK_ENTRIES = 4_000_000  # rows x F distance block per chunk of the kNN search (~32 MB of float64)


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
    """Exact k nearest neighbours of each row of ``X (F, D)`` by chunked brute force (BLAS blocks of
    about ``_CHUNK_ENTRIES`` distances, so peak memory is ``O(F k)`` + one block, never ``O(F^2)``)."""
    X = np.asarray(X, dtype=float)
    F = X.shape[0]
    k = int(k)
    if k < 1 or k > F - 1:
        raise ValueError(f"k must be in [1, F - 1] = [1, {F - 1}], got {k}")
    xx = np.einsum("ij,ij->i", X, X)
    idx = np.empty((F, k), dtype=np.int64)
    d2 = np.empty((F, k))
    rows = max(1, _CHUNK_ENTRIES // max(F, 1))
    for s in range(0, F, rows):
        e = min(F, s + rows)
        B = xx[s:e, None] + xx[None, :] - 2.0 * (X[s:e] @ X.T)
        B[np.arange(e - s), np.arange(s, e)] = np.inf  # exclude self
        part = np.argpartition(B, k - 1, axis=1)[:, :k]
        pd = np.take_along_axis(B, part, axis=1)
        order = np.argsort(pd, axis=1, kind="stable")
        idx[s:e] = np.take_along_axis(part, order, axis=1)
        d2[s:e] = np.maximum(np.take_along_axis(pd, order, axis=1), 0.0)
    chain = np.sum((X[1:] - X[:-1]) ** 2, axis=1)
    return KnnGraph(idx, d2, chain)


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


def _check_sigma(sigma) -> float:
    s = float(sigma)
    if not np.isfinite(s) or s <= 0:
        raise ValueError(f"sigma must be a finite number > 0, got {sigma!r}")
    return s


def dense_kernel(D2: np.ndarray, sigma: float) -> np.ndarray:
    """Eq. 1 on all pairs: ``K (F, F) = exp(-D2 / (2 sigma^2))`` from squared distances ``D2 (F, F)``."""
    s = _check_sigma(sigma)
    return np.exp(D2 * (-0.5 / (s * s)))


def sparse_kernel(knn: KnnGraph, sigma: float) -> sp.csr_matrix:
    """Eq. 1 on the symmetric kNN + temporal-chain edge set (plus the unit diagonal), ``(F, F)`` CSR.

    ``K_ij = exp(-d_ij^2 / 2 sigma^2)`` where ``j`` is among ``i``'s k nearest, or ``i`` among ``j``'s, or
    ``|i - j| = 1``; the symmetric union uses each edge once (maximum of duplicates, which are equal)."""
    s = _check_sigma(sigma)
    F, k = knn.indices.shape
    c = -0.5 / (s * s)
    rows = np.concatenate([np.repeat(np.arange(F), k), np.arange(F - 1)])
    cols = np.concatenate([knn.indices.reshape(-1), np.arange(1, F)])
    vals = np.exp(np.concatenate([knn.sq_distances.reshape(-1), knn.chain_sq]) * c)
    W = sp.coo_matrix((vals, (rows, cols)), shape=(F, F)).tocsr()
    W.sum_duplicates()
    # symmetric union: max(W, W^T) (duplicates hold the same value, so max is the value itself)
    W = W.maximum(W.T)
    W = W + sp.identity(F, format="csr")
    return W.tocsr()


def normalized_adjacency(K):
    """Eq. 2: ``A = D^-1/2 K D^-1/2`` with ``D = diag(K 1)``; dense ndarray or scipy sparse in, same out.
    Also returns the degrees ``r (F,)``."""
    if sp.issparse(K):
        r = np.asarray(K.sum(axis=1)).reshape(-1)
        s = 1.0 / np.sqrt(r)
        Dm = sp.diags(s)
        return (Dm @ K @ Dm).tocsr(), r
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
