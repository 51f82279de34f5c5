"""Falloff weights from a Green's row (Dean et al. 2018, §3.3 and Figure 1).

"Let w denote a copy of the i-th row of P that has been scaled to lie between 0 and 1 across the edited
region of the timeline": ``w_j = clip((g_j - min g) / (g_i - min g), 0, 1)`` over the frame range, with
``min`` taken over the range, so ``w = 1`` at the edited frame ``i`` and ``0`` at the most dissimilar
frame of the range; frames outside the range get 0 (a constant row, e.g. a static clip, gives 1 on the
whole range).  The clip matters where a row
peaks off its frame: a few frames off (§4.2's "offset of 2-3 frames", from truncating Eq. 3 and dropping
its self term), or at a repetition of the pose in a denser part of the clip (seen on bandai_walk and CMU
131_01 / 01_01 for some frames); such frames get weight 1, i.e. the full edit, and Eq. 5 stays well
defined (``0 <= w <= 1``: no frame gets more than the edit).  Measured with the defaults on the real
clips, rows whose clipped set reaches frames more than 0.25 s away: xia runs/walk 0 %, pymo 12 %,
bandai_walk 30 %, CMU 131_01 31 %; the clipped values exceed 1 by a median <= 0.2 % and at most 3 %
(12.7 % on CMU 131_01), so clipping changes those weights little: such a repetition would get about the
full edit unclipped too.  The normalised pose distance of Figure 1 is ``1 - w``.

"The artist ... can choose to include such repetition or discard it": with ``repetitions=False`` the range
shrinks to the valley on either side of ``i`` (walking outward from ``i`` until ``w`` has risen
``VALLEY_RISE`` above its running minimum) and each side is normalised again between ``g_i`` and its
own valley bottom, so ``w`` falls continuously from 1 at ``i`` to 0 at both valley bottoms and stays 0
beyond them.

Frame indices are 0-based; ranges are half-open ``[start, stop)``.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from .greens import GreensBasis, greens_basis

__all__ = ["normalize_row", "falloff", "greens_falloff", "greens_distance", "falloff_extent", "check_frame_range",
           "VALLEY_RISE"]

VALLEY_RISE = 0.02  # a rise of w by this much (of the [0, 1] scale) past its running minimum ends a valley


def check_frame_range(frame_range, num_frames: int, frame: int | None = None) -> tuple[int, int]:
    """Validate a half-open ``(start, stop)`` range (None = the whole clip); it must contain ``frame``."""
    if frame_range is None:
        start, stop = 0, num_frames
    else:
        try:
            start, stop = (int(v) for v in frame_range)
        except (TypeError, ValueError, OverflowError) as exc:  # OverflowError: int(inf)
            raise ValueError(f"frame_range must be a (start, stop) pair of frame indices, got {frame_range!r}") from exc
        if not 0 <= start < stop <= num_frames:
            raise ValueError(f"frame_range must satisfy 0 <= start < stop <= {num_frames}, got {frame_range!r}")
    if frame is not None and not start <= frame < stop:
        raise ValueError(f"frame {frame} is outside frame_range [{start}, {stop})")
    return start, stop


def _scale(g: np.ndarray, frame: int, start: int, stop: int) -> np.ndarray:
    w = np.zeros_like(g)
    seg = g[start:stop]
    lo = seg.min()
    den = g[frame] - lo
    if not den > 0:
        if np.all(seg == lo):  # a constant row: no frame of the range is less similar than another
            w[start:stop] = 1.0
        w[frame] = 1.0         # (else the frame is the range's minimum: only the frame itself)
        return w
    w[start:stop] = np.clip((seg - lo) / den, 0.0, 1.0)
    w[frame] = 1.0
    return w


def _valley(w: np.ndarray, frame: int, start: int, stop: int, step: int) -> int:
    """Index of the valley bottom walking from ``frame`` by ``step`` inside [start, stop)."""
    best, best_j = w[frame], frame
    j = frame + step
    while start <= j < stop:
        if w[j] < best:
            best, best_j = w[j], j
        elif w[j] > best + VALLEY_RISE:
            break
        j += step
    return best_j


def normalize_row(g: np.ndarray, frame: int, frame_range=None, repetitions: bool = True) -> np.ndarray:
    """Scale a Green's row ``g (F,)`` to the §3.3 falloff ``w (F,)`` in [0, 1] (see the module docstring)."""
    g = np.asarray(g, dtype=float)
    F = g.shape[0]
    frame = int(frame)
    if not 0 <= frame < F:
        raise ValueError(f"frame must be in [0, {F}), got {frame}")
    start, stop = check_frame_range(frame_range, F, frame)
    w = _scale(g, frame, start, stop)
    if not repetitions:
        lo = _valley(w, frame, start, stop, -1)
        hi = _valley(w, frame, start, stop, +1)
        left = _scale(g, frame, lo, frame + 1)    # 0 at the left valley bottom
        right = _scale(g, frame, frame, hi + 1)   # 0 at the right valley bottom
        w = np.concatenate([left[:frame], right[frame:]])
    return w


