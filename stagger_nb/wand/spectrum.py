"""Eigenpairs of the normalised pose Laplacian ``L = I - D^-1/2 K D^-1/2`` (Dean et al. 2018, §3.1-3.2): the
smallest non-null ones, which Eq. 3 sums.

Dense path (:func:`_dense_eigs`): ``scipy.linalg.eigh`` with ``subset_by_index`` on the ``F x F`` Laplacian (in
float32 plus a float64 Rayleigh-Ritz step above :data:`_F32_MIN_FRAMES` frames).  Sparse path
(:func:`_sparse_eigs`): plain Lanczos on ``A = I - L`` up to :data:`LA_MAX_FRAMES` frames, ``eigsh`` in
shift-invert mode about a small negative shift above, memory ``O(F (k + N))``.  Every eigenvalue below
:data:`NULL_TOL` is the null space (one per connected component of the kernel graph) and is left out.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .laplacian import normalized_adjacency, normalized_laplacian

__all__ = ["NULL_TOL", "LA_MAX_FRAMES"]

NULL_TOL = 1e-9          # eigenvalues of L (in [0, 2]) below this are the null space (connected components)
# Shift-invert centre for eigsh: L + 1e-5 I is positive definite (it factorises) and well enough conditioned
# (2e5) for double precision, while 1e-5 stays below the wanted eigenvalues of long clips (~1e-5..1e-3),
# whose transformed values 1/(lambda + 1e-5) are then well separated (faster convergence than 1e-3).
_SHIFT = -1e-5
_EIGSH_TOL = 1e-8  # ARPACK relative accuracy of the Ritz values (eigenvalues change by ~1e-12 relative vs 0)
_F32_MIN_FRAMES = 300  # dense eigenpairs in float32 + a float64 Rayleigh-Ritz step above this many frames
_F32_EXTRA = 8         # extra float32 eigenvectors in that subspace (a buffer at the cut)
LA_MAX_FRAMES = 4000   # sparse path: plain Lanczos on A up to this many frames, shift-invert above
_LA_TOL = 1e-10        # its ARPACK tolerance (relative to mu ~ 1)
_LA_EXTRA = 0          # Krylov space of max(2k + 1, k + this): ARPACK's 2k + 1. Measured on CMU 01_01 (k = 51, five
                       # sigmas 0.7-1.4 x default, one BLAS thread): 0.138 s CPU mean at 2k + 1 = 103, 0.155 s at
                       # k + 70, 0.21 s at k + 100 (fewer vectors to re-orthogonalise against; the same restarts)



def _eigh_smallest(L: np.ndarray, hi: int):
    """The ``hi`` smallest eigenpairs of dense symmetric ``L``, ascending, + null mask.

    Above ``_F32_MIN_FRAMES`` frames the tridiagonalisation (the O(F^3) part) runs in float32, for
    ``_F32_EXTRA`` more eigenvectors than asked, and one Rayleigh-Ritz step in float64 on that subspace
    (``Q^T L Q``, ``(F, hi)`` products) restores double-precision eigenvalues (the null space is then found
    with ``NULL_TOL`` as before): half the time of the float64 solver on 600 frames.  Measured on 600
    frames of pymo_walk_turnaround: eigenvalues within 5e-13 of float64, falloffs within 2e-6."""
    F = L.shape[0]
    if F <= _F32_MIN_FRAMES:
        lam, phi = sla.eigh(L, subset_by_index=[0, hi - 1], check_finite=False, driver="evr")
        return lam, phi, lam < NULL_TOL
    h2 = min(F, hi + _F32_EXTRA)
    _, q = sla.eigh(L.astype(np.float32), subset_by_index=[0, h2 - 1], check_finite=False, driver="evr")
    Q, _ = np.linalg.qr(q.astype(np.float64))
    theta, Y = np.linalg.eigh(Q.T @ (L @ Q))
    lam, phi = theta[:hi], Q @ Y[:, :hi]
    return lam, phi, lam < NULL_TOL


def _dense_eigs(K: np.ndarray, N: int):
    """Smallest non-null eigenpairs of the dense normalised Laplacian of ``K (F, F)``."""
    F = K.shape[0]
    r = K.sum(axis=1)
    L = normalized_laplacian(K)
    hi = min(F, N + 1)
    lam, phi, null = _eigh_smallest(L, hi)
    null_dim = int(np.count_nonzero(null))
    if null_dim > 1 and hi < F:  # several components: fetch enough eigenpairs to keep N non-null ones
        lam, phi, null = _eigh_smallest(L, min(F, N + null_dim))
        null_dim = int(np.count_nonzero(null))
    keep = np.flatnonzero(~null)[:N]
    return lam[keep], phi[:, keep], null_dim, r


def _shift_invert(L) -> spla.LinearOperator:
    """``(L - _SHIFT I)^-1`` as an operator: one sparse LU with a minimum-degree ordering on ``L + L^T``
    (L is symmetric; on kNN pose graphs this ordering fills in about 40 % less than COLAMD)."""
    F = L.shape[0]
    lu = spla.splu((L - _SHIFT * sp.identity(F, format="csc")).tocsc(), permc_spec="MMD_AT_PLUS_A")
    return spla.LinearOperator(L.shape, matvec=lu.solve, dtype=float)


def _eigsh_smallest(L, k: int, v0: np.ndarray, op=None):
    """``k`` eigenpairs of sparse ``L`` nearest ``_SHIFT`` (shift-invert Lanczos), ascending, + null mask."""
    ncv = min(L.shape[0] - 1, k + max(20, k // 2))  # a smaller Krylov space than ARPACK's 2k+1: fewer solves
    lam, phi = spla.eigsh(L, k=k, sigma=_SHIFT, which="LM", v0=v0, OPinv=op or _shift_invert(L), ncv=ncv,
                          tol=_EIGSH_TOL)
    order = np.argsort(lam)
    lam, phi = lam[order], phi[:, order]
    return lam, phi, lam < NULL_TOL


def _largest_adjacency(K, k: int, v0: np.ndarray):
    """``k`` eigenpairs of ``L`` from the largest of ``A = D^-1/2 K D^-1/2`` (plain Lanczos, no factorisation;
    ``L = I - A``), ascending in ``lambda``, + null mask.  The eigenvalues are the Rayleigh quotients
    ``phi^T L phi`` (accurate to ~1e-15 absolute, where ``1 - mu`` would keep the Ritz tolerance)."""
    A, _ = normalized_adjacency(K)
    ncv = min(A.shape[0] - 1, max(2 * k + 1, k + _LA_EXTRA))
    mu, phi = spla.eigsh(A, k=k, which="LA", v0=v0, ncv=ncv, tol=_LA_TOL)
    phi = phi[:, np.argsort(-mu)]
    lam = np.maximum(np.einsum("fk,fk->k", phi, phi - A @ phi), 0.0)
    order = np.argsort(lam, kind="stable")
    lam, phi = lam[order], phi[:, order]
    return lam, phi, lam < NULL_TOL


def _sparse_eigs(K, N: int):
    """Smallest non-null eigenpairs of the sparse normalised Laplacian: plain Lanczos on ``A`` up to
    ``LA_MAX_FRAMES`` frames (measured on CMU 01_01, 2,751 frames: 0.19 s CPU against 0.41 s for shift-invert,
    whose sparse LU fills in), shift-invert Lanczos above (the small eigenvalues of long clips cluster near 0,
    where plain Lanczos converges slowly)."""
    F = K.shape[0]
    r = np.asarray(K.sum(axis=1)).reshape(-1)
    if F <= 2 * N + 16:  # ARPACK needs k < F - 1 and room for its Krylov space; tiny graphs go dense
        return _dense_eigs(K.toarray(), N)
    k = N + 1
    v0 = np.sqrt(r) / np.linalg.norm(np.sqrt(r))  # a deterministic start vector (the null vector itself)
    if F <= LA_MAX_FRAMES:
        lam, phi, null = _largest_adjacency(K, k, v0)
        null_dim = int(np.count_nonzero(null))
        if null_dim > 1 and k < F - 2:
            lam, phi, null = _largest_adjacency(K, min(N + null_dim, F - 2), v0)
            null_dim = int(np.count_nonzero(null))
        keep = np.flatnonzero(~null)[:N]
        return lam[keep], phi[:, keep], null_dim, r
    L = normalized_laplacian(K).tocsc()
    op = _shift_invert(L)
    lam, phi, null = _eigsh_smallest(L, k, v0, op)
    null_dim = int(np.count_nonzero(null))
    if null_dim > 1 and k < F - 2:  # several components: fetch enough eigenpairs to keep N non-null ones
        lam, phi, null = _eigsh_smallest(L, min(N + null_dim, F - 2), v0, op)
        null_dim = int(np.count_nonzero(null))
    keep = np.flatnonzero(~null)[:N]
    return lam[keep], phi[:, keep], null_dim, r
