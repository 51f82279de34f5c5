"""Pose vectors for the magic wand (Dean et al. 2018, §3 and §3.1).

A pose is "a vector containing the concatenated rotational degrees of freedom of the skeleton",
represented in the log map: for every joint the quaternion logarithm ``log q = axis * angle / 2`` of
its local rotation, hemisphere-canonicalised first so ``q`` and ``-q`` give the same vector.

The log map is taken **relative to a per-joint reference rotation** ``r_j`` (default: the chordal mean of
the joint's rotations over the clip, the tangent space at the mean as in Tournier et al. 2009, which the
paper cites): ``log(r_j^-1 q)`` with the sign of ``r_j^-1 q`` chosen so its ``w >= 0``.  The log map of a
rotation is discontinuous where its angle crosses pi; real skeletons have joints that sit near pi
(e.g. the Bandai clips' upper legs at 179 degrees), where a log about the identity would jump by ~pi
between two almost equal poses.  About the mean the cut is as far from the data as it can be.
This is a deviation from the paper's plain log map (§3); ``reference="identity"`` gives the plain
``log q`` of the paper.  Measured: on bandai_run_cycle (30 Hz) the plain log jumps by > 2.0 between
consecutive frames where the mean-relative one moves < 0.6 (``tests/test_wand_pose_space.py``); with the
paper's spectrum (``self_term=True``) the looped bandai run's opposite-phase weights are 0.22-0.37 with
the plain log against 0.05-0.11 about the mean.  (With the default spectrum both references pass the
issue's propagation checks; the default sigma moves from 0.195 to 0.230 on that clip.)
Optional per-joint weights scale each joint's three log coordinates, and an optional temporal term
(the paper: "it may be desirable to include the temporal distance between poses") appends
``time_weight * t`` so that ``d(p_i, p_j)^2 = sum_j w_j^2 |log q_ij - log q_jj|^2 + time_weight^2 (t_i - t_j)^2``.

**Heading** (issue 13 item 10; a deviation from the paper, whose pose vector holds the root's rotation as
is): by default the pose space is *heading-invariant*.  The pelvis (:func:`..core.body.pelvis_joint`, not
necessarily joint 0) enters with its world rotation minus its heading, the twist about the vertical axis
(:func:`..core.body.remove_heading`; pitch and roll kept), and the joints above it (a static root) are left
out.  Otherwise a walk that turns puts the same phase one stride later far away in pose space: measured on
bandai_walk_turn_left the same-phase weight was 0.25 with the heading, 0.87 without.  ``heading="keep"``
gives the paper's form (every joint's local rotation, the root's heading included).

**Flipping joints** (issue 25; a deviation from the paper, ``flips="keep"`` is its form): a joint whose local
rotation turns by more than :data:`FLIP_DEGREES` between two consecutive frames is left out of the pose
distance (weight 0; :func:`flipped_joints`).  No body part turns 90 degrees in one frame at a mocap rate (on
the 17 clips at hand the largest step of any other joint is under 60 degrees, at 30 Hz); such a step is a
solver's flip, usually a twist of a bone about its own axis, which moves no joint (invisible in positions) yet
jumps the log map by ~pi/2 and cuts the pose graph in two.  Measured: xia_sexy_walk's RightToeBase flips by
180 degrees 4 times (frames 45..): kept, the frames between two flips form a cluster whose falloff is ~1 at
every phase (the half-stride weight 0.91 at 30 Hz, goal <= 0.3); dropped, 0.01.  CMU 131_01's RThumb
flips 8 times (half-stride weight 0.85 -> see ``benchmarks/bench_claims.py``).  The edit itself still moves
every joint (Eq. 5 is applied to all rotations; only the distance leaves the flipping joint out).

Shapes: F frames, J joints, D = 3 J (+ 1 with the temporal term) pose dimensions.
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..core.body import pelvis_joint, remove_heading, up_axis
from ..core.motion import Motion
from ..core.rotations import quat_conj, quat_exp, quat_hemisphere, quat_log, quat_mul

__all__ = ["mean_rotations", "reference_rotations", "pose_logs", "pose_exps", "pose_vectors",
           "joint_weight_array", "heading_free_quats", "flipped_joints", "HEADINGS", "FLIPS", "FLIP_DEGREES"]

HEADINGS = ("remove", "keep")
FLIPS = ("drop", "keep")
FLIP_DEGREES = 90.0  # a joint turning more than this between consecutive frames is a flip (module docstring)
_UP_SAMPLES = 256   # frames used to find the vertical axis (:func:`..core.body.up_axis`)


def mean_rotations(local_quats: np.ndarray) -> np.ndarray:
    """Chordal L2 mean rotation of each joint over frames (sign-invariant).

    Parameters
    ----------
    local_quats : ndarray, shape (F, J, 4), (x, y, z, w)

    Returns
    -------
    means : ndarray, shape (J, 4), (x, y, z, w), with ``w >= 0``
        Per joint the unit eigenvector of the largest eigenvalue of ``sum_f q_f q_f^T`` (4 x 4), which is
        unchanged when any ``q_f`` flips sign.
    """
    q = np.asarray(local_quats, dtype=float)
    M = np.einsum("fji,fjk->jik", q, q)
    _, vecs = np.linalg.eigh(M)
    return quat_hemisphere(vecs[:, :, -1])


def reference_rotations(local_quats: np.ndarray, reference="mean") -> np.ndarray:
    """The per-joint reference ``(J, 4)`` for ``reference`` = ``"mean"``, ``"identity"`` or a ``(J, 4)`` array."""
    q = np.asarray(local_quats, dtype=float)
    J = q.shape[-2]
    if isinstance(reference, str):
        if reference == "mean":
            return mean_rotations(q)
        if reference == "identity":
            return np.tile(np.array([0.0, 0.0, 0.0, 1.0]), (J, 1))
        raise ValueError(f"reference must be 'mean', 'identity' or a (J, 4) array, got {reference!r}")
    r = np.asarray(reference, dtype=float)
    if r.shape != (J, 4):
        raise ValueError(f"reference must have shape ({J}, 4), got {r.shape}")
    return r / np.linalg.norm(r, axis=-1, keepdims=True)


def pose_logs(local_quats: np.ndarray, reference: np.ndarray | None = None) -> np.ndarray:
    """Hemisphere-consistent log map of local joint rotations about a per-joint reference.

    Parameters
    ----------
    local_quats : ndarray, shape (..., J, 4), (x, y, z, w)
    reference : ndarray, shape (J, 4), or None (identity)

    Returns
    -------
    logs : ndarray, shape (..., J, 3)
        ``log(r_j^-1 q)`` = ``axis * angle / 2`` with ``angle`` in [0, pi]; ``q`` and ``-q`` map to the same log.
    """
    q = np.asarray(local_quats, dtype=float)
    if reference is not None:
        q = quat_mul(quat_conj(reference), q)
    return quat_log(quat_hemisphere(q))


def pose_exps(logs: np.ndarray, reference: np.ndarray | None = None) -> np.ndarray:
    """Inverse of :func:`pose_logs`: ``r_j exp(v)`` for ``logs (..., J, 3)`` -> quaternions ``(..., J, 4)``."""
    q = quat_exp(np.asarray(logs, dtype=float))
    if reference is not None:
        q = quat_mul(reference, q)
    return q


def joint_weight_array(skeleton, joint_weights) -> np.ndarray:
    """Per-joint weights ``(J,)`` from ``None`` (all ones), a ``(J,)`` sequence or a ``{name: weight}``
    mapping (joints not named keep weight 1). Raises ``ValueError`` naming ``joint_weights``."""
    J = skeleton.num_joints
    if joint_weights is None:
        return np.ones(J)
    if isinstance(joint_weights, Mapping):
        w = np.ones(J)
        for name, value in joint_weights.items():
            try:
                w[skeleton.index(name)] = float(value)
            except (KeyError, ValueError) as exc:
                raise ValueError(f"joint_weights: unknown joint {name!r}") from exc
    else:
        w = np.asarray(joint_weights, dtype=float).reshape(-1)
        if w.shape != (J,):
            raise ValueError(f"joint_weights must have shape ({J},) or be a {{name: weight}} mapping, got {w.shape}")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError("joint_weights must be finite and >= 0")
    return w


def heading_free_quats(motion: Motion, up=None) -> np.ndarray:
    """Local rotations ``(F, J, 4)`` with the pelvis's heading removed (module docstring).

    The pelvis row holds its *world* rotation minus the twist about ``up`` (default: :func:`..core.body.up_axis`
    of the motion), the rows of its ancestors the identity; every other row is the local rotation.
    """
    q = np.array(motion.local_quats, dtype=float)
    skel = motion.skeleton
    p = pelvis_joint(skel)
    if up is None:
        step = max(1, motion.num_frames // _UP_SAMPLES)
        up = up_axis(motion.slice(0, motion.num_frames, step))
    chain = [p]
    while skel.parents[chain[-1]] >= 0:
        chain.append(int(skel.parents[chain[-1]]))
    world = q[:, chain[-1]]
    for a in reversed(chain[:-1]):
        world = quat_mul(world, q[:, a])
    q[:, p] = remove_heading(world, np.asarray(up, dtype=float))
    q[:, chain[1:]] = [0.0, 0.0, 0.0, 1.0]
    return q


def flipped_joints(local_quats: np.ndarray, degrees: float = FLIP_DEGREES) -> np.ndarray:
    """Indices of the joints whose rotation ``(F, J, 4)`` turns by more than ``degrees`` between two
    consecutive frames (sign-free: ``q`` and ``-q`` are the same rotation), ascending."""
    q = np.asarray(local_quats, dtype=float)
    if q.shape[0] < 2:
        return np.zeros(0, dtype=np.int64)
    qn = q / np.linalg.norm(q, axis=-1, keepdims=True)
    c = np.abs(np.sum(qn[1:] * qn[:-1], axis=-1)).min(axis=0)        # cos of half the largest step, (J,)
    return np.flatnonzero(c < np.cos(np.radians(float(degrees)) / 2))


def pose_vectors(motion: Motion, joint_weights=None, time_weight: float = 0.0, reference="mean",
                 heading: str = "remove", flips: str = "drop") -> np.ndarray:
    """Pose vectors of every frame (§3: concatenated log-map rotational dofs).

    Parameters
    ----------
    motion : Motion
        ``local_quats (F, J, 4)`` are used; root and joint translations are not.
    joint_weights : None, (J,) array or {joint name: weight}
        Multiplies each joint's log coordinates (0 drops a joint, e.g. the root's heading).
    time_weight : float, >= 0, radians per second
        Weight of the temporal term: the extra coordinate is ``time_weight * t`` with ``t`` in seconds.
    reference : "mean" (default), "identity" or ndarray (J, 4)
        Per-joint rotation the log map is taken about (see the module docstring).
    heading : "remove" (default) | "keep"
        Leave the pelvis's heading (yaw about the vertical) out of the pose, keeping pitch and roll
        (heading-invariant), or keep every local rotation as in the paper (module docstring).
    flips : "drop" (default) | "keep"
        Leave joints that flip (:func:`flipped_joints`) out of the distance, or keep them as the paper does.

    Returns
    -------
    X : ndarray, shape (F, 3 J) or (F, 3 J + 1) when ``time_weight > 0``
    """
    w = joint_weight_array(motion.skeleton, joint_weights)
    tw = float(time_weight)
    if not np.isfinite(tw) or tw < 0:
        raise ValueError(f"time_weight must be a finite number >= 0, got {time_weight!r}")
    if heading not in HEADINGS:
        raise ValueError(f"heading must be one of {HEADINGS}, got {heading!r}")
    if flips not in FLIPS:
        raise ValueError(f"flips must be one of {FLIPS}, got {flips!r}")
    q = heading_free_quats(motion) if heading == "remove" else motion.local_quats
    if flips == "drop":
        bad = flipped_joints(q)
        if bad.size:
            w = w.copy()
            w[bad] = 0.0
    ref = reference_rotations(q, reference)
    logs = pose_logs(q, ref) * w[None, :, None]
    X = logs.reshape(motion.num_frames, -1)
    if tw > 0:
        X = np.concatenate([X, (tw * motion.times)[:, None]], axis=1)
    return np.ascontiguousarray(X)
