"""Green's function of the pose-space Laplacian (Dean et al. 2018, §3.2, Eq. 3).

``G(p_i, p_j) = sum_{k>0} phi_k(p_i) phi_k(p_j) / lambda_k`` over the eigenpairs ``(lambda_k, phi_k)`` of
``L = I - D^-1/2 K D^-1/2`` (§3.1), truncated to the first ``N`` non-null eigenpairs ("typically only a
few terms of the sum are needed since it is dominated by the smaller eigenvalues").

What exactly is computed (the choices the paper leaves open, stated once):

**Deviations from the paper, and why the defaults are not Eq. 3 as printed.**  The paper's formula is
``greens_basis(m, self_term=True, normalization="symmetric", chain_floor=0.0, reference="identity",
heading="keep", flips="keep")`` (every flag is opt-in; ``heading``: the default pose space leaves the root's
heading out, ``flips``: it leaves out joints that flip 180 degrees between frames, :mod:`.pose_space`).
Measured on the issue's checks (default sigma, N = 50; same-phase weight must be >= 0.8 and opposite-phase
<= 0.1, ``tests/test_wand_cyclic.py``), it fails them: xia_angry_run same phase
0.67 / 0.59 (frames 10 / 20); bandai_run_cycle looped x4 same phase 0.47 / 0.81 / 0.56 and opposite
0.22 / 0.33 / 0.37 (frames 3 / 5 / 15), with the neighbours of the edited frame down to 0.36 (a spike:
the "snap" the paper blames on ISOMAP); xia_neutral_walk opposite 0.13.  No N in {5, 10, 20, 50} with
sigma x {0.5, 1, 2} passes all eight cases, with the plain or the mean-relative log.  The defaults pass
(same phase 0.82-1.00, opposite <= 0.06).  Each deviation alone, from the defaults: ``self_term=True``
fails (xia_angry_run 0.71 / 0.62, bandai 0.62 / 0.96 / 0.70); ``normalization="symmetric"`` fails
(xia_neutral_walk opposite 0.14); the other two are explained where they live (``reference`` in
:mod:`.pose_space`: the log cut near pi; ``chain_floor`` in :mod:`.laplacian`: glitches nearly cutting
the graph).  The two spectral choices:

* **Eigenvectors** (``normalization``):  ``"random_walk"`` (default) uses ``psi_k = D^-1/2 phi_k``, so with
  all eigenpairs ``G = D^-1/2 L^+ D^-1/2``, the Green's function of the random-walk Laplacian
  ``I - D^-1 K`` (``(I - D^-1 K) G = D^-1 - 1 1^T / vol``).  It obeys a maximum principle: each full row
  peaks at its own frame, so the [0, 1] falloff of §3.3 is 1 there.  ``"symmetric"`` uses ``phi_k`` as
  printed, ``G = L^+``; its rows are modulated by ``sqrt(degree)`` and can peak away from their frame.
* **Null space**: every eigenvalue below ``NULL_TOL`` (one per connected component of the kernel graph)
  is left out; with all other eigenpairs ``G`` is the pseudo-inverse on the complement of the null space.
* **Self term** (``self_term``):  ``L^+ = I + A + A^2 + ...`` on that complement, so Eq. 3 holds a
  point-source spike ``1/degree_i`` on its diagonal (the ``lambda ~ 1`` eigenvectors, which are many because
  a Gaussian kernel matrix is numerically low-rank).  Kept (``self_term=True``), the falloff of §3.3 jumps
  at the edited frame by a fraction that grows with sigma, and truncating the sum to remove the spike
  shifts the peak (the "offset of 2-3 frames" of §4.2).  Dropped (default), the spectral weight
  is ``1/lambda - 1`` instead of ``1/lambda``: with all eigenpairs that is exactly
  ``G - D^-1 + 1 1^T / vol`` (random walk) — Eq. 3 unchanged off the diagonal, a smooth (rounded) peak at
  the edited frame, and a sum that converges in a few dozen eigenpairs (falloffs within 0.02-0.035 of
  all eigenpairs with N = 50 on 327-600-frame clips).  The price: no maximum principle, so a row may peak a
  few frames off its frame or at a repetition; the clip of §3.3 gives those frames weight 1 (measured on
  the six real clips: the clipped excess of the row over its own value is median <= 0.2 %, max 3 %, and
  12.7 % on CMU 131_01; see :mod:`.falloff`).

Dense path: ``scipy.linalg.eigh`` with ``subset_by_index`` on the ``F x F`` Laplacian.  Sparse path: the
kNN kernel of :func:`.laplacian.sparse_kernel` and ``scipy.sparse.linalg.eigsh`` in shift-invert mode
about a small negative shift, memory ``O(F (k + N))``.  Only the rows an edit needs are formed
(``basis.row(i)`` costs one ``(F, N) @ (N,)`` product).
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..core.digest import content_key
from ..core.motion import Motion
from .laplacian import (
    CHAIN_FLOOR,
    KernelPattern,
    KnnGraph,
    _check_sigma,
    default_sigma,
    dense_kernel,
    distinct_poses,
    kernel_pattern,
    knn_graph,
    normalized_adjacency,
    normalized_laplacian,
    pairwise_sq_distances,
    quotient_pattern,
    sparse_kernel,
)
from .pose_space import pose_vectors

__all__ = ["GreensBasis", "PoseGraph", "pose_graph", "greens_basis", "greens_rows", "NULL_TOL", "GRAPH_CACHE",
           "DENSE_MAX_FRAMES", "SPARSE_MAX_FRAMES", "MAX_LANDMARKS", "DEFAULT_NUM_EIGS", "DEFAULT_KNN",
           "cached_pose_graph", "clear_graph_cache"]

NULL_TOL = 1e-9          # eigenvalues of L (in [0, 2]) below this are the null space (connected components)
DENSE_MAX_FRAMES = 1200  # method="auto": dense eigendecomposition up to this many frames (~0.2 s), sparse above
DEFAULT_NUM_EIGS = 50    # N, the number of non-null eigenpairs kept in Eq. 3
GRAPH_CACHE = 4          # PoseGraphs the one-call functions (falloff, propagate, greens_basis) keep, see below
SPARSE_MAX_FRAMES = 20000  # method="auto": the sparse graph of every frame up to this many, landmarks above
MAX_LANDMARKS = 8000       # frames of a landmark graph at most
DEFAULT_KNN = 64         # neighbours per frame of the sparse kernel (~0.25 s of motion either side at 120 Hz)
# Shift-invert centre for eigsh: L + 1e-5 I is positive definite (it factorises) and well enough conditioned
# (2e5) for double precision, while 1e-5 stays below the wanted eigenvalues of long clips (~1e-5..1e-3),
# whose transformed values 1/(lambda + 1e-5) are then well separated (faster convergence than 1e-3).
_SHIFT = -1e-5
_EIGSH_TOL = 1e-8  # ARPACK relative accuracy of the Ritz values (eigenvalues change by ~1e-12 relative vs 0)
_F32_MIN_FRAMES = 300  # dense eigenpairs in float32 + a float64 Rayleigh-Ritz step above this many frames
_F32_EXTRA = 8         # extra float32 eigenvectors in that subspace (a buffer at the cut)
_COEF_TOL = 1e-10      # spectral weights below this are rounding noise of lambda = 1
LA_MAX_FRAMES = 4000   # sparse path: plain Lanczos on A up to this many frames, shift-invert above
_LA_TOL = 1e-10        # its ARPACK tolerance (relative to mu ~ 1)
_LA_EXTRA = 0          # Krylov space of max(2k + 1, k + this): ARPACK's 2k + 1. Measured on CMU 01_01 (k = 51, five
                       # sigmas 0.7-1.4 x default, one BLAS thread): 0.138 s CPU mean at 2k + 1 = 103, 0.155 s at
                       # k + 70, 0.21 s at k + 100 (fewer vectors to re-orthogonalise against; the same restarts)


@dataclass(frozen=True, eq=False)
class GreensBasis:
    """Truncated eigenbasis of the pose Laplacian for one sigma: Green's rows in ``O(F N)`` each.

    Attributes
    ----------
    eigenvalues : ndarray, shape (N,)
        Non-null eigenvalues ``lambda_k`` of ``L``, ascending.
    eigenvectors : ndarray, shape (F, N)
        ``psi_k = D^-1/2 phi_k`` (random walk) or ``phi_k`` (symmetric), one column per eigenvalue.
    degrees : ndarray, shape (F,)
        Kernel row sums ``r``.
    sigma : float
        Kernel width (pose-vector units, i.e. log-map radians / 2 when weights are 1).
    self_term : bool
        Spectral weight ``1/lambda`` (Eq. 3 as printed) when True, ``1/lambda - 1`` when False.
    normalization : str
        ``"random_walk"`` or ``"symmetric"``.
    method : str
        ``"dense"`` or ``"sparse"``.
    null_dim : int
        Number of null eigenvalues left out (connected components of the kernel graph), or -1 when the
        sparse solver could not tell.
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    degrees: np.ndarray
    sigma: float
    self_term: bool = False
    normalization: str = "random_walk"
    method: str = "dense"
    null_dim: int = 1
    _coef: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        lam = np.asarray(self.eigenvalues, dtype=float)
        coef = 1.0 / lam if self.self_term else 1.0 / lam - 1.0
        # lambda = 1 to rounding (e.g. every pose of a static clip alike) carries no weight: make it exactly 0
        coef[np.abs(coef) < _COEF_TOL] = 0.0
        object.__setattr__(self, "_coef", coef)

    @property
    def num_frames(self) -> int:
        return int(self.eigenvectors.shape[0])

    @property
    def num_eigs(self) -> int:
        return int(self.eigenvectors.shape[1])

    def _frames(self, frames) -> np.ndarray:
        f = np.asarray(frames)
        if f.dtype.kind not in "iu" or f.ndim > 1:
            raise ValueError(f"frame must be an integer frame index, got {frames!r}")
        if np.any(f < 0) or np.any(f >= self.num_frames):
            raise ValueError(f"frame must be in [0, {self.num_frames}), got {frames!r}")
        return f

    def row(self, frame: int) -> np.ndarray:
        """Green's row ``G(p_frame, p_j)`` for all ``j``, shape (F,): one ``(F, N) @ (N,)`` product."""
        f = self._frames(frame)
        if f.ndim:
            raise ValueError(f"frame must be one integer frame index, got {frame!r}")
        i = int(f)
        return self.eigenvectors @ (self.eigenvectors[i] * self._coef)

    def rows(self, frames) -> np.ndarray:
        """Green's rows for several frames, shape (E, F)."""
        f = self._frames(np.atleast_1d(np.asarray(frames)))
        return (self.eigenvectors[f] * self._coef) @ self.eigenvectors.T

    def matrix(self) -> np.ndarray:
        """The whole ``(F, F)`` matrix ``P`` of §3.2 (memory ``O(F^2)``: small clips and tests only)."""
        return (self.eigenvectors * self._coef) @ self.eigenvectors.T


