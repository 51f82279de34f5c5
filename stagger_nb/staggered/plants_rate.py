"""A turn-rate allowance inside plants (the contact layer, :mod:`stagger_nb.staggered.plants`): a held knee bends
no faster from one plant frame to the next than the source ever turns it plus :data:`KNEE_MARGIN` (within what
the pop cap allows, :mod:`.plants_pops`), by lowering the leg's reach where the plant would ask for more; a held
toe's heel lift changes by at most the pop cap's margin a frame.

Near full extension a knee's bend is very sensitive to the hip-ankle distance (the bend grows like the square
root of the distance given up): a plant whose first frames find the edited leg almost straight while the hip
comes quickly over the foot asks the knee to bend 10-17 degrees in one frame (xia_depressed_run sliced
mid-stance, strong edit). The pop cap then had to free the plant's first frames and ramp the knee there, which
let the foot off its plant by 2-6 cm. Here, instead, each plant's knee bend is raised to the smallest profile
at or above it that changes by at most the allowance a frame (the upper envelope of cones of that slope), and
the reach of each frame lowered to the distance of that bend: the root then comes down by what that needs
(a few millimetres: near extension a small drop buys a large bend) and the plant is still met exactly
(Kovar, Schreiner & Gleicher 2002, §4: the plants met exactly, the root adjusted only as the plants need;
Coleman et al. 2008, §3: the IK displacement only where a constraint is active, smoothly).
"""
from __future__ import annotations

import numpy as np

from .plants_carry import _source_frames

#: degrees a frame a held knee's bend may change beyond the source's fastest turn of the knee: half the pop cap's
#: margin (:data:`~.plants_pops.POP_MARGIN`), the other half left for what the bend does not measure (the edit's
#: own turn of the knee about other axes, the root's shift). Measured on benchmarks/bench_edit_quality.py's
#: derived clips (mild / moderate / strong of 118; 112 / 112 / 110 without the allowance): 2.5 (the whole
#: margin) 115 / 114 / 114, 1.25: 116 / 115 / 116 (the root lowered up to 0.5 cm more where the clips passed
#: already), 0: 116 / 115 / 116 (up to 1 cm).
KNEE_MARGIN = 1.25
_MIN_SLOW = 0.25     # the slowest a take-off is replayed, for a knee the edit slowed against its hip


