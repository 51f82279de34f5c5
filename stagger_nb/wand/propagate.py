"""Edit propagation with the Green's falloff (Dean et al. 2018, §3.3, Eqs. 4-5; §4.2, Figure 4).

For an edited frame ``i`` with new local rotations ``p'_i``:
``delta_i = log(p'_i) - log(p_i)`` (Eq. 4) per joint, and for every frame ``j`` of the range
``p'_j = exp(log(p_j) + w_ij delta_i)`` (Eq. 5), ``w_i`` the falloff of :mod:`.falloff`.  The logs are
the same hemisphere-consistent log maps about a per-joint reference rotation as the pose vectors
(:mod:`.pose_space`; the mean reference is a deviation from the paper, ``reference="identity"`` is its
plain ``log``): ``p = r exp(v)``.

Several edited frames ``i_1 .. i_E`` combine linearly in the log map, ``log p'_j = log p_j + sum_e w_ej c_e``:

* ``combine="interpolate"`` (default) solves the ``E x E`` system ``sum_e w_e(i_a) c_e = delta_a`` so that
  every edited frame gets exactly its edited pose even when the falloffs overlap (the Green's function
  solution with the edits as constraints, §3; our extension, the paper propagates one edit).  The system
  is ill-conditioned when two edited frames are nearly alike under the falloff (a few frames apart, or a
  frame and its repetition): measured on xia_angry_run, 17-degree edits about different axes at frames
  10 and 12 (cond 705) swing other frames by up to 43 degrees, at 10 and 11 (cond 1709) by 53 degrees;
  at 10 and its repetition 112 (cond 15) by no more than the edits.  A singular system (weights exactly
  alike) gets the least-squares solution, which no longer reproduces the edits exactly;
* ``combine="sum"`` uses ``c_e = delta_e`` (each edit propagated on its own and added).

Root translations and joint translations are not changed.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from .falloff import greens_falloff
from .greens import GreensBasis, greens_basis
from .pose_space import pose_exps, pose_logs, reference_rotations

__all__ = ["propagate", "propagate_logs"]


def propagate_logs(logs: np.ndarray, frames: np.ndarray, deltas: np.ndarray, weights: np.ndarray,
                   combine: str = "interpolate") -> np.ndarray:
    """Eq. 5 on log-map arrays.

    Parameters
    ----------
    logs : ndarray, shape (F, J, 3)
        Log map of the original poses.
    frames : ndarray, shape (E,), int
        Edited frames.
    deltas : ndarray, shape (E, J, 3)
        Eq. 4 delta-poses of the edits.
    weights : ndarray, shape (E, F)
        Falloff of each edit (1 at its own frame).
    combine : "interpolate" | "sum"

    Returns
    -------
    new_logs : ndarray, shape (F, J, 3)
    """
    E = len(frames)
    D = deltas.reshape(E, -1)
    if combine == "interpolate" and E > 1:
        W = weights[:, frames].T  # W[a, e] = w_e(i_a)
        C = np.linalg.lstsq(W, D, rcond=1e-10)[0]
    elif combine in ("interpolate", "sum"):
        C = D
    else:
        raise ValueError(f"combine must be 'interpolate' or 'sum', got {combine!r}")
    return logs + (weights.T @ C).reshape(logs.shape)


def propagate(m: Motion, frame, edited_local_quats, sigma: float | None = None, frame_range=None, *,
              repetitions: bool = True, combine: str = "interpolate", num_eigs: int | None = None,
              basis: GreensBasis | None = None, reference="mean", **basis_options) -> Motion:
    """Propagate an edit of the pose at ``frame`` to the motion (Eqs. 4-5).

    Parameters
    ----------
    m : Motion
    frame : int or sequence of E ints
        Edited frame(s), 0-based.
    edited_local_quats : ndarray, shape (J, 4) or (E, J, 4), (x, y, z, w)
        The edited pose(s) of those frames (sign of each quaternion irrelevant).
    sigma, frame_range, repetitions, num_eigs, basis, basis_options
        As in :func:`.falloff.falloff`; the frame range and repetition choice apply to every edit.
    combine : "interpolate" | "sum"
        How several edits combine (module docstring).
    reference : "mean" | "identity" | ndarray (J, 4)
        Rotation the log maps are taken about (:mod:`.pose_space`); also used for the basis built here.

    Returns
    -------
    Motion with new ``local_quats (F, J, 4)``; everything else as in ``m``.
    """
    F, J = m.num_frames, m.num_joints
    frames = np.atleast_1d(np.asarray(frame))
    if frames.ndim != 1 or frames.dtype.kind not in "iu":
        raise ValueError(f"frame must be an int or a sequence of ints, got {frame!r}")
    if np.any(frames < 0) or np.any(frames >= F):
        raise ValueError(f"frame must be in [0, {F}), got {frame!r}")
    if len(np.unique(frames)) != len(frames):
        raise ValueError(f"frame must not repeat a frame, got {frame!r}")
    E = len(frames)
    try:
        q = np.asarray(edited_local_quats, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"edited_local_quats must be an array of numbers (x, y, z, w), got "
                         f"{type(edited_local_quats).__name__}: {exc}") from None
    if q.shape == (J, 4) and E == 1:
        q = q[None]
    if q.shape != (E, J, 4):
        raise ValueError(f"edited_local_quats must have shape ({J}, 4) for one frame or ({E}, {J}, 4), got {q.shape}")
    if not np.all(np.isfinite(q)) or np.any(np.linalg.norm(q, axis=-1) < 1e-12):
        raise ValueError("edited_local_quats must be finite, non-zero quaternions")
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    if basis is None:
        basis = greens_basis(m, sigma=sigma, num_eigs=num_eigs, reference=reference, **basis_options)
    elif basis.num_frames != F:
        raise ValueError(f"basis has {basis.num_frames} frames, motion has {F}")
    ref = reference_rotations(m.local_quats, reference)
    logs = pose_logs(m.local_quats, ref)
    deltas = pose_logs(q, ref) - logs[frames]
    weights = np.stack([greens_falloff(basis, int(f), frame_range, repetitions) for f in frames])
    new_logs = propagate_logs(logs, frames, deltas, weights, combine)
    return m.replace(local_quats=pose_exps(new_logs, ref))
