"""Option checks at the public boundary of the staggered-pose functions (type and range, ValueError naming
the option), and the work bounds that depend on the frame time."""
from __future__ import annotations

import math
import numbers

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