def falloff_extent(w: np.ndarray, frame: int) -> tuple[int, int]:
    """Frames ``(before, after)`` from ``frame`` to the valley bottom on each side of a falloff ``w (F,)``
    (the walk of ``repetitions=False``); at least 1 each, for :func:`.compare.spline_falloff`."""
    w = np.asarray(w, dtype=float)
    F = w.shape[0]
    lo = _valley(w, int(frame), 0, F, -1)
    hi = _valley(w, int(frame), 0, F, +1)
    return max(int(frame) - lo, 1), max(hi - int(frame), 1)


def greens_falloff(basis: GreensBasis, frame: int, frame_range=None, repetitions: bool = True) -> np.ndarray:
    """Falloff ``(F,)`` in [0, 1], 1 at ``frame``, from a precomputed basis: one row product + O(F)."""
    return normalize_row(basis.row(frame), frame, frame_range, repetitions)


def greens_distance(basis: GreensBasis, frame: int, frame_range=None) -> np.ndarray:
    """Normalised Green's pose distance of Figure 1, shape (F,): 0 at ``frame``, 1 at the most dissimilar
    frame of the range (``1 - falloff``; 1 outside the range)."""
    return 1.0 - greens_falloff(basis, frame, frame_range)


def falloff(m: Motion, frame: int, sigma: float | None = None, frame_range=None, *, repetitions: bool = True,
            num_eigs: int | None = None, basis: GreensBasis | None = None, **basis_options) -> np.ndarray:
    """The magic-wand falloff of ``m`` around ``frame`` (§3.3).

    Parameters
    ----------
    m : Motion
    frame : int
        Edited frame, 0-based.
    sigma : float or None
        Kernel width (pose-vector units); None = :func:`.laplacian.default_sigma` of the clip.
    frame_range : (start, stop) or None
        Half-open frame range to edit; weights are 0 outside it.
    repetitions : bool
        Keep repetitions of the pose (non-local propagation) or only the valley around ``frame``.
    num_eigs : int or None
        N eigenpairs in Eq. 3.
    basis : GreensBasis or None
        A precomputed basis of ``m`` (then ``sigma``, ``num_eigs`` and ``basis_options`` are ignored).
    basis_options
        Passed to :func:`.greens.greens_basis` (``method``, ``knn``, ``self_term``, ``joint_weights``, ...).
        The defaults deviate from Eqs. 1-3 as printed (reasons and measurements in :mod:`.greens`); the
        paper's formula is ``self_term=True, normalization="symmetric", chain_floor=0.0, reference="identity",
        heading="keep", flips="keep"`` (the default pose space is heading-invariant, :mod:`.pose_space`).

    Returns
    -------
    w : ndarray, shape (F,), in [0, 1], ``w[frame] == 1``
    """
    if basis is None:
        basis = greens_basis(m, sigma=sigma, num_eigs=num_eigs, **basis_options)
    elif basis.num_frames != m.num_frames:
        raise ValueError(f"basis has {basis.num_frames} frames, motion has {m.num_frames}")
    return greens_falloff(basis, frame, frame_range, repetitions)