@dataclass(frozen=True, eq=False)
class PoseGraph:
    """The sigma-independent head of the pipeline, computed once per clip: pose vectors and either all
    squared distances (dense) or the kNN table (sparse).  ``basis(sigma)`` is the cheap tail.

    Attributes
    ----------
    pose_vectors : ndarray, shape (F, D)
    sq_distances : ndarray, shape (F, F), or None (sparse)
    knn : KnnGraph
        The sparse kernel's neighbours; on the dense path a small table (k = 8) backs ``default_sigma``.
    method : str
        ``"dense"``, ``"sparse"`` or ``"landmarks"``.
    landmarks : ndarray, shape (F_l,), int, or None
        ``"landmarks"`` (long takes): the frames the graph is built on (every ``stride``-th frame and the last);
        ``knn`` indexes them, and the eigenvectors are interpolated linearly in time to every frame.
    pattern : KernelPattern or None
        Sparse paths: the kernel's CSR structure built from ``knn`` once (:func:`.laplacian.kernel_pattern`),
        so a new sigma only recomputes kernel values (about a fifth of a new sigma's time on CMU 01_01).
    nodes, counts : ndarray (F,) int and (C,), or None
        Sparse paths on a clip that repeats poses exactly (:func:`.laplacian.distinct_poses`, e.g. a take
        concatenated with itself): the graph is on the C distinct poses (:func:`.laplacian.quotient_pattern`),
        ``nodes[f]`` is frame f's node (-1: between landmarks, interpolated in time) and ``counts`` the frames
        each node stands for.  None: one node per graph frame, as before.

    Immutable, with no hidden state: ``basis(sigma)`` computes a new :class:`GreensBasis` on every call.  A
    caller that revisits sigma values keeps the bases it wants (the session's cache does).
    """

    pose_vectors: np.ndarray
    sq_distances: np.ndarray | None
    knn: KnnGraph
    method: str
    landmarks: np.ndarray | None = None
    pattern: KernelPattern | None = None
    nodes: np.ndarray | None = None
    counts: np.ndarray | None = None
    sigma_knn: KnnGraph | None = None

    @property
    def num_frames(self) -> int:
        return int(self.pose_vectors.shape[0])

    @property
    def default_sigma(self) -> float:
        """See :func:`.laplacian.default_sigma` (median distance to the 8th nearest neighbour); with
        ``pose_graph(..., sigma_rate=r)`` measured on frames ``1 / r`` s apart (``sigma_knn``)."""
        return default_sigma(knn=self.knn if self.sigma_knn is None else self.sigma_knn)

    def basis(self, sigma: float | None = None, num_eigs: int | None = None, self_term: bool = False,
              normalization: str = "random_walk", chain_floor: float = CHAIN_FLOOR) -> GreensBasis:
        """Eigenpairs for kernel width ``sigma`` (default :attr:`default_sigma`); see :func:`greens_basis`."""
        F = self.num_frames
        if F < 2:
            raise ValueError("the magic wand needs at least 2 frames")
        s = self.default_sigma if sigma is None else _check_sigma(sigma)
        if normalization not in ("random_walk", "symmetric"):
            raise ValueError(f"normalization must be 'random_walk' or 'symmetric', got {normalization!r}")
        N = DEFAULT_NUM_EIGS if num_eigs is None else int(num_eigs)
        if N < 1:
            raise ValueError(f"num_eigs must be >= 1, got {num_eigs!r}")
        if self.method == "dense":
            K = dense_kernel(self.sq_distances, s, chain_floor)
            lam, phi, null_dim, r = _dense_eigs(K, N)
        else:
            K = sparse_kernel(self.knn if self.pattern is None else self.pattern, s, chain_floor)
            lam, phi, null_dim, r = _sparse_eigs(K, N)
        if lam.size == 0:
            raise ValueError(f"sigma={s!r} leaves no non-null eigenpair (every frame is its own component); "
                             "increase sigma")
        if self.nodes is not None:
            # the quotient graph (module docstring of .laplacian.quotient_pattern): a frame of class A has
            # degree r_A / c_A; psi lifts as it is, phi as phi_A / sqrt(c_A)
            c = np.asarray(self.counts, dtype=float)
            vecs = phi / np.sqrt(r)[:, None] if normalization == "random_walk" else phi / np.sqrt(c)[:, None]
            return GreensBasis(lam, np.ascontiguousarray(_lift(self.nodes, vecs)), _lift(self.nodes, r / c),
                               float(s), bool(self_term), normalization, self.method, null_dim)
        vecs = phi / np.sqrt(r)[:, None] if normalization == "random_walk" else phi
        if self.landmarks is not None:
            vecs, r = _interpolate_frames(self.landmarks, F, vecs), _interpolate_frames(self.landmarks, F, r)
        return GreensBasis(lam, np.ascontiguousarray(vecs), r, float(s), bool(self_term), normalization,
                           self.method, null_dim)


