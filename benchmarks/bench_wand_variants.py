"""Issue 25's Dean hop row against the walk rows and issue 13's opposite-phase bound: method variants of the pose
graph (Dean et al. 2018, §3.1: the distance d, the kernel width sigma, Eq. 1's kernel; §3.2: N) measured side by
side on the same clips, none of them a default (``benchmarks/bench_claims.py``'s docstring holds the verdict).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_wand_variants.py      # every row, ~15-25 min
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_wand_variants.py default cosine   # rows naming these
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_wand_variants.py =cosine          # that row only

Every variant is built here on the *dense* kernel (all F x F pairs, the library's random-walk spectrum without the
self term, chain floor, N = 50 unless stated), so the 120 Hz figures differ from the library's sparse path on
CMU 01_01 (2,751 frames): the default here gives 0.45/0.21 there, the sparse kNN graph 0.55/0.31.  Columns:

* ``hop30`` / ``hopF``: ``wand.measures.hop_falloffs`` on CMU 01_01 resampled to 30 Hz / at 120 Hz: the worst
  apex's median falloff at the other apexes / the highest median at the crouches (goal >= 0.7 / <= 0.3);
* ``hopseg30``: the same, worst over three stretches of the 30 Hz clip (frames 255-688, 0-450, 300-688: 6, 7
  and 6 hops), stand-ins for hop clips not seen (a fix tuned to the whole clip should hold on its parts);
* ``walk30`` / ``walkF``: over the five straight walks (procedural, xia neutral / sexy, bandai, iclone 07_01) at
  30 Hz / their file rate, the lowest falloff one or two strides away / the highest half a stride away
  (``walk_falloffs``; goal >= 0.7 / <= 0.3);
* ``pymo``, ``angry``, ``neutral``: the same-phase / opposite-phase falloff of ``tests/test_wand_heading.py``'s
  real turning walk (frames 200, 450, 500, 600), and ``tests/test_wand_cyclic.py``'s xia_angry_run (10, 20) and
  xia_neutral_walk (50, 100, 150), worst frame (goal >= 0.8 / <= 0.1);
* ``proc``: the procedural walk turning 90 deg/s at 60 Hz (``test_turning_walks_of_other_strides_and_rates``),
  every fifth of a cycle (goal >= 0.8 / <= 0.1);
* ``p0101``, ``p131``: issue 24's held-out propagation (``tests/test_compose_heldout.py``) on CMU 01_01 and CMU
  131_01 at 120 Hz: the falloff from the staggered pose nearest the middle step's mark (``tests/gait_marks.py``),
  lowest at the other steps' same-phase marks / highest at the opposite-phase marks (goal >= 0.8 / <= 0.2; the
  propagated edit follows the falloff to 0.2 there, tested).  Measured on this dense kernel: the library's sparse
  path gives CMU 01_01 0.51-0.55 at the opposite phase where the default row here says 0.39.

Variants: ``sigma_rate30`` (the library's opt-in: sigma from the 8 nearest of frames 1/30 s apart); ``N15`` /
``N20`` / ``N25`` (fewer eigenpairs in Eq. 3);
``alpha1`` (Coifman-Lafon's density normalisation K / (q_i q_j), q = K 1: the diffusion maps the paper compares
with, §4); ``sigma_outside0.1`` (sigma = the median distance to the 8th nearest frame more than 0.1 s away);
``no_local_edges0.1`` (also Eq. 1's kernel without the pairs less than 0.1 s apart, the chain kept: a graph of
similar poses, not of neighbouring frames); ``self_tuning`` (exp(-d^2 / 2 s_i s_j), s_i a frame's 8th-neighbour
distance; ``k16, mix 0.5``: s_i = sigma^0.5 d_16(i)^0.5; ``widening only``: s_i = max(sigma, d_8(i));
``widening on 30 Hz frames``: s_i = sigma min(cap, max(1, r_i)), r_i a frame's distance to its 8th nearest frame
of the clip sampled at 30 Hz over the median of those);
``subtree_weights`` (each joint's log coordinates weighted by the rest-pose RMS distance of the points
it moves: the dof weighting of the paper's introduction); ``positions`` (heading-free joint positions, root at
the origin); ``delay`` (a motion-segment distance: the pose vector with ``c`` times the poses ``delta`` s before
and after, the offsets held at their nearest inner frame at the clip's ends), with and without sigma_rate 30.

Session 11 (issue 25 / 24: a frame-rate-free falloff):
``graph at R Hz`` (``rate=R``): the graph built on the pose vectors sampled at R Hz (linear in time, onto
``round(duration R) + 1`` equal steps; R below the file rate: decimation, above: upsampling), its eigenvectors and
degrees interpolated linearly back to the clip's frames, so the falloff no longer depends on the capture rate (at
the file rate it is the plain graph); ``sigma xc``: c times that graph's default sigma;
``rho_i`` (a time-exclusion window, as recurrence plots' Theiler window): a frame's distance to its nearest frame
more than W s away, i.e. to its nearest repetition; ``s_i = rho_i``: exp(-d^2 / 2 s_i s_j); ``widen by rho, cap
c``: s_i = sigma min(c, max(1, rho_i / median rho)), sigma widened only at poses whose nearest repetition is
farther than typical; ``no pairs < W s``: Eq. 1 without the pairs less than W s apart (the chain kept), sigma from
the 8th nearest frame outside W (``sigma all``: from all frames);
``cosine``: the falloff from the Green's rows normalised by their diagonal, G_ij / sqrt(G_ii G_jj) (the cosine of
two frames' points in the Green's embedding; <= 1 where G is positive semi-definite, and the same from either
frame: an isolated frame's high G_ii no longer lowers every other frame's share); ``cw``: cosine, graph at 120 Hz,
widen by rho (W 0.25 s) cap 1.25, with the change named; ``commute``: the falloff 1 - R_ij / max R from the
truncated Green's function's commute-time (resistance) distance R_ij = G_ii + G_jj - 2 G_ij.
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from scipy.spatial import cKDTree

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))
SHARED = Path(os.environ.get("STAGGER_NB_SHARED_MOCAP") or REPO.parent / "shared" / "mocap")

import stagger_nb as sn
from stagger_nb import wand
from stagger_nb.core.kinematics import forward_kinematics
from stagger_nb.core.rotations import quat_mul, quat_rotate, rotvec_to_quat
from stagger_nb.data.procedural import walk as make_walk
from stagger_nb.wand.basis import GreensBasis
from stagger_nb.wand.laplacian import CHAIN_FLOOR, default_sigma, knn_graph, pairwise_sq_distances
from stagger_nb.wand.measures import hop_falloffs, stride_frames, walk_falloffs
from stagger_nb.wand.pose_space import heading_free_quats, pose_vectors
from stagger_nb.wand.spectrum import _dense_eigs

SEGMENTS = [(255, 688), (0, 450), (300, 688)]   # CMU 01_01 at 30 Hz: 6, 7 and 6 hops (stand-ins for unseen hop clips)
WALKS = ["walk", "xia_neutral_walk", "xia_sexy_walk", "bandai_walk", "iclone_cmu_07_01_walk"]


def load(name: str):
    p = SHARED / f"{name}.bvh"
    return sn.read_bvh(p) if p.is_file() else sn.data.load(name)


# ------------------------------------------------------------------------------------------------ features
def subtree_weights(sk) -> np.ndarray:
    """Per joint: the RMS rest-pose distance of the joints and end sites below it (the joint's positional lever)."""
    J = sk.num_joints
    P = np.zeros((J, 3))
    for j in range(J):
        P[j] = sk.offsets[j] + (P[sk.parents[j]] if sk.parents[j] >= 0 else 0.0)
    pts = [[P[j]] for j in range(J)] + [[P[j] + np.asarray(v)] for j, v in sk.end_sites.items()]
    owner = list(range(J)) + list(sk.end_sites)
    sums = np.zeros(J)
    for o, (p,) in zip(owner, pts):
        a = o
        while a >= 0:
            sums[a] += np.sum((p - P[a]) ** 2)
            a = sk.parents[a]
    w = np.sqrt(sums)
    return w / np.sqrt(np.mean(w[w > 0] ** 2))


def positions(m) -> np.ndarray:
    mm = m.replace(local_quats=heading_free_quats(m), root_positions=np.zeros_like(m.root_positions))
    X = forward_kinematics(mm)[0].reshape(m.num_frames, -1)
    return X - X.mean(0)


def delay(m, delta: float = 0.1, c: float = 0.7) -> np.ndarray:
    X = pose_vectors(m)
    F = X.shape[0]
    k = max(1, int(round(delta / m.frame_time)))
    if F <= 2 * k:
        return X
    i = np.clip(np.arange(F), k, F - 1 - k)
    return np.concatenate([X, c * (X + X[i - k] - X[i]), c * (X + X[i + k] - X[i])], axis=1)


# ------------------------------------------------------------------------------------------------ the graph
def basis(m, X=None, rate=None, **kw):
    """The variant's Green's basis of ``m``; ``rate``: the graph on the poses sampled at ``rate`` Hz (the pose
    vectors interpolated linearly in time onto ``round(duration * rate) + 1`` equally spaced times), its
    eigenvectors and degrees interpolated linearly back to the clip's frames (at the clip's own rate: the plain
    graph)."""
    X = pose_vectors(m) if X is None else X
    F = X.shape[0]
    n = int(round((F - 1) * m.frame_time * rate)) + 1 if rate else F
    if n == F:
        return _basis(X, m.frame_time, **kw)
    t = np.arange(F) * m.frame_time
    tl = np.linspace(0.0, t[-1], n)
    Xl = np.stack([np.interp(tl, t, X[:, d]) for d in range(X.shape[1])], axis=1)
    b = _basis(Xl, tl[1], **kw)
    back = lambda v: np.stack([np.interp(t, tl, v[:, k]) for k in range(v.shape[1])], axis=1)  # noqa: E731
    return GreensBasis(b.eigenvalues, np.ascontiguousarray(back(b.eigenvectors)),
                       np.interp(t, tl, b.degrees), b.sigma, False, "random_walk", "dense", b.null_dim)


class CosineBasis:
    """Green's rows normalised by the diagonal, ``G_ij / sqrt(G_ii G_jj)`` (the cosine of the angle between two
    frames' points of the Green's embedding ``Psi_i = (psi_k(i) sqrt(1 / lambda_k - 1))_k``; <= 1 where G is
    positive semi-definite, so no row peaks away from its frame)."""

    def __init__(self, b):
        self.b = b
        coef = 1.0 / b.eigenvalues - 1.0
        self.scale = 1.0 / np.sqrt(np.maximum(np.einsum("fk,fk,k->f", b.eigenvectors, b.eigenvectors, coef), 1e-300))
        self.num_frames = b.num_frames

    def row(self, i):
        return self.b.row(i) * self.scale * self.scale[i]


class CommuteBasis(CosineBasis):
    """Rows ``-(G_ii + G_jj - 2 G_ij)``: minus the commute-time (resistance) distance of the truncated Green's
    function, so the falloff of section 3.3 is ``1 - R_ij / max_j R_ij``."""

    def row(self, i):
        g = 1.0 / self.scale ** 2
        return 2.0 * self.b.row(i) - g - g[i]


def commute_basis(m, X=None, **kw):
    return CommuteBasis(basis(m, X, **kw))


def cosine_basis(m, X=None, **kw):
    return CosineBasis(basis(m, X, **kw))


def _basis(X, frame_time, N=50, sigma_rate=None, outside=0.0, drop_local=False, alpha=0.0, self_tuning=False,
           tuning_k=8, tuning_mix=1.0, tuning_floor=False, widen_cap=None, sigma_scale=1.0, rep_window=0.0,
           rep_cap=None, sigma_all=False):
    F = X.shape[0]
    D2 = pairwise_sq_distances(X)
    lag = np.abs(np.arange(F)[:, None] - np.arange(F)[None, :]) * frame_time
    D2s = np.where(lag < (1e-12 if sigma_all else max(outside, 1e-12)), np.inf, D2)
    d8 = np.sqrt(np.sort(D2s, axis=1)[:, 7])
    s = float(np.median(d8))
    if self_tuning:   # s_i = s^(1 - mix) d_k(i)^mix, d_k the distance to the k-th nearest frame
        dk = np.sqrt(np.sort(np.where(lag < 1e-12, np.inf, D2), axis=1)[:, tuning_k - 1])
        d8 = s ** (1.0 - tuning_mix) * dk ** tuning_mix
        if tuning_floor:  # local scales only widen the global one
            d8 = np.maximum(d8, s)
    if sigma_rate:
        step = max(1, int(round(1.0 / (sigma_rate * frame_time))))
        s = default_sigma(knn=knn_graph(X[::step], 8))
    if widen_cap:   # s_i = s min(cap, max(1, d_8,30Hz(i) / its median)): sparse poses widen, measured on 30 Hz frames
        step = max(1, int(round(1.0 / (30.0 * frame_time))))
        dk = cKDTree(X[::step]).query(X, 9)[0][:, 8]
        d8 = s * np.minimum(widen_cap, np.maximum(1.0, dk / np.median(dk)))
        self_tuning = True
    if rep_window:  # rho_i = the distance to the nearest frame more than rep_window s away (its nearest repetition)
        rho = np.sqrt(np.min(np.where(lag <= rep_window, np.inf, D2), axis=1))
        d8 = rho if rep_cap is None else s * sigma_scale * np.minimum(rep_cap, np.maximum(1.0, rho / np.median(rho)))
        self_tuning = True
    s *= sigma_scale
    K = np.exp(-D2 / (2 * np.outer(d8, d8))) if self_tuning else np.exp(-D2 / (2 * s * s))
    if drop_local:
        K[(lag > 0) & (lag < outside)] = 0.0
    i = np.arange(F - 1)
    K[i, i + 1] = np.maximum(K[i, i + 1], CHAIN_FLOOR)
    K[i + 1, i] = K[i, i + 1]
    if alpha:
        q = K.sum(1)
        K = K / np.outer(q ** alpha, q ** alpha)
    lam, phi, null_dim, r = _dense_eigs(K, N)
    return GreensBasis(lam, np.ascontiguousarray(phi / np.sqrt(r)[:, None]), r, s, False, "random_walk", "dense",
                       null_dim)


# ------------------------------------------------------------------------------------------------ measures
def closest_phases(m, i):
    """Same phase = the frame >= 0.4 s away whose pose is closest to frame i; opposite = halfway (the tests')."""
    d = np.sqrt(pairwise_sq_distances(pose_vectors(m)[[i]], pose_vectors(m)))[0]
    far = np.flatnonzero(np.abs(np.arange(m.num_frames) - i) >= round(0.4 / m.frame_time))
    j = int(far[np.argmin(d[far])])
    return j, (i + j) // 2


def turning(m, deg_per_s):
    yaw = rotvec_to_quat(np.outer(np.radians(deg_per_s) * m.times, [0.0, 1.0, 0.0]))
    q = np.array(m.local_quats)
    q[:, 0] = quat_mul(yaw, q[:, 0])
    step = np.diff(m.root_positions, axis=0, prepend=m.root_positions[:1])
    return m.replace(local_quats=q, root_positions=m.root_positions[0] + np.cumsum(quat_rotate(yaw, step), axis=0))


def row(clips, feature, kw) -> list[str]:
    X = (lambda m: None) if feature is None else feature
    kw = dict(kw)
    basis = cosine_basis if kw.pop("cosine", False) else globals()["basis"]
    basis = commute_basis if kw.pop("commute", False) else basis
    cells = []
    for m in (clips["hop30"], clips["hopF"]):
        rows = hop_falloffs(m, basis=basis(m, X(m), **kw))
        cells.append(f"{min(r[1] for r in rows):.2f}/{max(r[2] for r in rows):.2f}")
    seg = [hop_falloffs(m, basis=basis(m, X(m), **kw)) for m in clips["segments"]]
    cells.append(f"{min(r[1] for rows in seg for r in rows):.2f}/{max(r[2] for rows in seg for r in rows):.2f}")
    for key in ("walks30", "walksF"):
        hi, lo = 1.0, 0.0
        for m in clips[key]:
            rows, _ = walk_falloffs(m, basis=basis(m, X(m), **kw), stride=stride_frames(m))
            hi, lo = min(hi, np.nanmin([r[1] for r in rows])), max(lo, max(r[2] for r in rows))
        cells.append(f"{hi:.2f}/{lo:.2f}")
    for key, frames in (("pymo", (200, 450, 500, 600)), ("angry", (10, 20)), ("neutral", (50, 100, 150))):
        m = clips[key]
        b = basis(m, X(m), **kw)
        ph = [(closest_phases(m, i), wand.greens_falloff(b, i)) for i in frames]
        cells.append(f"{min(w[j] for (j, _), w in ph):.2f}/{max(w[o] for (_, o), w in ph):.2f}")
    m, P = clips["proc"], int(round(1.0 / clips["proc"].frame_time))
    b = basis(m, X(m), **kw)
    ws = {i: wand.greens_falloff(b, i) for i in range(P, m.num_frames - P, max(1, P // 5))}
    cells.append(f"{min(w[i + P] for i, w in ws.items()):.2f}/{max(w[i + P // 2] for i, w in ws.items()):.2f}")
    for key in ("p0101", "p131"):
        m, frame, others, opposite = clips[key]
        w = wand.greens_falloff(basis(m, X(m), **kw), frame)
        cells.append(f"{w[others].min():.2f}/{w[opposite].max():.2f}")
    return cells


def propagation_marks(m, hops: bool):
    """Issue 24's held-out check (``tests/test_compose_heldout.py``): ``(m, frame, others, opposite)``, the frame of
    the staggered pose nearest the middle step's mark, the same-phase marks of the other steps and the opposite
    phase marks; a propagated edit moves each frame by the falloff from ``frame`` (to 0.2, tested there)."""
    from gait_marks import hop_marks, rig_of, walk_marks

    from stagger_nb import staggered
    left, right, _ = rig_of(m)
    same, opposite = hop_marks(m) if hops else walk_marks(m, left, right)
    frames = staggered.extract(m).pose_times / m.frame_time
    at = same[len(same) // 2]
    frame = int(round(frames[int(np.argmin(np.abs(frames - at)))]))
    others = [f for f in same if abs(f - at) > 0.25 * np.median(np.diff(same))]
    return m, frame, np.asarray(others), np.asarray(opposite)


VARIANTS = [
    ("default", None, {}),
    ("sigma_rate30", None, dict(sigma_rate=30)),
    ("N15", None, dict(N=15)),
    ("N20", None, dict(N=20)),
    ("N25", None, dict(N=25)),
    ("alpha1", None, dict(alpha=1.0)),
    ("sigma_outside0.1", None, dict(outside=0.1)),
    ("no_local_edges0.1", None, dict(outside=0.1, drop_local=True)),
    ("self_tuning", None, dict(self_tuning=True)),
    ("self_tuning k16, mix 0.5", None, dict(self_tuning=True, tuning_k=16, tuning_mix=0.5)),
    ("self_tuning, widening only", None, dict(self_tuning=True, tuning_floor=True)),
    ("widening on 30 Hz frames, cap 1.25", None, dict(widen_cap=1.25)),
    ("subtree_weights", lambda m: pose_vectors(m, joint_weights=subtree_weights(m.skeleton)), {}),
    ("positions", positions, {}),
    ("delay 0.1 s, c 0.7", delay, {}),
    ("delay 0.1 s, c 0.7, sigma_rate30", delay, dict(sigma_rate=30)),
    ("delay 0.1 s, c 1.0, sigma_rate30", lambda m: delay(m, 0.1, 1.0), dict(sigma_rate=30)),
    *[(f"graph at {rate} Hz, sigma x{k:.1f}", None, dict(rate=rate, sigma_scale=k))
      for rate in (30, 60, 120) for k in (0.7, 1.0, 1.4, 2.0)],
    ("graph at 30 Hz, s_i = rho_i (W 0.25)", None, dict(rate=30, rep_window=0.25)),
    ("graph at 30 Hz, widen by rho, cap 1.25", None, dict(rate=30, rep_window=0.25, rep_cap=1.25)),
    ("graph at 30 Hz, widen by rho, cap 1.5", None, dict(rate=30, rep_window=0.25, rep_cap=1.5)),
    ("graph at 30 Hz, widen by rho, cap 2.0", None, dict(rate=30, rep_window=0.25, rep_cap=2.0)),
    ("graph at 120 Hz, s_i = rho_i (W 0.25)", None, dict(rate=120, rep_window=0.25)),
    ("graph at 120 Hz, widen by rho, cap 1.25", None, dict(rate=120, rep_window=0.25, rep_cap=1.25)),
    ("graph at 120 Hz, widen by rho, cap 1.5", None, dict(rate=120, rep_window=0.25, rep_cap=1.5)),
    ("graph at 120 Hz, widen by rho, cap 2.0", None, dict(rate=120, rep_window=0.25, rep_cap=2.0)),
    ("graph at 30 Hz, no pairs < 0.1 s, x1.0", None, dict(rate=30, outside=0.1, drop_local=True, sigma_scale=1.0)),
    ("graph at 30 Hz, no pairs < 0.1 s, x1.4", None, dict(rate=30, outside=0.1, drop_local=True, sigma_scale=1.4)),
    ("graph at 30 Hz, no pairs < 0.25 s, x1.0", None, dict(rate=30, outside=0.25, drop_local=True, sigma_scale=1.0)),
    ("graph at 30 Hz, no pairs < 0.25 s, x1.4", None, dict(rate=30, outside=0.25, drop_local=True, sigma_scale=1.4)),
    ("graph at 120 Hz, no pairs < 0.1 s, x1.0", None, dict(rate=120, outside=0.1, drop_local=True, sigma_scale=1.0)),
    ("graph at 120 Hz, no pairs < 0.1 s, x1.4", None, dict(rate=120, outside=0.1, drop_local=True, sigma_scale=1.4)),
    ("graph at 120 Hz, no pairs < 0.25 s, x1.0", None, dict(rate=120, outside=0.25, drop_local=True, sigma_scale=1.0)),
    ("graph at 120 Hz, no pairs < 0.25 s, x1.4", None, dict(rate=120, outside=0.25, drop_local=True, sigma_scale=1.4)),
    ("cosine", None, dict(cosine=True)),
    ("cosine, graph at 30 Hz, x0.7", None, dict(cosine=True, rate=30, sigma_scale=0.7)),
    ("cosine, graph at 30 Hz, x1.0", None, dict(cosine=True, rate=30, sigma_scale=1.0)),
    ("cosine, graph at 30 Hz, x1.4", None, dict(cosine=True, rate=30, sigma_scale=1.4)),
    ("cosine, graph at 30 Hz, x2.0", None, dict(cosine=True, rate=30, sigma_scale=2.0)),
    ("cosine, graph at 120 Hz, x0.7", None, dict(cosine=True, rate=120, sigma_scale=0.7)),
    ("cosine, graph at 120 Hz, x1.0", None, dict(cosine=True, rate=120, sigma_scale=1.0)),
    ("cosine, graph at 120 Hz, x1.4", None, dict(cosine=True, rate=120, sigma_scale=1.4)),
    ("cosine, graph at 120 Hz, x2.0", None, dict(cosine=True, rate=120, sigma_scale=2.0)),
    ("graph at 120 Hz, no pairs < 0.05 s, x1.0", None, dict(rate=120, outside=0.05, drop_local=True, sigma_scale=1.0)),
    ("graph at 120 Hz, no pairs < 0.05 s, x1.4", None, dict(rate=120, outside=0.05, drop_local=True, sigma_scale=1.4)),
    ("graph at 120 Hz, no pairs < 0.1 s, sigma all", None,
     dict(rate=120, outside=0.1, drop_local=True, sigma_all=True)),
    ("cosine, graph at 120 Hz, no pairs < 0.1 s", None, dict(cosine=True, rate=120, outside=0.1, drop_local=True)),
    ("cosine, graph at 120 Hz, widen by rho, cap 1.25", None,
     dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.25)),
    ("cosine, graph at 120 Hz, widen by rho, cap 1.5", None, dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.5)),
    ("cosine, graph at 120 Hz, x1.2", None, dict(cosine=True, rate=120, sigma_scale=1.2)),
    ("cosine, graph at 120 Hz, x1.7", None, dict(cosine=True, rate=120, sigma_scale=1.7)),
    ("cosine, graph at 120 Hz, x2.0", None, dict(cosine=True, rate=120, sigma_scale=2.0)),
    ("cosine, x1.4", None, dict(cosine=True, sigma_scale=1.4)),
    ("cw N30", None, dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.25, N=30)),
    ("cw N100", None, dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.25, N=100)),
    ("cw W0.5", None, dict(cosine=True, rate=120, rep_window=0.5, rep_cap=1.25)),
    ("cw cap1.25 x1.2", None, dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.25, sigma_scale=1.2)),
    ("cw x1.2 alpha0.5", None, dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.25, sigma_scale=1.2, alpha=0.5)),
    ("cw x1.2 alpha1", None, dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.25, sigma_scale=1.2, alpha=1.0)),
    ("cw x1.2 N30", None, dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.25, sigma_scale=1.2, N=30)),
    ("cw x1.4", None, dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.25, sigma_scale=1.4)),
    ("ca x1.5 alpha0.5", None, dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.25, sigma_scale=1.5, alpha=0.5)),
    ("ca x1.8 alpha0.5", None, dict(cosine=True, rate=120, rep_window=0.25, rep_cap=1.25, sigma_scale=1.8, alpha=0.5)),
    ("ca x1.5 alpha0.5 no widening", None, dict(cosine=True, rate=120, sigma_scale=1.5, alpha=0.5)),
    ("commute", None, dict(commute=True)),
    ("commute, graph at 120 Hz", None, dict(commute=True, rate=120)),
    ("commute, graph at 120 Hz, widen by rho 1.25", None, dict(commute=True, rate=120, rep_window=0.25, rep_cap=1.25)),
    ("graph at 30 Hz, alpha1", None, dict(rate=30, alpha=1.0)),
    ("graph at 30 Hz, self_tuning", None, dict(rate=30, self_tuning=True)),
    ("graph at 30 Hz, widening cap 1.25", None, dict(rate=30, widen_cap=1.25)),
    ("graph at 30 Hz, N20", None, dict(rate=30, N=20)),
    ("graph at 30 Hz, sigma_outside0.25", None, dict(rate=30, outside=0.25)),
    ("sigma_outside0.25", None, dict(outside=0.25)),
]


