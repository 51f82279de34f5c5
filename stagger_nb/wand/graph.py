"""The sigma-independent head of the magic wand (Dean et al. 2018, §3, §3.1): :class:`PoseGraph`, built once
per clip by :func:`pose_graph` (pose vectors and all squared distances, or a kNN table of every frame, of
landmark frames, or of a clip's distinct poses), and its cheap tail ``graph.basis(sigma)``, the eigenpairs of
:mod:`.spectrum` as a :class:`~.basis.GreensBasis`."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..core.motion import Motion
from .basis import GreensBasis
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
    pairwise_sq_distances,
    quotient_pattern,
    sparse_kernel,
)
from .pose_space import pose_vectors
from .spectrum import _dense_eigs, _sparse_eigs

__all__ = ["PoseGraph", "pose_graph", "DENSE_MAX_FRAMES", "SPARSE_MAX_FRAMES", "MAX_LANDMARKS", "DEFAULT_NUM_EIGS",
           "DEFAULT_KNN"]

DENSE_MAX_FRAMES = 1200  # method="auto": dense eigendecomposition up to this many frames (~0.2 s), sparse above
DEFAULT_NUM_EIGS = 50    # N, the number of non-null eigenpairs kept in Eq. 3
SPARSE_MAX_FRAMES = 20000  # method="auto": the sparse graph of every frame up to this many, landmarks above
MAX_LANDMARKS = 8000       # frames of a landmark graph at most
DEFAULT_KNN = 64         # neighbours per frame of the sparse kernel (~0.25 s of motion either side at 120 Hz)


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



def pose_graph(motion: Motion, method: str = "auto", knn: int = DEFAULT_KNN, joint_weights=None,
               time_weight: float = 0.0, reference="mean", heading: str = "remove", distinct: bool = True,
               flips: str = "drop", sigma_rate: float | None = None, max_landmarks: int | None = None) -> PoseGraph:
    """Pose vectors + distances for ``motion`` (the expensive, sigma-independent head; cache it).

    Parameters
    ----------
    motion : Motion
    method : "auto" | "dense" | "sparse" | "landmarks"
        ``auto``: dense up to ``DENSE_MAX_FRAMES`` frames, sparse up to ``SPARSE_MAX_FRAMES``, landmarks above.
        Dense keeps ``F x F`` squared distances; sparse a kNN table of every frame; ``landmarks`` (long takes)
        builds the sparse graph on every ``ceil(F / max_landmarks)``-th frame (and the last) and interpolates
        its eigenvectors linearly in time, so the eigenproblem stays at most ``max_landmarks`` frames (a
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
    max_landmarks : int >= 2 or None
        Frames of a landmark graph at most (``method="landmarks"``, and a repeating clip's distinct poses on the
        sparse paths); None: :data:`MAX_LANDMARKS` (8,000).  Fewer landmarks: a faster, coarser graph.
    """
    landmarks_max = _check_max_landmarks(max_landmarks)
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
        return replace(_quotient_graph(X, method, k, first, inverse, counts, landmarks_max), sigma_knn=sigma_knn)
    if method == "sparse":
        table = knn_graph(X, min(k, F - 1))
        return PoseGraph(X, None, table, "sparse", pattern=kernel_pattern(table), sigma_knn=sigma_knn)
    stride = max(1, -(-F // landmarks_max))
    frames = np.unique(np.r_[np.arange(0, F, stride), F - 1])
    table = knn_graph(X[frames], min(k, frames.size - 1))
    return PoseGraph(X, None, table, "landmarks", frames, kernel_pattern(table), sigma_knn=sigma_knn)


def _check_max_landmarks(max_landmarks) -> int:
    """``max_landmarks`` as an int >= 2 (None: :data:`MAX_LANDMARKS`); ``ValueError`` naming it otherwise."""
    if max_landmarks is None:
        return MAX_LANDMARKS
    if isinstance(max_landmarks, bool) or not isinstance(max_landmarks, (int, np.integer)) or max_landmarks < 2:
        raise ValueError(f"max_landmarks must be an integer >= 2 or None, got {max_landmarks!r}")
    return int(max_landmarks)


def _sigma_table(X: np.ndarray, frame_time: float, rate: float) -> KnnGraph:
    """The 8-neighbour table of the distinct poses of every ``round(1 / (rate * frame_time))``-th frame."""
    step = max(1, int(round(1.0 / (rate * frame_time))))
    U = X[::step]
    first, _, _ = distinct_poses(U)
    if first.size > 1:
        U = U[first]
    return knn_graph(U, min(8, U.shape[0] - 1))


def _quotient_graph(X: np.ndarray, method: str, k: int, first, inverse, counts, max_landmarks: int) -> PoseGraph:
    """The sparse / landmark graph of a clip that repeats poses exactly: on its distinct poses (issue 25).

    The frames' kNN graph of a take repeated 60 times links each frame to its 59 equal poses and to few others
    (k = 64), and the landmark graph, which sees every third frame, to fewer of them: the two disagreed
    (falloffs mean 0.26-0.34 apart, max 1.0 on 20,000 frames of xia_neutral_walk repeated).  On the distinct
    poses with their multiplicities (:func:`.laplacian.quotient_pattern`) both are the same graph while the
    distinct poses fit ``max_landmarks``; beyond, landmarks every ``ceil(F / max_landmarks)``-th frame and
    the classes they fall in."""
    F = X.shape[0]
    if method == "sparse" or first.size <= max_landmarks:
        frames = np.arange(F)
        landmarks = None
    else:
        stride = max(1, -(-F // max_landmarks))
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

