"""The curves the procedural clips are blocked with (:mod:`.procedural`): easing (minimum jerk, smoothstep), a
soft minimum, Hermite keys, smoothed noise, and the foot plants of one foot (:class:`_Plants`: stance
intervals, then minimum-jerk swings with a ``sin^2`` lift)."""
from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.ndimage import gaussian_filter1d

from .procedural_rig import ANKLE_HEIGHT

_SOFT = 0.5                # cm, smoothness of the soft minimum that keeps ankles in reach


def _min_jerk(s: np.ndarray) -> np.ndarray:
    """0 -> 1 with zero velocity and acceleration at both ends."""
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def _smoothstep(t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """0 before ``t0``, 1 after ``t1``, minimum-jerk in between."""
    return _min_jerk(np.clip((t - t0) / (t1 - t0), 0.0, 1.0))


def _softmin(a: np.ndarray, b: np.ndarray, k: float = _SOFT) -> np.ndarray:
    """Smooth minimum; equals ``a`` exactly where ``b`` is +inf."""
    m = np.minimum(a, b)
    with np.errstate(invalid="ignore", over="ignore"):
        r = m - k * np.log(np.exp(-(a - m) / k) + np.exp(-(b - m) / k))
    return np.where(np.isinf(b), a, r)


def _hermite(keys, t: np.ndarray) -> np.ndarray:
    """Piecewise cubic Hermite through ``keys = [(t, value, slope), ...]``, held constant outside."""
    k = np.asarray(keys, dtype=float)
    spline = CubicHermiteSpline(k[:, 0], k[:, 1], k[:, 2])
    tc = np.clip(t, k[0, 0], k[-1, 0])
    return spline(tc)


def _noise(rng: np.random.Generator, n: int, dims: int, deg: float, sigma_frames: float = 8.0) -> np.ndarray:
    """Smoothed Gaussian noise (n, dims), roughly ``deg`` degrees standard deviation."""
    w = gaussian_filter1d(rng.standard_normal((n, dims)), sigma_frames, axis=0, mode="nearest")
    return w * (deg / max(float(np.std(w)), 1e-12))


class _Plants:
    """Foot plants of one foot: stance intervals ``[t_on, t_off]`` at ``xz (n, 2)`` (cm), sorted;
    ``lift`` (cm, scalar or (n,)) is the ankle's rise during the swing that follows each plant."""

    def __init__(self, t_on, t_off, xz, lift):
        self.t_on = np.asarray(t_on, dtype=float)
        self.t_off = np.asarray(t_off, dtype=float)
        self.xz = np.asarray(xz, dtype=float).reshape(-1, 2)
        self.lift = np.broadcast_to(np.asarray(lift, dtype=float), self.t_on.shape)

    def evaluate(self, t: np.ndarray):
        """Ankle targets (F, 3), foot pitch (F,) degrees, stance mask (F,) at times ``t``."""
        i = np.searchsorted(self.t_on, t, side="right") - 1      # last plant that started
        if np.any(i < 0) or np.any(i >= len(self.t_on)):
            raise ValueError("plants must cover the whole clip")
        stance = t <= self.t_off[i]
        j = np.minimum(i + 1, len(self.t_on) - 1)
        if np.any(~stance & (j == i)):
            raise ValueError("plants must cover the whole clip")
        s = np.where(stance, 0.0, (t - self.t_off[i]) / np.maximum(self.t_on[j] - self.t_off[i], 1e-9))
        s = np.clip(s, 0.0, 1.0)
        m = _min_jerk(s)[:, None]
        xz = self.xz[i] * (1.0 - m) + self.xz[j] * m
        bump = np.sin(np.pi * s) ** 2
        y = ANKLE_HEIGHT + self.lift[i] * bump
        pos = np.stack([xz[:, 0], y, xz[:, 1]], axis=-1)
        pitch = -12.0 * np.sin(2.0 * np.pi * s) * (s > 0)   # toes down after lift-off, up before contact
        return pos, np.where(stance, 0.0, pitch), stance


def _cycle_plants(t_end: float, period: float, duty: float, phase: float, root_z, x: float, lift: float,
                  first: int = -2):
    """Periodic plants: stance centred at ``(i + phase) * period`` under the root, lasting ``duty*period``."""
    idx = np.arange(first, int(np.ceil(t_end / period)) + 2)
    tc = (idx + phase) * period
    half = 0.5 * duty * period
    xz = np.stack([np.full(tc.shape, x), root_z(tc)], axis=-1)
    return tc - half, tc + half, xz, lift

