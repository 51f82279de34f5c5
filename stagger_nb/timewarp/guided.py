"""Guided time warping (Hsu, da Silva, Popović 2007): retime a motion to keytimes while matching the local
timing of a reference motion.

Pipeline, split so that an interactive editor re-runs only the cheap tail:

1. :func:`prepare_warp` (the expensive head, once per input / reference / skip / upsampling): pose features
   (§3.2), the kNN local-score table of every admissible triple (eq. 2). Returns :class:`WarpTables`.
2. :func:`solve_warp` (per target length / keytimes): the constrained shortest path (§3.3), optionally with the
   coarse-to-fine heuristic. Returns :class:`WarpSolution` (selected frames, their input times, the cost).
3. :func:`.postprocess.smooth_warp` + :func:`.postprocess.apply_warp` (§3.4): moving-average smoothing of the
   discrete warp, slerp resampling, adaptive smoothing under compression.

:func:`guided_warp` runs all three. Output frames are ``m.frame_time`` apart (the output plays at the input's
frame rate); the reference is resampled to that frame time so velocities per output frame compare. Expansion
(``num_frames > n``) upsamples the input by an integer factor first and compresses that (§3.1, §4.3); a backward
warp reverses the input (``reverse=True``).

Keytimes: a list of ``(input_time_s, output_time_s)`` pairs, end points implied; the search pins each at the
nearest (upsampled) input frame and output frame, and the final warp meets them exactly
(:func:`.postprocess.meet_keytimes`). See :mod:`.postprocess`.

Modules: :mod:`.tables` (the head: :func:`prepare_warp`, sizing, :func:`slice_tables`), :mod:`.tables_cache`
(:func:`cached_prepare_warp`), :mod:`.solve` (the search: :func:`solve_warp`, the speed penalty) and this one
(:func:`guided_warp`); every name stays importable from here.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion
from .features import prefilter_frames
from .linear import check_output_size, validate_num_frames
from .objective import validate_skip
from .postprocess import apply_warp, meet_keytimes, parse_keytimes, smooth_warp
from .solve import (
    FREE_OBJECTIVE,
    PENALTY_FREE_RATIO,
    PENALTY_SCALES,
    SPEED_PENALTY,
    WEIGHTINGS,
    WarpSolution,
    _check_speed_penalty,
    penalty_unit,
    solve_warp,
    speed_change_penalty,
)
from .tables import (
    AUTO_APPROX_PAIRS,
    DEFAULT_CANDIDATES,
    FREE_K,
    FREE_SEARCH_TIME,
    FREE_UPSAMPLE,
    MAX_SEARCH_FRAMES,
    MAX_WARP_BYTES,
    WarpTables,
    _check_warp_size,
    _same_content,
    _validate_upsample,
    free_length_search,
    prepare_warp,
    required_upsample,
    reverse_motion,
    slice_tables,
    warp_memory,
)
from .tables_cache import TABLES_CACHE, TABLES_CACHE_BYTES, cached_prepare_warp, clear_tables_cache

__all__ = ["WarpTables", "WarpSolution", "prepare_warp", "slice_tables", "solve_warp", "guided_warp",
           "required_upsample", "reverse_motion", "warp_memory", "MAX_WARP_BYTES", "FREE_UPSAMPLE", "FREE_K",
           "SPEED_PENALTY", "SMOOTHING", "MAX_SEARCH_FRAMES", "cached_prepare_warp", "clear_tables_cache",
           "TABLES_CACHE", "TABLES_CACHE_BYTES", "FREE_OBJECTIVE", "free_length_search", "FREE_SEARCH_TIME",
           "penalty_unit", "PENALTY_SCALES", "WEIGHTINGS", "speed_change_penalty", "PENALTY_FREE_RATIO",
           "AUTO_APPROX_PAIRS"]


SMOOTHING = 0.2            # default smoothing, seconds (applied twice: a triangular kernel, see guided_warp)


def guided_warp(m: Motion, reference: Motion, num_frames: int | None, skip: int = 8, keytimes=None, *,
                upsample: int | None = None, reverse: bool = False, backward: bool | None = None, k: int | None = None,
                weights=(1.0, 1.0, 1.0), joint_weights=None, prefilter: float = 0.1, time_unit: float = 1.0 / 30.0,
                coarse: int | None = None, band: float | None = None, speed_penalty: float = SPEED_PENALTY,
                smoothing: float = SMOOTHING, adaptive: bool = True, knn: str = "auto",
                candidates: int = DEFAULT_CANDIDATES, tables: WarpTables | None = None,
                free_objective: str = FREE_OBJECTIVE, frame: str = "pelvis_height", end_terms: bool = True,
                penalty_scale: str = "doubling", reverse_reference: bool | None = None,
                weighting: str = "input_time", penalty_free_ratio: float | None = None, progress=None,
                solution: WarpSolution | None = None):
    """Retime ``m`` to ``num_frames`` frames through ``keytimes`` so its local timing matches ``reference``.

    What an editor can ask for (issue 11 item 5):

    * **compression / expansion** to ``num_frames`` (``m > n`` upsamples the input, §3.1, §4.3);
    * **same-duration style warp**: ``num_frames == n`` with a reference that differs from ``m`` upsamples
      by 2 automatically (:func:`required_upsample`), so the timing changes while the length does not.
      With ``m`` itself as reference it is the identity (the only complete subsequence, §3.1), unless an
      explicit ``upsample > 1`` is given;
    * **free length**: ``num_frames=None`` (§3.3, V8) and the output is as long as the reference's timing
      makes it (speeds 1/4 .. skip/4 x: :func:`free_length_search`, the input upsampled 4x at 30 Hz, searched
      every 1/30 s at 120 Hz); no keytimes. Two objectives (measured at 30 Hz, ``benchmarks/bench_claims.py``):
      ``free_objective="input_time"`` (default, issue 25), the local score integrated over input time
      (:func:`.dp.input_time_dp`: each stretch of input played at the speed whose velocities best match the
      reference at that pose, whatever the number of frames): against a 1.5x faster / slower copy of the clip
      0.667-0.70 / 1.35-1.45 of the length on all 17 clips; ``"mean"`` (the previous default), the least mean
      score per output frame (:func:`.dp.mean_cost_dp`), lingers where the score is low -- still poses:
      0.82-0.89 / 1.89-2.05 on CMU 131_01, bandai_kick, MocapBank get-down.  Neither times poses the reference
      lacks: V8 (one hop with its flight in 0.4x slow motion as the reference of all of CMU 01_01) plays the
      flights at 0.33x with ``"input_time"`` but the turn-around and standing, which the hop does not have,
      slow down too (0.41x; ``"mean"`` 0.45 / 0.83); at a chosen length V8 holds with either;
    * **backward**: ``backward=True`` (alias ``reverse=True``) plays ``m`` backwards, timed like the
      reference played backwards (``reverse_reference``, see :func:`prepare_warp`); keytimes stay on the
      original input clock;
    * **keytimes**: ``[(input_time_s, output_time_s), ...]``, end points implied, met exactly by the
      interpolated warp also between output frames (:func:`.postprocess.meet_keytimes`); a keytime anywhere
      inside the clip gives a warp: where a segment between keys plays slower than real time the input is
      upsampled (:func:`required_upsample`), as the paper's expansions are.

    The defaults deviate from the paper where its form failed the §4.1 claims on real clips (issue 25; each is
    a flag, measured where it is defined): ``frame="pelvis_height"`` (:mod:`.features`),
    ``weighting="input_time"``, ``end_terms=True``, ``penalty_scale="doubling"``, ``penalty_free_ratio=1.5``
    (:func:`solve_warp`, :func:`speed_change_penalty`).  The paper's objective: ``frame="pelvis",
    weighting="output", end_terms=False, speed_penalty=0``.

    Parameters
    ----------
    m : input Motion (n >= 2 frames, ``frame_time`` seconds apart); the output has the same frame time
    reference : Motion with the same joints giving the desired timing (``m`` itself to preserve timing, §4.1)
    num_frames : output frame count m (``n / skip <= m``; ``m > n`` upsamples), or None: free length
    skip : s, largest input-frame step per output frame (the fastest playback is s times real time)
    keytimes : list of (input_time_s, output_time_s) pairs or None; end points ``(0, 0)`` and
        ``(m.duration, (num_frames - 1) * frame_time)`` are implied; both times strictly increasing
    upsample : integer upsampling of the input (default :func:`required_upsample`); 1 forbids expansion
    reverse, backward : backward warp (play the input backwards); ``backward`` overrides ``reverse`` if given
    k : kNN count of eq. (2); default 3 (the paper), :data:`FREE_K` = 1 for free length (measured on CMU 01_01
        at 30 Hz, FREE_UPSAMPLE = 4, free length / n for a self / 1.5x slower / 1.5x faster reference: k=1
        1.000 / 1.69 / 0.669 (``free_objective="input_time"``: 1.000 / 1.40 / 0.669); with k=3 1.39 / 1.87 /
        1.11: averaging three neighbours favours slow paths whose poses fall between reference frames)
    free_objective : "input_time" (default) or "mean", the free-length objective (see above)
    frame, end_terms, reverse_reference : objective options, see :func:`prepare_warp`
    penalty_scale, weighting, penalty_free_ratio : search options, see :func:`solve_warp`
    weights, joint_weights, prefilter, time_unit, knn, candidates : objective options, see
        :func:`prepare_warp` (long takes: ``knn="auto"`` switches to the approximate kNN beyond ~3,000 x 3,000
        frames and the search to the coarse-to-fine heuristic beyond 6,000; 20,000 frames take ~20-30 s)
    coarse, band, speed_penalty : search options, see :func:`solve_warp`
    smoothing : seconds, moving-average window applied twice to the discrete warp's speed (§3.4; a triangular
        kernel ``2 smoothing`` wide); 0 disables. With the default speed penalty, measured as
        :func:`.postprocess.speed_jumps` (|change of log speed| per 1/30 s) at 65 % length, self reference:
        95th percentile 0.090 / max 0.166 on CMU 01_01, 0.108 / 0.147 on CMU 131_01 (paper objective with a
        0.1 s box: 0.69 / 1.20 and 0.42 / 1.20); the goal is <= 0.12 / <= 0.25.
    adaptive : adaptive smoothing of the resampled motion under compression (§3.4)
    tables : precomputed :func:`prepare_warp` result to reuse (without it, the tables of the last few calls are
        reused when the input, reference and objective options are the same: :func:`cached_prepare_warp`); then
        ``reference``, ``skip``, ``upsample``,
        ``reverse`` and the objective options are the ones the tables were prepared with (the editor's cheap
        tail: cache one table per upsampling factor, :func:`required_upsample` says which one a length needs)
    progress : callable(fraction in [0, 1]) or None
    solution : a :func:`solve_warp` result of ``tables`` for ``num_frames`` and ``keytimes`` with the search
        options given here, used instead of searching again (§3.3; a session caches them per length, so a
        duration slider's step back, or one solved ahead in the background, runs only §3.4)

    Returns
    -------
    out : Motion with ``num_frames`` frames (the warped motion)
    warp : (num_frames,) input time in seconds of each output frame (the smoothed warp curve)

    Raises ``ValueError`` naming the parameter: ``m`` with fewer than 2 frames, ``num_frames`` out of reach,
    a search larger than :data:`MAX_WARP_BYTES` (before allocating; the message says how to shrink it).
    """
    if not isinstance(m, Motion):
        raise ValueError(f"m must be a Motion, got {type(m).__name__}")
    if m.num_frames < 2:
        raise ValueError(f"m must have at least 2 frames to be warped, got {m.num_frames}")
    if num_frames is not None:
        num_frames = validate_num_frames(num_frames)
        check_output_size(m, num_frames)
    if isinstance(smoothing, bool) or not isinstance(smoothing, (int, float, np.integer, np.floating)) \
            or not np.isfinite(smoothing) or smoothing < 0:
        raise ValueError(f"smoothing must be a non-negative number of seconds, got {smoothing!r}")
    _check_speed_penalty(speed_penalty)
    if free_objective not in ("input_time", "mean"):
        raise ValueError(f"free_objective must be 'input_time' or 'mean', got {free_objective!r}")
    if penalty_scale not in PENALTY_SCALES:
        raise ValueError(f"penalty_scale must be one of {PENALTY_SCALES}, got {penalty_scale!r}")
    if weighting not in WEIGHTINGS:
        raise ValueError(f"weighting must be one of {WEIGHTINGS}, got {weighting!r}")
    if backward is not None:
        reverse = bool(backward)
    if k is None:
        k = FREE_K if num_frames is None else 3
    if tables is None:
        if not isinstance(reference, Motion):
            raise ValueError(f"reference must be a Motion, got {type(reference).__name__}")
        out_step = 1
        if upsample is None:
            if num_frames is None:
                u, out_step = free_length_search(m.frame_time)
            else:
                differs = num_frames == m.num_frames and not _same_content(m, reference)
                u = required_upsample(m.num_frames, num_frames, differs, keytimes=keytimes,
                                      frame_time=m.frame_time, skip=validate_skip(skip))
        else:
            u = _validate_upsample(upsample)
        r = max(2, int(round(reference.duration / m.frame_time)) + 1)
        _check_warp_size(m.num_frames, r, validate_skip(skip), u, 3 * m.num_joints,
                         "num_frames" if upsample is None and u > 1 else ("upsample" if u > 1 else "m"),
                         knn if knn in ("exact", "approx") else "auto", candidates)
        if num_frames is not None and num_frames > (m.num_frames - 1) * u + 1:
            raise ValueError(f"num_frames={num_frames} is more than the {m.num_frames} input frames and "
                             f"upsample={u} gives only {(m.num_frames - 1) * u + 1}: expansion needs upsampling")
        head = None if progress is None else (lambda f: progress(0.9 * f))
        tables = cached_prepare_warp(m, reference, skip, u, reverse=reverse, k=k, weights=weights,
                                     joint_weights=joint_weights, prefilter=prefilter, time_unit=time_unit,
                                     knn=knn, candidates=candidates, frame=frame, end_terms=end_terms,
                                     out_step=out_step, reverse_reference=reverse_reference, progress=head)
    elif tables.motion is not m and (tables.motion.num_frames != m.num_frames
                                     or tables.motion.num_joints != m.num_joints):
        raise ValueError("tables were prepared for a different input motion")
    tail = None if progress is None else (lambda f: progress(0.9 + 0.1 * f))
    if solution is not None:
        _check_solution(solution, tables, num_frames)
        sol = solution
    else:
        sol = solve_warp(tables, num_frames, keytimes, coarse=coarse, band=band, speed_penalty=speed_penalty,
                         free_objective=free_objective, penalty_scale=penalty_scale, weighting=weighting,
                         penalty_free_ratio=penalty_free_ratio, progress=tail)
    ft = m.frame_time
    times, pinned = sol.times, sol.pinned
    if sol.out_step > 1:     # a free-length search at a coarser output rate: every output frame, linearly
        r = sol.out_step
        times = np.interp(np.arange((times.size - 1) * r + 1), np.arange(times.size) * r, times)
        pinned = tuple(p * r for p in pinned)
    window = prefilter_frames(smoothing, ft) if smoothing else 1
    warp = smooth_warp(times, window, pinned=pinned, passes=2)
    warp = np.clip(warp, 0.0, m.duration)
    if keytimes is not None and len(keytimes):
        warp = meet_keytimes(warp, ft, parse_keytimes(keytimes, m.duration, (warp.size - 1) * ft))
    out = apply_warp(m, warp, ft, adaptive=adaptive)
    if progress is not None:
        progress(1.0)
    return out, warp


def _check_solution(sol, tables: WarpTables, num_frames: int | None) -> None:
    """ValueError naming ``solution`` unless it is a :class:`WarpSolution` that ``tables`` can have given for
    ``num_frames`` (its frame count, output step and searched-frame range)."""
    if not isinstance(sol, WarpSolution):
        raise ValueError(f"solution must be a WarpSolution (solve_warp's result), got {type(sol).__name__}")
    frames = np.asarray(sol.frames)
    if sol.out_step != tables.out_step or frames.ndim != 1 or frames.size < 2 \
            or (num_frames is not None and frames.size != num_frames) or frames[0] != 0 \
            or frames[-1] != tables.n_up - 1:
        raise ValueError(f"solution: {frames.size} frames over [{frames[0] if frames.size else '-'}, "
                         f"{frames[-1] if frames.size else '-'}] at output step {sol.out_step} is not a search of "
                         f"these tables ({tables.n_up} searched frames, output step {tables.out_step}) for "
                         f"num_frames={num_frames}")
