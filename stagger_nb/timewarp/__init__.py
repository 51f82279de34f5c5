"""Guided time warping (Hsu, da Silva, Popović 2007): retime a motion to keytimes while matching a reference
motion's local timing. Pure functions on Motions and arrays; see :mod:`.guided` for the pipeline.

Public names::

    out, warp = guided_warp(m, reference, num_frames, skip=8, keytimes=None)   # warp: (num_frames,) input s
    out, warp = linear_warp(m, num_frames, keytimes=None)                      # the spline-style baseline
    tables = prepare_warp(m, reference, skip=8, upsample=1)   # expensive head (features + kNN scores), cache it
    out, warp = guided_warp(m, reference, num_frames, keytimes=..., tables=tables)   # cheap tail

Keytimes are ``[(input_time_s, output_time_s), ...]``; the end points are implied.

Editor capabilities (see :func:`guided_warp`): same-duration style warps (``num_frames == n`` with a different
reference upsamples x2), free length (``num_frames=None``), backward warps (``backward=True``), keytimes.
Long takes: ``knn="auto"`` switches to an approximate kNN (:func:`.objective.candidate_scores`) and the
coarse-to-fine search; beyond ``MAX_SEARCH_FRAMES`` or ``MAX_WARP_BYTES`` (:func:`warp_memory`) a ValueError
names the parameter and the remedy before anything is allocated.  :func:`speed_jumps` measures playback pops.
The torso frame of the features is the pelvis (:func:`stagger_nb.core.body.pelvis_joint`), not joint 0.

Issue 25 (the papers' claims on real clips): the defaults deviate from the paper where its form failed §4.1
(features with the pelvis's height, input-time weighting, end terms, the speed penalty's unit and free ratio;
the flags and measurements are in :func:`guided_warp`, :func:`solve_warp` and :mod:`.features`); free length
integrates the score over input time; backward warps reverse the reference too; keytimes are met exactly and
anywhere inside the clip (:func:`required_upsample` with ``keytimes=``).  Measures of the claims:
:func:`airborne_speed` (:mod:`.measures`).  An editor that precomputes tables: duration changes use
``prepare_warp(m, ref, skip, required_upsample(n, num_frames, keytimes=..., frame_time=..., skip=...))``;
free length and backward use ``u, r = free_length_search(m.frame_time)`` and
``prepare_warp(m, ref, skip, u, k=FREE_K, out_step=r, reverse=...)``; a duration slider's next lengths:
``sweep = length_sweep(tables, m_lo, m_hi)`` then ``solve_warp(tables, m, sweep=sweep)`` (:mod:`.sweep`, the
same frames as without it).
"""
from .dp import constrained_dp, input_time_dp, mean_cost_dp, path_cost, unconstrained_dp, warp_bounds
from .features import pose_features, reference_features, triple_features
from .guided import (
                     FREE_K,
                     FREE_UPSAMPLE,
                     WarpSolution,
                     WarpTables,
                     cached_prepare_warp,
                     clear_tables_cache,
                     free_length_search,
                     guided_warp,
                     penalty_unit,
                     prepare_warp,
                     required_upsample,
                     reverse_motion,
                     slice_tables,
                     solve_warp,
                     warp_memory,
)
from .linear import linear_warp, linear_warp_curve
from .measures import airborne_frames, airborne_speed, intervals, overall_speed, speed_inside
from .objective import end_scores, knn_scores
from .postprocess import (
                     apply_warp,
                     meet_keytimes,
                     parse_keytimes,
                     smooth_warp,
                     speed_at_input_times,
                     speed_jumps,
                     warp_speed,
)
from .solve import length_sweep
from .sweep import LengthSweep

__all__ = ["guided_warp", "linear_warp", "linear_warp_curve", "prepare_warp", "solve_warp", "WarpTables",
           "WarpSolution", "required_upsample", "reverse_motion", "knn_scores", "constrained_dp",
           "unconstrained_dp", "warp_bounds", "path_cost", "pose_features", "reference_features",
           "triple_features", "apply_warp", "smooth_warp", "warp_speed", "speed_at_input_times", "parse_keytimes",
           "speed_jumps", "warp_memory", "mean_cost_dp", "FREE_K", "FREE_UPSAMPLE", "slice_tables",
           "cached_prepare_warp", "clear_tables_cache", "input_time_dp", "free_length_search", "penalty_unit",
           "airborne_frames", "airborne_speed", "intervals", "overall_speed", "speed_inside", "end_scores",
           "meet_keytimes", "length_sweep", "LengthSweep"]
