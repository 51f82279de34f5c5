"""The falloff claims of Dean et al. 2018 stated as numbers (Figs. 1 and 4; issue 25).

* **Hops** (:func:`hop_falloffs`): the falloff of a flight's apex (the highest pelvis frame of an airborne
  stretch, :func:`..core.body.airborne_frames`) should be high at the other apexes and low at the crouches
  (the lowest pelvis frame between two flights).  Each value is the falloff's maximum within ``tolerance``
  seconds of the frame (a peak a frame or two off is the same peak).
* **Walks** (:func:`walk_falloffs`): the falloff of a mid-walk frame should be high one and two strides away
  (the same phase of later or earlier cycles) and low half a stride away (the other leg forward).  The stride
  is the lag (0.7-1.6 s) at which the pose vectors repeat best (:func:`stride_frames`); "high" is the maximum
  within 10 % of a stride of ``i +- k T``, "low" the maximum within 5 % of ``i +- T / 2``.

Goals (the issue's): high >= 0.7, low <= 0.3.  Frames 0-based.
"""
from __future__ import annotations

import numpy as np

from ..core.body import airborne_frames, pelvis_joint, up_axis
from ..core.kinematics import forward_kinematics
from ..core.motion import Motion
from .falloff import greens_falloff
from .greens import GreensBasis, greens_basis
from .pose_space import pose_vectors

__all__ = ["hop_frames", "stride_frames", "stride_contrast", "hop_falloffs", "walk_falloffs", "window_max"]


def _runs(mask) -> list[tuple[int, int]]:
    d = np.diff(np.r_[0, np.asarray(mask, dtype=np.int8), 0])
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def hop_frames(m: Motion, min_flight: float = 0.15) -> tuple[list[int], list[int]]:
    """``(apexes, crouches)``: the highest pelvis frame of every airborne stretch of at least ``min_flight``
    seconds, and the lowest pelvis frame between consecutive ones."""
    pos, _ = forward_kinematics(m)
    h = pos[:, pelvis_joint(m.skeleton)] @ up_axis(m, pos)
    flights = [(a, b) for a, b in _runs(airborne_frames(m, positions=pos)) if (b - a) * m.frame_time >= min_flight]
    apex = [a + int(np.argmax(h[a:b])) for a, b in flights]
    crouch = [b0 + int(np.argmin(h[b0:a1])) for (_, b0), (a1, _) in zip(flights[:-1], flights[1:]) if a1 > b0]
    return apex, crouch


def stride_frames(m: Motion, lo: float = 0.7, hi: float = 1.6, X=None) -> int:
    """The gait cycle in frames: the lag in ``[lo, hi]`` seconds minimising the mean pose-vector distance
    between frames that far apart (:func:`.pose_space.pose_vectors`)."""
    X = pose_vectors(m) if X is None else X
    lags = np.arange(max(1, int(round(lo / m.frame_time))), int(round(hi / m.frame_time)) + 1)
    lags = lags[lags < m.num_frames - 1]
    if not lags.size:
        raise ValueError(f"the clip ({m.duration:.2f} s) is shorter than a stride of {lo} s")
    d = [np.mean(np.linalg.norm(X[:-L] - X[L:], axis=1)) for L in lags]
    return int(lags[int(np.argmin(d))])


def stride_contrast(m: Motion, stride: int, X=None) -> float:
    """How well the poses repeat at ``stride`` frames: the mean pose-vector distance between frames a stride
    apart over the one between frames half a stride apart (0 for an exact cycle; near or above 1 when the
    poses do not repeat, e.g. a walk whose arm does something else every step).  A walk claim needs a gait:
    ``benchmarks/bench_claims.py`` states a clip with contrast > 0.5, or a stride at the end of the searched
    lags, as having none."""
    X = pose_vectors(m) if X is None else X
    T = int(stride)
    h = max(1, int(round(T / 2)))
    if T >= X.shape[0] - 1:
        return float("nan")
    return float(np.mean(np.linalg.norm(X[:-T] - X[T:], axis=1)) / np.mean(np.linalg.norm(X[:-h] - X[h:], axis=1)))


def window_max(w: np.ndarray, centre: float, half: float) -> float:
    """Maximum of ``w`` over the frames within ``half`` frames of ``centre`` (NaN outside the clip)."""
    lo, hi = int(np.ceil(centre - half - 1e-9)), int(np.floor(centre + half + 1e-9)) + 1
    lo, hi = max(lo, 0), min(hi, w.size)
    return float(w[lo:hi].max()) if hi > lo else float("nan")


def hop_falloffs(m: Motion, basis: GreensBasis | None = None, tolerance: float = 0.05, **basis_options):
    """For every apex: ``(apex frame, median falloff at the other apexes, median at the crouches, lowest at the
    other apexes, highest at the crouches)``, a list (empty without two hops)."""
    apex, crouch = hop_frames(m)
    if len(apex) < 2 or not crouch:
        return []
    basis = basis or greens_basis(m, **basis_options)
    h = tolerance / m.frame_time
    out = []
    for i in apex:
        w = greens_falloff(basis, i)
        hi = [window_max(w, j, h) for j in apex if j != i]
        lo = [window_max(w, c, h) for c in crouch]
        out.append((i, float(np.median(hi)), float(np.median(lo)), float(min(hi)), float(max(lo))))
    return out


def walk_falloffs(m: Motion, basis: GreensBasis | None = None, frames: int = 8, stride: int | None = None,
                  **basis_options):
    """For ``frames`` mid-walk frames spread over one stride around the clip's middle: ``(frame, lowest
    falloff one / two strides away (either side, where inside the clip), highest half a stride away)``; and
    the stride in frames.  Returns ``(rows, stride)``."""
    T = stride_frames(m) if stride is None else int(stride)
    basis = basis or greens_basis(m, **basis_options)
    F = m.num_frames
    rows = []
    for i in np.linspace(F / 2 - T / 2, F / 2 + T / 2, frames).round().astype(int):
        w = greens_falloff(basis, int(i))
        high = [window_max(w, i + s * k * T, 0.1 * T) for k in (1, 2) for s in (1, -1)
                if 0 <= i + s * k * T - 0.1 * T and i + s * k * T + 0.1 * T <= F - 1]
        low = [window_max(w, i + s * T / 2, 0.05 * T) for s in (1, -1) if 0 <= i + s * T / 2 <= F - 1]
        rows.append((int(i), min(high) if high else float("nan"), max(low)))
    return rows, T
