"""Linear (spline-style) baseline warp through keytimes (Hsu et al. 2007, §4.1: the comparison baseline,
what motion warping [WP95] gives when only duration keys are set)."""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from .postprocess import apply_warp, meet_keytimes, parse_keytimes

__all__ = ["linear_warp", "linear_warp_curve", "validate_num_frames", "check_output_size", "MAX_OUTPUT_BYTES"]

MAX_OUTPUT_BYTES = 1 << 30   # refuse (ValueError) a warped Motion larger than this


def validate_num_frames(num_frames) -> int:
    if isinstance(num_frames, bool) or not isinstance(num_frames, (int, np.integer)) or num_frames < 2:
        raise ValueError(f"num_frames must be an integer >= 2, got {num_frames!r}")
    return int(num_frames)


def check_output_size(m: Motion, num_frames: int) -> None:
    """ValueError naming ``num_frames`` (before allocating) when the warped motion would exceed
    :data:`MAX_OUTPUT_BYTES`: ``num_frames x J`` quaternions (+ translations) of float64."""
    per_frame = 8 * (4 * m.num_joints + 3 + (3 * m.num_joints if m.local_translations is not None else 0))
    need = int(num_frames) * per_frame
    if need > MAX_OUTPUT_BYTES:
        raise ValueError(f"num_frames={num_frames}: the warped motion would need {need / 2**30:.1f} GiB, more than "
                         f"the {MAX_OUTPUT_BYTES / 2**30:.0f} GiB limit (at most "
                         f"{MAX_OUTPUT_BYTES // per_frame} frames of {m.num_joints} joints); ask for fewer frames "
                         "or a longer frame time (m.resample(frame_time))")


def linear_warp_curve(in_duration: float, num_frames: int, frame_time: float, keytimes=None) -> np.ndarray:
    """Piecewise-linear warp ``(num_frames,)`` (input seconds of each output frame, ``frame_time`` apart)
    through the keytimes ``[(input_time_s, output_time_s), ...]`` and the end points."""
    num_frames = validate_num_frames(num_frames)
    out_duration = (num_frames - 1) * frame_time
    keys = parse_keytimes(keytimes, in_duration, out_duration)
    t_out = np.arange(num_frames) * frame_time
    warp = np.interp(t_out, keys[:, 1], keys[:, 0])
    # keys between output frames: the interpolated warp passes through them exactly (:func:`meet_keytimes`)
    return meet_keytimes(warp, frame_time, keys) if keys.shape[0] > 2 else warp


def linear_warp(m: Motion, num_frames: int, keytimes=None, adaptive: bool = False):
    """Retime ``m`` to ``num_frames`` frames (same frame time) with a piecewise-linear warp.

    Parameters
    ----------
    m : Motion with n frames
    num_frames : output frame count (any value >= 2: compression or expansion)
    keytimes : list of (input_time_s, output_time_s) pairs or None; end points implied
    adaptive : apply the adaptive compression smoothing of §3.4 (off by default: the plain baseline)

    Returns
    -------
    out : Motion with ``num_frames`` frames
    warp : (num_frames,) input time in seconds of each output frame
    """
    if not isinstance(m, Motion):
        raise ValueError(f"m must be a Motion, got {type(m).__name__}")
    if m.num_frames < 2:
        raise ValueError(f"m must have at least 2 frames to be warped, got {m.num_frames}")
    num_frames = validate_num_frames(num_frames)
    check_output_size(m, num_frames)
    warp = linear_warp_curve(m.duration, num_frames, m.frame_time, keytimes)
    return apply_warp(m, warp, m.frame_time, adaptive=adaptive), warp