def _lift(nodes: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Node values ``(C, ...)`` -> every frame ``(F, ...)``: ``values[nodes[f]]``, and for frames without a node
    (``nodes[f] = -1``, between landmarks) linear interpolation in time between the nearest frames with one."""
    have = np.flatnonzero(nodes >= 0)
    if have.size == nodes.size:
        return values[nodes]
    return _interpolate_frames(have, nodes.size, values[nodes[have]])


def _interpolate_frames(frames: np.ndarray, F: int, values: np.ndarray) -> np.ndarray:
    """Values at ascending ``frames`` (first 0, last F - 1), shape (F_l, ...) -> every frame, (F, ...),
    linearly in time."""
    t = np.arange(F)
    i1 = np.clip(np.searchsorted(frames, t, side="right"), 1, frames.size - 1)
    i0 = i1 - 1
    w = ((t - frames[i0]) / (frames[i1] - frames[i0])).reshape((F,) + (1,) * (values.ndim - 1))
    lo = values[i0]                           # v0 (1 - w) + v1 w in place: two (F, ...) arrays, not five;
    lo *= 1.0 - w                             # exact at both ends of every interval
    out = values[i1]
    out *= w
    out += lo
    return out


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


def pose_graph(motion: Motion, method: str = "auto", knn: int = DEFAULT_KNN, joint_weights=None,
               time_weight: float = 0.0, reference="mean", heading: str = "remove", distinct: bool = True,
               flips: str = "drop", sigma_rate: float | None = None) -> PoseGraph:
    """Pose vectors + distances for ``motion`` (the expensive, sigma-independent head; cache it).

    Parameters
    ----------
    motion : Motion
    method : "auto" | "dense" | "sparse" | "landmarks"
        ``auto``: dense up to ``DENSE_MAX_FRAMES`` frames, sparse up to ``SPARSE_MAX_FRAMES``, landmarks above.
        Dense keeps ``F x F`` squared distances; sparse a kNN table of every frame; ``landmarks`` (long takes)
        builds the sparse graph on every ``ceil(F / MAX_LANDMARKS)``-th frame (and the last) and interpolates
        its eigenvectors linearly in time, so the eigenproblem stays at most ``MAX_LANDMARKS`` frames (a
        sparse LU of 100,000 frames does not fit in 4 GB).  An approximation, and not a small one on every clip:
        against the sparse graph of every frame, on the 20,000-frame benchmark clip (xia walk/run copies),
        stride 2 gives falloffs within mean 0.009 / max 0.07, stride 4 mean 0.017 / max 0.19; on a 400-frame
        synthetic cyclic clip stride 2 gives mean 0.28 (the temporal chain's diffusion, which the chain floor
        makes strong, depends on the sampling).  ``benchmarks/bench_wand.py`` prints the figures.
    knn : int
        Neighbours per frame of the sparse kernel (ignored by the dense kernel).
    joint_weights, time_weight, reference, heading, flips
        See :func:`.pose_space.pose_vectors` (``heading="keep"``: the paper's pose space, root heading included;
        ``flips="keep"``: joints that flip 180 degrees between frames kept in the distance).
    distinct : bool
        Poses a clip repeats exactly (a take concatenated with itself) form one node each on the sparse paths,
        and the default sigma is taken over distinct poses (default; :func:`_quotient_graph`, measured there).
        ``False``: one node per frame, as Eq. 1 is written (the graphs of such clips then depend on k).
    sigma_rate : float or None
        None (default, the paper's data-derived form): the default sigma from every frame's 8th nearest
        neighbour, so it shrinks with the capture rate (at 120 Hz 95 % of those neighbours are the frame's own
        neighbours in time: CMU 01_01 sigma 0.112 at 120 Hz, 0.235 resampled to 30 Hz).  A rate ``r`` (e.g. 30)
        takes it on frames ``round(1 / (r * frame_time))`` apart, so it no longer depends on the capture rate.
        Measured (session 8, ``benchmarks/bench_claims.py`` docstring): CMU 01_01 at 120 Hz hop apex falloff
        0.50 / 0.04 -> 0.77 / 0.01 (goal >= 0.7 / <= 0.3); issue 24's propagated arm edit opposite phase
        0.55 -> 0.19 but same phase 0.83 -> 0.66 (goal >= 0.8); the opposite phase of 120 Hz turning walks and
        runs rises to 0.17-0.33 (issue 13's tests bound it at 0.1).  Tried as the default it failed 16 of 400
        wand / compose / session tests, among them dense vs sparse agreement and two of issue 24's held-out
        rows that pass today, so it stays opt-in.
    """
    if sigma_rate is not None:
        sigma_rate = float(sigma_rate)
        if not np.isfinite(sigma_rate) or sigma_rate <= 0:
            raise ValueError(f"sigma_rate must be a finite rate in Hz > 0 or None, got {sigma_rate!r}")
    if method not in ("auto", "dense", "sparse", "landmarks"):
        raise ValueError(f"method must be 'auto', 'dense', 'sparse' or 'landmarks', got {method!r}")
    X = pose_vectors(motion, joint_weights=joint_weights, time_weight=time_weight, reference=reference,
                     heading=heading, flips=flips)
    F = X.shape[0]
    if F < 2:
        raise ValueError("the magic wand needs a motion with at least 2 frames")
    if method == "auto":
        method = "dense" if F <= DENSE_MAX_FRAMES else ("sparse" if F <= SPARSE_MAX_FRAMES else "landmarks")
    if distinct:
        first, inverse, counts = distinct_poses(X)
    else:
        first, inverse, counts = np.arange(F), np.arange(F), np.ones(F, dtype=np.int64)
    sigma_knn = None if sigma_rate is None else _sigma_table(X, motion.frame_time, sigma_rate)
    if method == "dense":
        D2 = pairwise_sq_distances(X)
        # the default sigma from distinct poses: a take repeated 20 times gives every frame 19 equal poses, whose
        # 8th nearest is at distance 0 (sigma = the 1e-9 floor)
        U = X if first.size == F else X[first]
        table = knn_graph(U, min(8, U.shape[0] - 1)) if U.shape[0] > 1 else knn_graph(X, min(8, F - 1))
        return PoseGraph(X, D2, table, "dense", sigma_knn=sigma_knn)
    k = int(knn)
    if k < 1:
        raise ValueError(f"knn must be >= 1, got {knn!r}")
    if first.size < F and first.size >= 2:
        return replace(_quotient_graph(X, method, k, first, inverse, counts), sigma_knn=sigma_knn)
    if method == "sparse":
        table = knn_graph(X, min(k, F - 1))
        return PoseGraph(X, None, table, "sparse", pattern=kernel_pattern(table), sigma_knn=sigma_knn)
    stride = max(1, -(-F // MAX_LANDMARKS))
    frames = np.unique(np.r_[np.arange(0, F, stride), F - 1])
    table = knn_graph(X[frames], min(k, frames.size - 1))
    return PoseGraph(X, None, table, "landmarks", frames, kernel_pattern(table), sigma_knn=sigma_knn)


def _sigma_table(X: np.ndarray, frame_time: float, rate: float) -> KnnGraph:
    """The 8-neighbour table of the distinct poses of every ``round(1 / (rate * frame_time))``-th frame."""
    step = max(1, int(round(1.0 / (rate * frame_time))))
    U = X[::step]
    first, _, _ = distinct_poses(U)
    if first.size > 1:
        U = U[first]
    return knn_graph(U, min(8, U.shape[0] - 1))


def _quotient_graph(X: np.ndarray, method: str, k: int, first, inverse, counts) -> PoseGraph:
    """The sparse / landmark graph of a clip that repeats poses exactly: on its distinct poses (issue 25).

    The frames' kNN graph of a take repeated 60 times links each frame to its 59 equal poses and to few others
    (k = 64), and the landmark graph, which sees every third frame, to fewer of them: the two disagreed
    (falloffs mean 0.26-0.34 apart, max 1.0 on 20,000 frames of xia_neutral_walk repeated).  On the distinct
    poses with their multiplicities (:func:`.laplacian.quotient_pattern`) both are the same graph while the
    distinct poses fit :data:`MAX_LANDMARKS`; beyond, landmarks every ``ceil(F / MAX_LANDMARKS)``-th frame and
    the classes they fall in."""
    F = X.shape[0]
    if method == "sparse" or first.size <= MAX_LANDMARKS:
        frames = np.arange(F)
        landmarks = None
    else:
        stride = max(1, -(-F // MAX_LANDMARKS))
        frames = np.unique(np.r_[np.arange(0, F, stride), F - 1])
        landmarks = frames
    cls = inverse[frames]
    node_cls, node_of = np.unique(cls, return_inverse=True)      # graph nodes: the classes the frames fall in
    node_of = node_of.reshape(-1)
    ncount = np.bincount(node_of, minlength=node_cls.size).astype(float)
    reps = first[node_cls]
    table = knn_graph(X[reps], min(k, reps.size - 1))
    chain_sq = np.sum((X[frames[1:]] - X[frames[:-1]]) ** 2, axis=1)
    pattern = quotient_pattern(table, ncount, node_of[:-1], node_of[1:], chain_sq)
    nodes = np.full(F, -1, dtype=np.int64)
    lookup = np.full(first.size, -1, dtype=np.int64)
    lookup[node_cls] = np.arange(node_cls.size)
    nodes[:] = lookup[inverse]                                     # every frame whose pose is a node's
    return PoseGraph(X, None, table, method, landmarks, pattern, nodes, ncount)


_GRAPHS: OrderedDict[bytes, PoseGraph] = OrderedDict()
_GRAPHS_LOCK = threading.Lock()


def _graph_key(motion: Motion, options: dict) -> bytes:
    """Content key of (motion rotations, skeleton, options) (:func:`..core.digest.content_key`), never ``id()``."""
    opts = tuple((name, options[name]) for name in sorted(options))
    return content_key(motion.local_quats, motion.skeleton.parents,
                       (motion.num_frames, motion.frame_time, motion.skeleton.names), opts)


def cached_pose_graph(motion: Motion, **options) -> PoseGraph:
    """:func:`pose_graph` through a small module cache, so the one-call functions (:func:`greens_basis`,
    ``wand.falloff``, ``wand.propagate``) do not rebuild the sigma-independent graph when only sigma changes.

    Explicit and bounded: keyed by the content of ``motion.local_quats``, the skeleton and ``options`` (a
    BLAKE2b digest; about 1 ms per MB of rotations), holds the last :data:`GRAPH_CACHE` graphs, least recently
    used out first; :func:`clear_graph_cache` empties it.  Graphs are immutable, so sharing them is safe.
    Callers that manage their own caching (the session) call :func:`pose_graph` directly."""
    key = _graph_key(motion, options)
    with _GRAPHS_LOCK:
        g = _GRAPHS.get(key)
        if g is not None:
            _GRAPHS.move_to_end(key)
            return g
    g = pose_graph(motion, **options)
    with _GRAPHS_LOCK:
        _GRAPHS[key] = g
        while len(_GRAPHS) > GRAPH_CACHE:
            _GRAPHS.popitem(last=False)
    return g


def clear_graph_cache() -> None:
    """Empty the module cache of :func:`cached_pose_graph`."""
    with _GRAPHS_LOCK:
        _GRAPHS.clear()


def greens_basis(motion: Motion, sigma: float | None = None, num_eigs: int | None = None, method: str = "auto",
                 knn: int = DEFAULT_KNN, self_term: bool = False, normalization: str = "random_walk",
                 chain_floor: float = CHAIN_FLOOR, joint_weights=None, time_weight: float = 0.0,
                 reference="mean", heading: str = "remove", distinct: bool = True, flips: str = "drop",
                 sigma_rate: float | None = None) -> GreensBasis:
    """Eigenpairs of the pose Laplacian of ``motion`` for one ``sigma`` (§3.1-3.2).

    For a sigma slider build :func:`pose_graph` once and call ``graph.basis(sigma)`` per value; this one-call
    form reuses the graph of the same motion and options through :func:`cached_pose_graph`.

    Parameters
    ----------
    sigma : float or None
        Kernel width in pose-vector units; None = the data-derived default (:func:`.laplacian.default_sigma`).
    num_eigs : int or None
        N, the non-null eigenpairs kept in Eq. 3 (default ``DEFAULT_NUM_EIGS``; capped at F - null_dim).
    self_term, normalization
        See the module docstring.
    chain_floor : float in [0, 1]
        Minimum kernel value between consecutive frames (:mod:`.laplacian`); 0 = plain Eq. 1.
    method, knn, joint_weights, time_weight, reference, heading, distinct, flips, sigma_rate
        See :func:`pose_graph`.
    """
    if sigma is not None:
        _check_sigma(sigma)
    g = cached_pose_graph(motion, method=method, knn=knn, joint_weights=joint_weights, time_weight=time_weight,
                          reference=reference, heading=heading, distinct=distinct, flips=flips,
                          sigma_rate=sigma_rate)
    return g.basis(sigma=sigma, num_eigs=num_eigs, self_term=self_term, normalization=normalization,
                   chain_floor=chain_floor)


def greens_rows(basis: GreensBasis, frames) -> np.ndarray:
    """``basis.rows(frames)``: Green's rows ``(E, F)`` for edited frames ``(E,)``."""
    return basis.rows(frames)