def _segments(frames: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Index ``(n,)`` of the run of consecutive ``frames`` of one group each row belongs to (0, 1, ...)."""
    if frames.size == 0:
        return np.zeros(0, np.int64)
    new = np.r_[True, (np.diff(frames) != 1) | (np.diff(groups) != 0)]
    return np.cumsum(new) - 1


def rate_envelope(x: np.ndarray, rate, seg: np.ndarray) -> np.ndarray:
    """The smallest profile ``>= x (n,)`` that changes by at most ``rate`` from one row to the next inside each
    run ``seg (n,)`` (:func:`_segments`): ``max_k x[k] - (the rates between k and n)`` over the rows ``k`` of the
    run. ``rate``: a number, or ``(n,)`` with ``rate[i]`` the step allowed from row ``i - 1`` to row ``i``."""
    n = x.size
    if n == 0:
        return x.copy()
    r = np.broadcast_to(np.asarray(rate, dtype=float), (n,))
    c = np.r_[0.0, np.cumsum(r[1:])]                          # the allowance from row 0 to each row
    big = 4.0 * (float(np.ptp(x)) + float(c[-1]) + 1.0)     # each run starts above every earlier one
    off = seg * big
    fwd = np.maximum.accumulate(x + c + off) - off - c
    cb = c[-1] - c                                            # the allowance from each row to the last
    roff = (seg.max() - seg) * big
    bwd = (np.maximum.accumulate((x + cb + roff)[::-1]) - (roff + cb)[::-1])[::-1]
    return np.maximum(np.maximum(fwd, bwd), x)


def knee_rate_reach(hip: np.ndarray, target: np.ndarray, l1: np.ndarray, l2: np.ndarray, reach: np.ndarray,
                    frames: np.ndarray, groups: np.ndarray, rate) -> np.ndarray:
    """The reach ``(n,)`` (<= ``reach``) that keeps a held knee's bend changing by at most ``rate`` radians a
    frame (a number or per row, :func:`rate_envelope`) over each plant's consecutive ``frames`` (``groups``: the
    plant of each row), for ``target (n, 3)``
    from ``hip (n, 3)`` with thigh and shin lengths ``l1``, ``l2`` ``(n,)`` (module docstring)."""
    d = np.minimum(np.linalg.norm(target - hip, axis=-1), reach)
    lo = np.abs(l1 - l2)
    hi = l1 + l2
    d = np.clip(d, lo, hi)
    # the bend (0: straight) that puts the ankle at distance d: d^2 = l1^2 + l2^2 + 2 l1 l2 cos(bend)
    c = np.clip((d * d - l1 * l1 - l2 * l2) / np.maximum(2.0 * l1 * l2, 1e-300), -1.0, 1.0)
    bend = np.arccos(c)
    want = rate_envelope(bend, rate, _segments(frames, groups))
    if not np.any(want > bend + 1e-9):
        return reach
    d_new = np.sqrt(np.maximum(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * np.cos(want), 0.0))
    return np.where(want > bend + 1e-9, np.minimum(reach, d_new), reach)


def pivot_rate(off: np.ndarray, to_hip: np.ndarray, angle: np.ndarray, limit: float, frames: np.ndarray,
               groups: np.ndarray, rate: float) -> np.ndarray:
    """Rotation vectors ``(n, 3)`` of a held toe's heel lift (the foot turned about the toe, toe -> ankle
    ``off (n, 3)`` towards the hip, toe -> hip ``to_hip (n, 3)``) whose ``angle (n,)`` (radians, the least that
    lets the leg reach) changes by at most ``rate`` a frame over each plant's consecutive ``frames``: the upper
    envelope (:func:`rate_envelope`; a heel lifted a little more than needed, and sooner, never less), at most
    ``limit`` and never past the hip's direction. A lift that relaxes as the hip comes over the toe turned the
    foot 7-9 degrees a frame at 120 Hz (xia_angry_run, s = +0.1), which the pop cap then ramped by letting the
    toe off its plant (2.3 cm)."""
    axis = np.cross(off, to_hip)
    s = np.linalg.norm(axis, axis=-1)
    c = np.einsum("ni,ni->n", off, to_hip)
    most = np.minimum(np.arctan2(s, c), limit)
    want = np.minimum(rate_envelope(angle, rate, _segments(frames, groups)), most)
    want = np.maximum(want, angle)
    return axis / np.maximum(s, 1e-300)[:, None] * want[:, None]


def _knee_lag(tables, t0: float, ft: float, ft_s: float, lim, ends: np.ndarray, nb: int, F: int) -> np.ndarray:
    """``(E,)``: per plant end (edited frames ``ends``), how fast the knee's own clock runs over the ``nb``
    frames after it against the hip's (the mean slopes of their inverse warps there), in [_MIN_SLOW, 1]: 1
    where the knee keeps the hip's pace or runs ahead of it, and without a timing edit."""
    if tables is None or nb < 1 or not ends.size:
        return np.ones(ends.size)
    a = np.minimum(ends + nb, F - 1)
    frames = np.r_[ends, a].astype(float)
    knee = _source_frames(tables, t0, ft, ft_s, lim.mid, frames)
    hip = _source_frames(tables, t0, ft, ft_s, lim.upper, frames)
    n = ends.size
    dk, dh = knee[n:] - knee[:n], hip[n:] - hip[:n]
    lag = np.where((a > ends) & (dh > 0), dk / np.where(dh > 0, dh, 1.0), 1.0)
    return np.clip(lag, _MIN_SLOW, 1.0)
