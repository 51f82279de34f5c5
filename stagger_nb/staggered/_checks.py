"""Option checks at the public boundary of the staggered-pose functions (type and range, ValueError naming
the option), the work bounds that depend on the frame time, and the editing tools' argument readers (joint and
pose selections, pose indices, per-joint rotation tables)."""
from __future__ import annotations

import math
import numbers

import numpy as np

from ..core.checks import finite_number as _finite  # noqa: F401 (the editing tools read it from here)
from ..core.rotations import quat_exp
from .representation import StaggeredMotion

_IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])

# Highest frame rate extraction accepts: the tent filter and the refinement window span
# ``width / frame_time`` frames, and Laplacian smoothing needs ``(0.02 s / frame_time)² / λ`` passes.
MIN_FRAME_TIME = 1e-4          # seconds (10 kHz)


def real(where: str, name: str, value, lo: float | None = None, hi: float | None = None, *,
         lo_open: bool = False, none_ok: bool = False):
    """``float(value)`` if it is a finite real number in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``), else
    ValueError ``"<where>: <name> must be ..., got <value>"``. ``None`` passes through with ``none_ok``."""
    if value is None and none_ok:
        return None
    rng = (f"in {'(' if lo_open else '['}{lo:g}, {hi:g}]" if lo is not None and hi is not None
           else f"{'>' if lo_open else '>='} {lo:g}" if lo is not None else f"<= {hi:g}" if hi is not None else "")
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{where}: {name} must be a number {rng}, got {value!r}")
    v = float(value)
    ok = math.isfinite(v) and (lo is None or (v > lo if lo_open else v >= lo)) and (hi is None or v <= hi)
    if not ok:
        raise ValueError(f"{where}: {name} must be a finite number {rng}, got {value!r}")
    return v


def integer(where: str, name: str, value, lo: int, hi: int, *, none_ok: bool = False):
    """``int(value)`` if it is an integer (an int, or a float with an integral value) in ``[lo, hi]``."""
    if value is None and none_ok:
        return None
    integral = (isinstance(value, numbers.Integral) and not isinstance(value, bool)) or (
        isinstance(value, float) and math.isfinite(value) and value == int(value))
    if not integral or not lo <= int(value) <= hi:
        raise ValueError(f"{where}: {name} must be an integer in [{lo}, {hi}], got {value!r}")
    return int(value)


def frame_time(where: str, ft: float) -> float:
    """The motion's frame time if extraction can work at it, else ValueError naming it and the remedy."""
    ft = float(ft)
    if not (math.isfinite(ft) and ft >= MIN_FRAME_TIME):
        raise ValueError(
            f"{where}: frame_time {ft!r} s is shorter than {MIN_FRAME_TIME:g} s ({1 / MIN_FRAME_TIME:g} Hz): the "
            f"smoothing and filter widths would span too many frames; resample first, e.g. "
            f"m.resample(1 / 120)")
    return ft


def _check(sm) -> None:
    if not isinstance(sm, StaggeredMotion):
        raise ValueError(f"sm must be a StaggeredMotion, got {type(sm).__name__}")


def _joint_mask(sm: StaggeredMotion, joints, default=None) -> np.ndarray:
    """(J,) bool mask of a joint subset given by names/indices; ``None`` -> ``default`` (all joints)."""
    J = sm.num_joints
    if joints is None:
        return np.ones(J, bool) if default is None else default
    if isinstance(joints, (str, int, np.integer)):
        joints = [joints]
    mask = np.zeros(J, bool)
    for j in joints:
        if isinstance(j, str):
            try:
                mask[sm.skeleton.index(j)] = True
            except KeyError as e:
                raise ValueError(f"joints: {e.args[0]}") from None
        else:
            if not 0 <= int(j) < J:
                raise ValueError(f"joints: index {j} outside [0, {J})")
            mask[int(j)] = True
    return mask


def _pose_mask(sm: StaggeredMotion, poses, interior_default: bool) -> np.ndarray:
    K = sm.num_poses
    if poses is None:
        mask = np.ones(K, bool)
        if interior_default:
            mask[[0, -1]] = False
        return mask
    if isinstance(poses, (int, np.integer)):
        poses = [poses]
    mask = np.zeros(K, bool)
    for k in poses:
        if not -K <= int(k) < K:
            raise ValueError(f"poses: index {k} outside [0, {K})")
        mask[int(k)] = True
    return mask


def _pose_index(sm: StaggeredMotion, k, name="k") -> int:
    K = sm.num_poses
    if not isinstance(k, (int, np.integer)) or not -K <= int(k) < K:
        raise ValueError(f"{name} must be a pose index in [0, {K}), got {k!r}")
    return int(k) % K


def _rotation_table(sm: StaggeredMotion, spec, name: str) -> tuple[np.ndarray, np.ndarray]:
    """Per-joint rotations from ``{joint: rotvec (3,) | quat (4,)}`` or an array ``(J, 3)``/``(J, 4)``.

    Returns ``quats (J, 4)`` (identity where absent) and the ``(J,)`` mask of given joints."""
    J = sm.num_joints
    q = np.tile(_IDENTITY, (J, 1))
    given = np.zeros(J, bool)
    if isinstance(spec, dict):
        items = spec.items()
    else:
        arr = np.asarray(spec, dtype=float)
        if arr.ndim != 2 or arr.shape[0] != J or arr.shape[1] not in (3, 4):
            raise ValueError(f"{name} must be a dict joint -> rotation or an array of shape ({J}, 3|4), "
                             f"got {arr.shape}")
        items = enumerate(arr)
    for j, v in items:
        try:
            jj = _joint_mask(sm, [j])
        except ValueError as e:
            raise ValueError(f"{name}: {e}") from None
        v = np.asarray(v, dtype=float).reshape(-1)
        if v.size == 3:
            v = quat_exp(0.5 * v)                 # rotation vector, radians
        elif v.size == 4 and np.linalg.norm(v) > 0:
            v = v / np.linalg.norm(v)             # quaternion (x, y, z, w)
        else:
            raise ValueError(f"{name}[{j!r}] must be a rotation vector (3 numbers) or a quaternion (4), "
                             f"got {v.tolist()}")
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{name}[{j!r}] must be finite")
        q[jj] = v
        given |= jj
    return q, given


def _pose_weights(sm: StaggeredMotion, weights, name: str = "weights", rows: int | None = None) -> np.ndarray | None:
    """Per-pose weights as a float array: shape (K,) (``rows`` None) or (rows, K) (a (K,) array is accepted for
    one row), every entry finite; None passes through."""
    if weights is None:
        return None
    K = sm.num_poses
    try:
        w = np.array(weights, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an array of numbers, one per pose, got {type(weights).__name__}") from None
    want = (K,) if rows is None else (rows, K)
    if rows is not None and w.shape == (K,) and rows == 1:
        w = w[None]
    if w.shape != want:
        raise ValueError(f"{name} must have shape {want} (one weight per pose), got {w.shape}")
    if not np.all(np.isfinite(w)):
        raise ValueError(f"{name} must be finite")
    return w
