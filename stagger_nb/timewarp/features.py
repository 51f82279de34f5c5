"""Pose features for guided time warping (Hsu et al. 2007, §3.2).

A frame's *pose* is the vector of its joint positions in a body-attached coordinate frame, low-pass
prefiltered to limit temporal aliasing of the finite differences (§3.2, last paragraph). The feature vector
of an output frame is ``[y, ẏ, ÿ]`` where the derivatives are central finite differences *over output frames*:
if input frames ``i, j, k`` are placed at consecutive output frames,

    y = x_j,    ẏ = (x_k - x_i) / 2,    ÿ = x_k - 2 x_j + x_i          (units: file units per output frame)

**Which body frame** (``frame``; a deviation from the paper's letter, issue 25).  The paper follows Arikan &
Forsyth: positions "in the torso coordinate system", independent of global position and orientation.  Read
literally (``frame="pelvis"``: ``R_p(t)^-1 (x_j - x_p)``, :func:`..core.body.positions_in_pelvis_frame`) the
torso's own motion is gone, and with it what §4.1 says the objective sees in a jump: "accelerations during
such motions are practically constant" -- the body's fall under gravity is the pelvis's vertical
acceleration, identically 0 in its own frame.  The default ``frame="pelvis_height"`` adds that one
coordinate: the pelvis's height above the floor (:func:`..core.body.positions_in_heading_frame`), weighted by
``sqrt(sum of the joint weights)`` (``sqrt(n)`` unweighted) so the body's common vertical motion counts as if
every joint moved with it.  ``frame="heading"`` puts every joint in the pelvis's heading frame with its height
above the floor instead.  Measured (self reference, 65 % length, 30 Hz; airborne speed as
:func:`.measures.airborne_speed`, 1 = real time, the linear warp 1.54), with the other defaults:

=============================================  ========  ===============  =========
clip                                           pelvis    pelvis_height    heading
=============================================  ========  ===============  =========
CMU 01_01 (688 frames)                         1.12      1.02             1.01
the procedural jump (166 frames)               3.18      1.00             1.00
13 standing jumps / single hops, 1.25-2 s      --        0.96 (max 1.15)  0.96 (max 1.09)
=============================================  ========  ===============  =========

and for another performer's reference (the xia neutral walk's free length guided by the angry run,
``tests/test_timewarp_eval.py``): ``pelvis`` median 17.9 cm/s, ``pelvis_height`` 16.4, ``heading`` 14.8
(the run's 19.8): heights of every joint above the floor differ between a walk and a run more than their
torso-frame poses do, so ``heading`` matches another activity's poses worse.

The torso frame is the **pelvis's** (:func:`..core.body.pelvis_joint`, the joint where the legs' and the
spine's chains branch), not joint 0's: on rigs whose joint 0 is a static root above the hips (the Bandai files)
joint 0's frame does not move with the body, and positions in it carry the global travel (807 cm on
bandai_walk). Only the pelvis's subtree enters the features (joints above it carry the travel too).

Glossary: F frames, J joints, D = 3 J pose dimensions, n input frames, r reference frames.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter1d

from ..core.body import FLOOR_PERCENTILE, positions_in_heading_frame, positions_in_pelvis_frame, up_axis
from ..core.kinematics import forward_kinematics
from ..core.motion import Motion

__all__ = ["pose_features", "prefilter_frames", "feature_weights", "triple_features", "reference_blocks",
           "reference_features", "FRAMES", "check_frame"]

FRAMES = ("pelvis_height", "heading", "pelvis")   # body frames of the pose features (module docstring); the first
                                                  # is the default


def check_frame(frame) -> str:
    if frame not in FRAMES:
        raise ValueError(f"frame must be one of {FRAMES}, got {frame!r}")
    return frame


def prefilter_frames(prefilter: float, frame_time: float) -> int:
    """Odd box-filter width in frames for a prefilter of ``prefilter`` seconds (1 = no filtering)."""
    if not np.isfinite(prefilter) or prefilter < 0:
        raise ValueError(f"prefilter must be a non-negative number of seconds, got {prefilter!r}")
    w = int(round(prefilter / frame_time))
    return max(1, w | 1)  # make it odd so the filter is centred


def pose_features(motion: Motion, joint_weights=None, prefilter: float = 0.1,
                  frame: str = "pelvis_height") -> np.ndarray:
    """Body-frame joint positions, prefiltered and weighted (§3.2).

    Parameters
    ----------
    motion : Motion with F frames, J joints
    joint_weights : (J,) non-negative weights or None (all 1). A joint's coordinates are multiplied by
        ``sqrt(weight)`` so squared feature distances weight each joint by ``weight``.
    prefilter : float, seconds
        Width of the uniform (box) low-pass filter applied along time; 0 disables it.
    frame : "pelvis_height" (default: the pelvis's frame plus the pelvis's height above the floor),
        "heading" (the pelvis's heading frame, every joint's height above the floor) or "pelvis" (the pelvis's
        own frame, the paper's letter); see the module docstring

    Returns
    -------
    X : (F, 3 n) float64, positions of the pelvis's subtree (n joints, ``n = J`` when the pelvis is joint 0)
        in that frame (file units), flattened joint-major; ``"pelvis_height"`` appends one column, the
        weighted height (F, 3 n + 1).
    """
    J = motion.num_joints
    if joint_weights is not None:
        w = np.asarray(joint_weights, dtype=float)
        if w.shape != (J,) or not np.all(np.isfinite(w)) or np.any(w < 0):
            raise ValueError(f"joint_weights must be {J} non-negative finite numbers, got shape {w.shape}")
    frame = check_frame(frame)
    fk = forward_kinematics(motion)                       # once: both frames and the vertical axis use it
    up = up_axis(motion, fk[0])
    if frame == "heading":
        p, joints = positions_in_heading_frame(motion, up, fk)       # (F, n, 3)
    else:
        p, joints = positions_in_pelvis_frame(motion, fk)
    wj = np.ones(joints.size) if joint_weights is None else w[joints]
    if joint_weights is not None:
        p = p * np.sqrt(wj)[None, :, None]
    X = p.reshape(motion.num_frames, -1)
    if frame == "pelvis_height":
        h = fk[0][:, joints] @ up                                # (F, n) heights; the pelvis is joints[0]
        height = h[:, 0] - np.percentile(h.min(axis=1), FLOOR_PERCENTILE)   # as positions_in_heading_frame
        X = np.concatenate([X, np.sqrt(wj.sum()) * height[:, None]], axis=1)
    width = prefilter_frames(prefilter, motion.frame_time)
    if width > 1 and motion.num_frames > 1:
        X = uniform_filter1d(X, size=width, axis=0, mode="nearest")
    return np.ascontiguousarray(X)


def feature_weights(weights) -> tuple[float, float, float]:
    """Validate ``weights = (w_pose, w_velocity, w_acceleration)`` (scales of the three feature blocks)."""
    w = np.asarray(weights, dtype=float).reshape(-1)
    if w.shape != (3,) or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise ValueError(f"weights must be three non-negative numbers (pose, velocity, acceleration), got {weights!r}")
    return float(w[0]), float(w[1]), float(w[2])


def triple_features(X: np.ndarray, i, j, k, weights=(1.0, 1.0, 1.0)) -> np.ndarray:
    """Feature vectors ``[w_p y, w_v ẏ, w_a ÿ]`` of input frames ``j`` placed between ``i`` and ``k``.

    Parameters
    ----------
    X : (n, D) pose features
    i, j, k : int or (N,) int arrays of input frame indices (consecutive output frames)
    weights : (w_pose, w_velocity, w_acceleration)

    Returns
    -------
    (..., 3 D) feature vectors.
    """
    wp, wv, wa = feature_weights(weights)
    xi, xj, xk = X[i], X[j], X[k]
    return np.concatenate([wp * xj, wv * 0.5 * (xk - xi), wa * (xk - 2.0 * xj + xi)], axis=-1)


def _at(R: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Rows of ``R`` at fractional indices ``f`` (linear interpolation; exact at integers)."""
    i0 = np.clip(np.floor(f).astype(int), 0, R.shape[0] - 1)
    i1 = np.minimum(i0 + 1, R.shape[0] - 1)
    a = (f - i0)[:, None]
    return R[i0] * (1.0 - a) + R[i1] * a


def reference_blocks(R: np.ndarray, step: float = 1.0):
    """Pose, velocity and acceleration blocks of the reference, each (r', D), for every frame ``t`` with
    ``t - step >= 0`` and ``t + step <= r - 1``: ``P = R_t``, ``V = (R_{t+step} - R_{t-step}) / 2``,
    ``A = R_{t+step} - 2 R_t + R_{t-step}`` (fractional ``step`` interpolates linearly). ``step = 1`` is eq. (2)'s
    reference; a larger step gives the coarse problem of the coarse-to-fine heuristic differences over the
    same span as its coarse output frames, from every reference frame."""
    step = float(step)
    if not np.isfinite(step) or step < 1.0:
        raise ValueError(f"step must be >= 1 frame, got {step!r}")
    t = np.arange(int(np.ceil(step - 1e-9)), int(np.floor(R.shape[0] - 1 - step + 1e-9)) + 1)
    P = R[t]
    if step == 1.0:
        lo, hi = R[t - 1], R[t + 1]
    else:
        lo, hi = _at(R, t - step), _at(R, t + step)
    return P, 0.5 * (hi - lo), hi - 2.0 * P + lo


def reference_features(R: np.ndarray, weights=(1.0, 1.0, 1.0), step: float = 1.0) -> np.ndarray:
    """Features ``[w_p P, w_v V, w_a A]`` of the reference (:func:`reference_blocks`), shape (r', 3 D);
    for ``step = 1`` these are the frames ``t = 1 .. r-2`` with neighbours ``t - 1, t + 1``."""
    wp, wv, wa = feature_weights(weights)
    P, V, A = reference_blocks(R, step)
    return np.concatenate([wp * P, wv * V, wa * A], axis=1)