def main() -> int:
    t0 = time.perf_counter()
    cmu = load("cmu_01_01")
    walks = [load(n) for n in WALKS]
    clips = dict(hop30=cmu.resample(1 / 30), hopF=cmu, walks30=[w.resample(1 / 30) for w in walks], walksF=walks,
                 pymo=load("pymo_walk_turnaround"), angry=load("xia_angry_run"), neutral=load("xia_neutral_walk"),
                 proc=turning(make_walk(duration=6.0, speed=140.0, period=1.0, seed=5), 90.0))
    clips["segments"] = [clips["hop30"].slice(a, b) for a, b in SEGMENTS]
    clips["p0101"] = propagation_marks(cmu, True)
    clips["p131"] = propagation_marks(load("cmu_131_01_walk_startstop"), False)
    heads = ["hop30", "hopF", "hopseg30", "walk30", "walkF", "pymo", "angry", "neutral", "proc", "p0101", "p131"]
    print("goals: hops >= 0.7 / <= 0.3, walks >= 0.7 / <= 0.3, same / opposite phase >= 0.8 / <= 0.1 "
          "(p0101, p131: >= 0.8 / <= 0.2)")
    print(f"{'variant':34s} " + " ".join(f"{h:>9s}" for h in heads))
    only = sys.argv[1:]
    for name, feature, kw in VARIANTS:
        if only and not any(name == o[1:] if o.startswith("=") else o in name for o in only):
            continue
        print(f"{name:34s} " + " ".join(f"{c:>9s}" for c in row(clips, feature, kw)), flush=True)
    print(f"\n({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
