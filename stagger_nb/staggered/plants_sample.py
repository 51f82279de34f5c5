"""Sampling helpers of the contact layer (:mod:`.plants_hold`): positions and rotations at fractional frames,
the C1 raised-cosine fade, a fade's turn kept on one way round, a limb's length."""
from __future__ import annotations

import numpy as np

from ..core.rotations import slerp
from .limbs import Limb


def _sample(arr: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``arr (F, ...)`` positions at fractional frames ``f (n,)`` (linear; clamped to the clip)."""
    f = np.clip(f, 0, arr.shape[0] - 1)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, arr.shape[0] - 1)
    w = (f - i0).reshape((-1,) + (1,) * (arr.ndim - 1))
    return arr[i0] * (1 - w) + arr[i1] * w


def _sample_quats(arr: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``arr (F, ..., 4)`` unit quaternions at fractional frames ``f (n,)`` (slerp; clamped)."""
    f = np.clip(f, 0, arr.shape[0] - 1)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, arr.shape[0] - 1)
    w = (f - i0).reshape((-1,) + (1,) * (arr.ndim - 2))
    return slerp(arr[i0], arr[i1], np.broadcast_to(w, arr[i0].shape[:-1]))


def _raised_cosine(d: np.ndarray, n: int) -> np.ndarray:
    """C1 fade ``(1 + cos(pi d / (n + 1))) / 2`` for ``0 <= d <= n`` frames, 0 beyond."""
    d = np.asarray(d, dtype=float)
    return np.where((d >= 0) & (d <= n), 0.5 * (1.0 + np.cos(np.pi * np.minimum(d, n + 1) / (n + 1))), 0.0)


def _sample_rows(arr, f, cols):
    """``arr (F, J, 3)`` at fractional frames ``f (n,)`` and joints ``cols (n,)`` (linear; clamped)."""
    f = np.clip(f, 0, arr.shape[0] - 1)
    i0 = np.floor(f).astype(np.int64)
    i1 = np.minimum(i0 + 1, arr.shape[0] - 1)
    w = (f - i0).reshape((-1,) + (1,) * (arr.ndim - 2))
    return arr[i0, cols] * (1 - w) + arr[i1, cols] * w


def _scaled_along(dd: np.ndarray, w: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """Displacements ``dd (n, C, 4)`` on ``frames (n,)`` (ascending) turned by the share ``w (n,)`` of their
    rotation, the way round kept continuous along each run of consecutive frames: the sign of each quaternion
    follows its neighbour's, chosen short where ``w`` is largest (next to the plant), and ``w`` scales that
    quaternion's own angle in [0, 2π). ``slerp(1, dd, w)`` takes the short way on every frame, so a displacement
    whose angle crosses 180° inside a fade flipped the way round: a one-frame turn of ``w · 360°`` (a 100-115°
    foot pop measured on an exaggerated kick)."""
    n = len(frames)
    if n == 0:
        return dd
    start = np.r_[True, np.diff(frames) != 1]
    dots = np.einsum("nci,nci->nc", dd[1:], dd[:-1])
    step = np.where(np.r_[np.zeros((1,) + dots.shape[1:], bool), dots < 0] & ~start[:, None], -1.0, 1.0)
    sign = np.ones_like(step)
    for r0, r1 in zip(np.flatnonzero(start), np.r_[np.flatnonzero(start)[1:], n]):
        seg = np.cumprod(step[r0:r1], axis=0)
        top = r0 + int(np.argmax(w[r0:r1]))
        seg = seg * np.where(dd[top, :, 3] * seg[top - r0] < 0, -1.0, 1.0)
        sign[r0:r1] = seg
    q = dd * sign[..., None]
    v = q[..., :3]
    vn = np.linalg.norm(v, axis=-1)
    theta = 2.0 * np.arctan2(vn, q[..., 3])
    half = 0.5 * w[:, None] * theta
    axis = v / np.where(vn > 0, vn, 1.0)[..., None]
    return np.concatenate([axis * np.sin(half)[..., None], np.cos(half)[..., None]], axis=-1)


def _length(pos, lim: Limb) -> np.ndarray:
    """The limb's two bones' length on every frame ``(F,)`` (file units; animated translations may change it)."""
    return (np.linalg.norm(pos[:, lim.mid] - pos[:, lim.upper], axis=-1)
            + np.linalg.norm(pos[:, lim.eff] - pos[:, lim.mid], axis=-1))
