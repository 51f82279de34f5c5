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

Where each part lives: :mod:`.graph` (:class:`PoseGraph`, :func:`pose_graph`: the sigma-independent head),
:mod:`.spectrum` (the dense and sparse eigensolvers), :mod:`.basis` (:class:`GreensBasis`: Green's rows),
:mod:`.graph_cache` (the one-call functions' graph cache); this module holds the one-call
:func:`greens_basis` and re-exports the others' names.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from .basis import GreensBasis
from .graph import (
    DEFAULT_KNN,
    DEFAULT_NUM_EIGS,
    DENSE_MAX_FRAMES,
    MAX_LANDMARKS,
    SPARSE_MAX_FRAMES,
    PoseGraph,
    pose_graph,
)
from .graph_cache import GRAPH_CACHE, cached_pose_graph, clear_graph_cache
from .laplacian import CHAIN_FLOOR, _check_sigma
from .spectrum import LA_MAX_FRAMES, NULL_TOL  # noqa: F401

__all__ = ["GreensBasis", "PoseGraph", "pose_graph", "greens_basis", "greens_rows", "NULL_TOL", "GRAPH_CACHE",
           "DENSE_MAX_FRAMES", "SPARSE_MAX_FRAMES", "MAX_LANDMARKS", "DEFAULT_NUM_EIGS", "DEFAULT_KNN",
           "cached_pose_graph", "clear_graph_cache"]


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
