"""The comparison curves of Dean et al. 2018, §4 and Figure 3: ISOMAP geodesic distance (Tenenbaum et al.
2000), diffusion-map distance (Coifman & Lafon 2006) and a generic spline (smoothstep) falloff.

All work on the same pose vectors as the Green's function (:mod:`.pose_space`) and return ``(F,)`` arrays
indexed by frame, so a notebook can overlay them with :func:`.falloff.greens_distance`.  Distances are in
pose-vector units and 0 at ``frame``; :func:`normalize_distance` scales one to [0, 1] over a range.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import dijkstra

from ..core.motion import Motion
from .falloff import check_frame_range, falloff_extent, greens_falloff
from .greens import GreensBasis, greens_basis
from .laplacian import (
    default_sigma,
    dense_kernel,
    knn_graph,
    normalized_adjacency,
    pairwise_sq_distances,
    symmetric_edges,
)
from .pose_space import pose_vectors

__all__ = ["isomap_distance", "isomap_graph", "diffusion_distance", "diffusion_coordinates", "spline_falloff",
           "smoothstep", "normalize_distance", "figure3_curves"]


def _frame(frame, F: int) -> int:
    f = int(frame)
    if f != frame or not 0 <= f < F:
        raise ValueError(f"frame must be an integer in [0, {F}), got {frame!r}")
    return f


def isomap_graph(m: Motion, k: int = 8, *, joint_weights=None, reference="mean") -> sp.csr_matrix:
    """The frame-independent part of :func:`isomap_distance`: the (F, F) sparse graph with an edge of
    Euclidean pose length between each frame and its ``k`` nearest neighbours (made symmetric) and between
    consecutive frames, so a viewer builds it once per clip and each frame's distances cost one Dijkstra."""
    X = pose_vectors(m, joint_weights=joint_weights, reference=reference)
    F = X.shape[0]
    k = int(k)
    if not 1 <= k <= F - 1:
        raise ValueError(f"k must be in [1, {F - 1}], got {k!r}")
    rows, cols, d2, _ = symmetric_edges(knn_graph(X, k))
    # tiny floor keeps zero-length edges (repeated poses) as edges: csgraph drops explicit zeros
    return sp.csr_matrix((np.maximum(np.sqrt(d2), 1e-300), (rows, cols)), shape=(F, F))


def isomap_distance(m: Motion, frame: int, k: int = 8, *, joint_weights=None, reference="mean",
                    graph: sp.csr_matrix | None = None) -> np.ndarray:
    """ISOMAP geodesic distance from ``frame`` to every frame, shape (F,).

    The graph has an edge of Euclidean pose length between each frame and its ``k`` nearest neighbours
    (made symmetric) and between consecutive frames (so it is connected); distances are shortest paths
    (Dijkstra) from ``frame``.  Memory ``O(F k)``.  ``graph``: :func:`isomap_graph` of ``m`` computed before
    (then ``k``, ``joint_weights`` and ``reference`` are the ones it was built with).
    """
    W = isomap_graph(m, k, joint_weights=joint_weights, reference=reference) if graph is None else graph
    f = _frame(frame, W.shape[0])
    return dijkstra(W, directed=True, indices=f)


def diffusion_coordinates(m: Motion, steps: int = 10, sigma: float | None = None, *, joint_weights=None,
                          reference="mean", tol: float = 0.0) -> np.ndarray:
    """Diffusion-map coordinates after ``steps`` random-walk steps, shape (F, N): the frame-independent part of
    :func:`diffusion_distance` (whose value at ``frame`` is ``norm(coords - coords[frame], axis=1)``), so a
    viewer computes the eigendecomposition once per (clip, sigma, steps) and each frame's curve in O(F N).

    ``tol = 0`` keeps every coordinate (N = F, ``numpy.linalg.eigh``: what :func:`diffusion_distance`
    computes). ``tol > 0`` keeps only the coordinates whose factor ``mu_k^steps`` exceeds ``tol`` (the top of
    the spectrum, ``scipy.linalg.eigh`` with ``subset_by_value``: about half the time on 2,751 frames, 373 of
    2,751 coordinates at ``tol = 1e-8`` on CMU 01_01): the distances change by at most ``tol`` times the
    coordinates' spread left out. ``A`` is positive semi-definite but for the consecutive-frame floor's small
    entries (eigenvalues >= -0.017 measured on CMU 01_01), so the negative end is never kept."""
    X = pose_vectors(m, joint_weights=joint_weights, reference=reference)
    t = int(steps)
    if t != steps or t < 1:
        raise ValueError(f"steps must be an integer >= 1, got {steps!r}")
    tol = float(tol)
    if not 0.0 <= tol < 1.0:
        raise ValueError(f"tol must be in [0, 1), got {tol!r}")
    s = default_sigma(X) if sigma is None else sigma
    K = dense_kernel(pairwise_sq_distances(X), s)
    A, r = normalized_adjacency(K)
    if tol > 0:
        import scipy.linalg as sl
        mu, phi = sl.eigh(A, subset_by_value=(tol ** (1.0 / t), np.inf), driver="evr")
    else:
        mu, phi = np.linalg.eigh(A)
    psi = phi / np.sqrt(r)[:, None] * np.sqrt(r.sum())
    return psi * mu ** t  # diffusion-map coordinates; the top one (mu = 1, psi = 1) cancels in differences


