"""The constants of :mod:`stagger_nb.quality`: the body every length is expressed on, the detail's band and grid, the
source contacts' shrink, the report's row fields."""
from __future__ import annotations

#: The body every length is expressed on (cm): the figures read as on a 170 cm person.
BODY_CM = 170.0


#: Percentile of the per-frame vertical extent taken as the body height (see :func:`body_height`).
HEIGHT_PERCENTILE = 90.0


#: Gaussian σs (seconds) of the band-pass whose output is the "detail" of a joint curve: what a 0.08 s
#: low-pass removes (the wiggles), less what a 0.015 s low-pass removes (frame-level jitter, and the smoothing
#: that reading a curve between its frames does: neither is visible detail).
DETAIL_SIGMA = 0.08


DETAIL_FINE = 0.015


#: Highest sampling rate (Hz) of the detail grid: the source's frames, every k-th one for a faster clip (the
#: band of the detail, roughly 2-10 Hz, is far below the grid's Nyquist frequency).
DETAIL_RATE = 60.0


#: Elements per temporary array in the detail's slerp and velocity (blocks of joints stay in cache).
_BLOCK = 8192


#: Seconds cut from each end of a source contact for ``foot_travel_source`` (heel strike and toe-off).
SOURCE_SHRINK = 0.1


#: Added pops (degrees) and jumps (cm) below this are rounding (e.g. of a frame-rate ratio): 0.
_ROUNDING = 1e-9


#: The fields of :meth:`QualityReport.to_row`, in order.
ROW_FIELDS = ("ok", "summary", "foot_travel", "foot_height", "floor", "pelvis", "pelvis_vs_baseline", "added_pop",
              "added_pop_joint", "knots_out_of_order", "detail", "moved")


#: Tolerance (cm) of "no more sliding than without the layer" (rounding of the two evaluations).
_BASELINE_SLACK = 0.1
