"""The magic wand (Dean, Lewis & Chalmers, SIGGRAPH Asia 2018 Technical Briefs): a data-driven falloff from
the Green's function of the pose-space Laplacian, and edit propagation to similar poses.

Pipeline (each step a pure function; cache the head for sliders)::

    graph = wand.pose_graph(m)            # pose vectors + distances (sigma-independent), §3, §3.1
    basis = graph.basis(sigma)            # eigenpairs of L = I - D^-1/2 K D^-1/2, §3.1-3.2 (Eq. 1-3)
    w = wand.greens_falloff(basis, frame, frame_range)     # (F,) in [0, 1], §3.3
    m2 = wand.propagate(m, frame, edited_pose, basis=basis) # Eqs. 4-5

One-call forms: ``wand.falloff(m, frame, sigma=None, frame_range=None)`` and
``wand.propagate(m, frame, edited_local_quats, sigma=None, frame_range=None)``; they reuse the pose graph of
the same motion through a small, explicit content-keyed module cache (``cached_pose_graph``,
``clear_graph_cache``), so a new sigma costs only the eigenpairs.  ``PoseGraph`` itself holds no cache.
Comparisons of §4 / Figure 3: ``isomap_distance``, ``diffusion_distance``, ``spline_falloff``, or all four
normalised curves at once with ``figure3_curves(m, frame)``.
Frames are 0-based indices; ranges half-open; quaternions (x, y, z, w).
"""
from .compare import (
                      diffusion_coordinates,
                      diffusion_distance,
                      figure3_curves,
                      isomap_distance,
                      isomap_graph,
                      normalize_distance,
                      smoothstep,
                      spline_falloff,
)
from .falloff import falloff, falloff_extent, greens_distance, greens_falloff, normalize_row
from .greens import GreensBasis, PoseGraph, cached_pose_graph, clear_graph_cache, greens_basis, greens_rows, pose_graph
from .laplacian import default_sigma, dense_kernel, knn_graph, normalized_laplacian, sparse_kernel
from .pose_space import mean_rotations, pose_exps, pose_logs, pose_vectors
from .propagate import propagate, propagate_logs

__all__ = ["falloff", "propagate", "greens_falloff", "greens_distance", "falloff_extent", "figure3_curves",
           "normalize_row", "GreensBasis",
           "PoseGraph", "cached_pose_graph", "clear_graph_cache", "greens_basis", "greens_rows", "pose_graph",
           "default_sigma", "dense_kernel",
           "knn_graph", "normalized_laplacian", "sparse_kernel", "mean_rotations", "pose_exps", "pose_logs",
           "pose_vectors", "propagate_logs", "isomap_distance", "diffusion_distance", "spline_falloff",
           "smoothstep", "normalize_distance", "diffusion_coordinates", "isomap_graph"]