def diffusion_distance(m: Motion, frame: int, steps: int = 10, sigma: float | None = None, *,
                       joint_weights=None, reference="mean") -> np.ndarray:
    """Diffusion-map distance after ``steps`` random-walk steps from ``frame`` to every frame, shape (F,).

    With the Gaussian kernel of Eq. 1 (same ``sigma`` default and the same consecutive-frame floor,
    :data:`.laplacian.CHAIN_FLOOR`, as the Green's function), ``P = D^-1 K`` and
    stationary distribution ``pi = r / sum(r)``, ``D_t(i, j)^2 = sum_l (P^t_il - P^t_jl)^2 / pi_l``
    = ``sum_{k>0} mu_k^(2t) (psi_k(i) - psi_k(j))^2`` with ``mu_k`` the eigenvalues of
    ``A = D^-1/2 K D^-1/2`` and ``psi_k = D^-1/2 phi_k sqrt(sum r)`` (Coifman & Lafon 2006).
    Dense: ``O(F^2)`` memory, for clips of up to a few thousand frames. :func:`diffusion_coordinates` is the
    frame-independent part.
    """
    f = _frame(frame, m.num_frames)
    coords = diffusion_coordinates(m, steps, sigma, joint_weights=joint_weights, reference=reference)
    return np.linalg.norm(coords - coords[f], axis=1)


def smoothstep(x: np.ndarray) -> np.ndarray:
    """``3 x^2 - 2 x^3`` on [0, 1] (clipped outside): C1, 0 -> 0, 1 -> 1, flat at both ends."""
    x = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def spline_falloff(F: int, frame: int, extent) -> np.ndarray:
    """A generic spline falloff (the artist's usual tool, §1 and §4.3), shape (F,).

    ``w_j = smoothstep(1 - |j - frame| / extent)``: 1 at ``frame``, 0 from ``extent`` frames away on.
    ``extent`` is a number of frames > 0, or a ``(before, after)`` pair for an asymmetric falloff.
    """
    F = int(F)
    if F < 1:
        raise ValueError(f"F must be >= 1, got {F!r}")
    f = _frame(frame, F)
    before, after = (extent, extent) if np.ndim(extent) == 0 else tuple(extent)
    before, after = float(before), float(after)
    if not (before > 0 and after > 0 and np.isfinite(before) and np.isfinite(after)):
        raise ValueError(f"extent must be > 0 frames (or a pair of them), got {extent!r}")
    j = np.arange(F) - f
    x = np.where(j < 0, 1.0 + j / before, 1.0 - j / after)
    return smoothstep(x)


def normalize_distance(d: np.ndarray, frame_range=None) -> np.ndarray:
    """Scale a distance curve ``d (F,)`` to [0, 1] by its maximum over the half-open ``frame_range``
    (whole clip by default); frames outside the range and unreachable frames (inf) become 1."""
    d = np.asarray(d, dtype=float)
    start, stop = check_frame_range(frame_range, d.shape[0])
    seg = d[start:stop]
    finite = seg[np.isfinite(seg)]
    top = finite.max() if finite.size else 0.0
    out = np.ones_like(d)
    if top > 0:
        out[start:stop] = np.clip(np.where(np.isfinite(seg), seg / top, 1.0), 0.0, 1.0)
    else:
        out[start:stop] = np.where(np.isfinite(seg), 0.0, 1.0)
    return out


def figure3_curves(m: Motion, frame: int, sigma: float | None = None, *, k: int = 8, steps: int = 10,
                   extent=None, basis: GreensBasis | None = None) -> dict:
    """The four normalised distance curves of Figure 3, each ``(F,)`` in [0, 1] and 0 at ``frame``:
    ``"green"`` (1 - the §3.3 falloff), ``"isomap"`` (k neighbours), ``"diffusion"`` (``steps`` steps, the same
    sigma) and ``"spline"`` (1 - smoothstep falloff; ``extent`` defaults to the Green's valley on each side,
    :func:`.falloff.falloff_extent`).  Pass ``basis`` to reuse a precomputed Green's basis of ``m``."""
    if basis is None:
        basis = greens_basis(m, sigma=sigma)
    w = greens_falloff(basis, frame)
    ext = falloff_extent(w, frame) if extent is None else extent
    return {"green": 1.0 - w,
            "isomap": normalize_distance(isomap_distance(m, frame, k=k)),
            "diffusion": normalize_distance(diffusion_distance(m, frame, steps=steps, sigma=basis.sigma)),
            "spline": 1.0 - spline_falloff(m.num_frames, frame, ext)}
