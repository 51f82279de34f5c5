"""How a warp treats parts of its input: the measures the paper's §4.1 claim is stated in (issue 25).

*Airborne speed* (:func:`airborne_speed`): the speed ``d(input time) / d(output time)`` over the input frames
where both feet are off the ground (:func:`..core.body.airborne_frames`), i.e. the airborne input time
divided by the output time spent showing it.  1 = the flights play in real time; a linear warp to a
fraction ``c`` of the length plays them at ``1 / c`` (the overall compression, :func:`overall_speed`).  The
claim of §4.1 ("ballistic activities preserved", V1-V5): with the input as its own reference, airborne speed
within 0.85-1.15 and at least twice as close to 1 as the linear warp's.

Warps are ``(m,)`` input seconds of output frames ``frame_time`` apart, increasing (:mod:`.postprocess`).
"""
from __future__ import annotations

import numpy as np

from ..core.body import airborne_frames

__all__ = ["intervals", "speed_inside", "airborne_speed", "overall_speed", "airborne_frames"]


def intervals(mask) -> list[tuple[int, int]]:
    """Runs of True in a (F,) bool mask as half-open ``(start, stop)`` frame pairs."""
    d = np.diff(np.r_[0, np.asarray(mask, dtype=np.int8), 0])
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def speed_inside(warp, frame_time: float, mask, input_frame_time: float) -> float:
    """Input seconds of the frames in ``mask`` (F,) divided by the output seconds the warp spends on them.

    Input frame ``f`` stands for the input times ``[(f - 1/2) ft, (f + 1/2) ft]`` (clipped to the clip); the
    output time spent there is exact for the piecewise-linear warp between its samples.  NaN when the mask is
    empty or the warp never reaches it.
    """
    w = np.asarray(warp, dtype=float).reshape(-1)
    mask = np.asarray(mask, dtype=bool).reshape(-1)
    if w.size < 2 or not mask.any():
        return float("nan")
    t_out = np.arange(w.size) * float(frame_time)
    end = (mask.size - 1) * float(input_frame_time)
    t_in = out = 0.0
    for a, b in intervals(mask):
        lo = max(0.0, (a - 0.5) * input_frame_time)
        hi = min(end, (b - 0.5) * input_frame_time)
        if hi <= lo:
            continue
        t_in += hi - lo
        out += float(np.interp(hi, w, t_out) - np.interp(lo, w, t_out))
    return t_in / out if out > 0 else float("nan")


def airborne_speed(warp, frame_time: float, motion, airborne=None) -> float:
    """Speed of ``warp`` over ``motion``'s airborne frames (module docstring); ``airborne`` (F,) bool defaults
    to :func:`..core.body.airborne_frames`.  NaN for a clip without flight."""
    mask = airborne_frames(motion) if airborne is None else airborne
    return speed_inside(warp, frame_time, mask, motion.frame_time)


def overall_speed(warp, frame_time: float) -> float:
    """Input seconds per output second over the whole warp (``1 / c`` for a compression to a fraction c)."""
    w = np.asarray(warp, dtype=float).reshape(-1)
    return float((w[-1] - w[0]) / ((w.size - 1) * float(frame_time)))
