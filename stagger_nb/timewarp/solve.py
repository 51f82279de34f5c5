"""The cheap tail's search (Hsu et al. 2007, §3.3): :func:`solve_warp` runs the constrained shortest path over
prepared :class:`~.tables.WarpTables` for a target length and keytimes (optionally coarse-to-fine), with the
speed-change penalty (:func:`speed_change_penalty`, :func:`penalty_unit`) and the score weighting. Returns a
:class:`WarpSolution`."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dp import constrained_dp, input_time_dp, mean_cost_dp, path_cost, step_weights, validate_keys
from .linear import validate_num_frames
from .objective import candidate_scores, knn_scores
from .postprocess import parse_keytimes
from .sweep import LengthSweep
from .tables import WarpTables, required_upsample

FREE_OBJECTIVE = "input_time"   # default free_objective (see guided_warp)
SPEED_PENALTY = 0.3        # default speed_penalty (see solve_warp)
AUTO_COARSE_FRAMES = 6000  # solve_warp: the coarse-to-fine heuristic by default above this many searched frames


@dataclass(frozen=True, eq=False)
class WarpSolution:
    """A discrete warp: ``frames (m,)`` selected searched-input frames (0 .. n_up - 1, increasing, steps
    1..s), ``times (m,)`` their times in seconds on the *original* input clock, ``cost`` the objective (eq. 1),
    ``pinned`` the output frames fixed by keytimes (end points included)."""

    frames: np.ndarray
    times: np.ndarray
    cost: float
    pinned: tuple
    out_step: int = 1


def _frame_keys(tables: WarpTables, num_frames: int, keytimes) -> list[tuple[int, int]]:
    """Keytimes (seconds) -> (output frame, searched input frame) pairs, end points included."""
    ft = tables.motion.frame_time
    if tables.reverse and keytimes is not None and len(keytimes):
        # the searched clock runs backwards: input time t is reversed time duration - t
        keytimes = [(tables.motion.duration - float(t_in), t_out) for t_in, t_out in keytimes]
    keys = parse_keytimes(keytimes, tables.motion.duration, (num_frames - 1) * ft)
    q = np.rint(keys[:, 1] / ft).astype(int)
    y = np.rint(keys[:, 0] / tables.search_frame_time).astype(int)
    return list(zip(q.tolist(), y.tolist()))


def _coarse_band(tables: WarpTables, m: int, keys, factor: int, band: float | None, weighting: str = "input_time"):
    """Solve on a subsampled problem and return (lo, hi) bounds around the coarse path (§3.3, end), or None
    when the coarse problem is too small or infeasible."""
    n = tables.n_up
    s = tables.skip
    n_c = int(np.ceil((n - 1) / factor)) + 1
    m_c = max(2, int(round((m - 1) / factor)) + 1)
    r = tables.R.shape[0]
    dt_in = (n - 1) / (n_c - 1)                      # coarse input spacing, searched frames
    dt_out = (m - 1) / (m_c - 1)                     # coarse output spacing, output frames
    fx = np.linspace(0.0, n - 1, n_c)
    Xc = np.stack([np.interp(fx, np.arange(n), col) for col in tables.X.T], axis=1)
    if r - 2 * np.ceil(dt_out) < tables.k:
        return None
    ckeys = sorted({(int(round(q / dt_out)), int(round(y / dt_in))) for q, y in keys})
    try:
        validate_keys(n_c, m_c, s, ckeys)
    except ValueError:
        return None
    wp, wv, wa = tables.weights  # coarse differences span dt_out output frames: rescale to keep the units
    wc = (wp, wv / dt_out, wa / dt_out ** 2)
    if tables.knn == "approx":
        Sc = candidate_scores(Xc, tables.R, s, tables.k, wc, candidates=tables.candidates, ref_step=dt_out)
    else:
        Sc = knn_scores(Xc, tables.R, s, tables.k, wc, ref_step=dt_out)
    ends = None   # the coarse problem: eq. (1) without end terms (on 17 coarse frames they decide the path)
    if weighting == "input_time":
        Sc = Sc * step_weights(s)[None]
    fc, cost_c = constrained_dp(Sc, m_c, keys=ckeys, ends=ends)
    if not np.isfinite(cost_c):
        return None
    yhat = np.interp(np.arange(m), np.arange(m_c) * dt_out, fc * dt_in)
    half = 4.0 * max(factor, s) if band is None else float(band)
    return np.floor(yhat - half).astype(np.int64), np.ceil(yhat + half).astype(np.int64)


PENALTY_SCALES = ("doubling", "median")


def penalty_unit(scores: np.ndarray, penalty_scale: str = "doubling") -> float:
    """The unit ``u`` of the speed-change penalty of :func:`solve_warp` (scores are per output frame).

    ``"doubling"`` (default): the median over frames of ``f(j-2, j, j+2) - f(j-1, j, j+1)``, what playing one
    frame at twice the speed costs (its positive part; frames where it is not admissible left out): the
    penalty is then stated in the currency the search trades.  ``"median"``: the median of every admissible
    score (the previous default).  Most of the table's triples are implausible (skips up to ``s`` both sides),
    so that median grows with how bad they are, not with the choices a warp makes: on 1.25 s clips of single
    hops it was 8x the typical score of a real-time frame (183 against 22 on the procedural jump, 58 against
    7.7 on CMU 01_01 at 30 Hz) and the penalty flattened every short clip's warp to near-linear (airborne speed
    1.35-1.81 with the linear warp's 1.54, issue 25).  Falls back to ``"median"`` when ``s < 2``.
    """
    if penalty_scale not in PENALTY_SCALES:
        raise ValueError(f"penalty_scale must be one of {PENALTY_SCALES}, got {penalty_scale!r}")
    if penalty_scale == "doubling" and scores.shape[1] >= 2:
        with np.errstate(invalid="ignore"):
            d = scores[:, 1, 1] - scores[:, 0, 0]
        d = d[np.isfinite(d)]
        if d.size:
            u = float(np.median(np.maximum(d, 0.0)))
            if u > 0:
                return u
    fin = scores[np.isfinite(scores)]
    return float(np.median(fin)) if fin.size else 0.0


WEIGHTINGS = ("input_time", "output")


def _weighted(tables: WarpTables, weighting: str):
    """The scores and end terms the constrained DP sums: as tabulated (``"output"``: one ``f`` per output frame,
    eq. 1) or, for the interior frames, times the input time each stands for (``"input_time"``: ``(a + b) / 2``
    searched frames between steps ``a`` and ``b``); see :func:`solve_warp`.  The end terms stay one frame's
    worth: weighted by half their step they made the search avoid any long first / last step and compress the
    flight of a 1.25 s cut of the procedural jump instead (airborne speed 1.61 against 1.03)."""
    if weighting not in WEIGHTINGS:
        raise ValueError(f"weighting must be one of {WEIGHTINGS}, got {weighting!r}")
    S, ends = tables.scores, tables.ends
    if weighting == "output":
        return S, ends
    return S * step_weights(tables.skip)[None], ends


def _penalised(tables: WarpTables, speed_penalty: float, penalty_scale: str = "doubling",
               weighting: str = "output", free_ratio: float = None) -> np.ndarray:
    """``scores + lambda * u * (log b - log a)^2`` with ``u`` = :func:`penalty_unit` (of the unweighted
    scores): the DP's scores (:func:`_weighted`) with the speed-change penalty of :func:`solve_warp` (a new
    (n, s, s) array; the tables are not modified)."""
    S = _weighted(tables, weighting)[0]
    if speed_penalty == 0:
        return S
    scale = penalty_unit(tables.scores, penalty_scale)
    if not scale > 0:
        return S
    ratio = PENALTY_FREE_RATIO if free_ratio is None else free_ratio
    return S + (speed_penalty * scale) * speed_change_penalty(tables.skip, ratio)[None]


PENALTY_FREE_RATIO = 1.5   # consecutive steps within this ratio are not penalised (see speed_change_penalty)


def speed_change_penalty(skip: int, free_ratio: float = PENALTY_FREE_RATIO) -> np.ndarray:
    """``P[a-1, b-1] = max(0, |log b - log a| - log free_ratio)^2``, shape (s, s): the speed-change penalty of
    consecutive steps ``a, b`` before its weight (:func:`solve_warp`).

    ``free_ratio = 1`` is the plain ``(log b - log a)^2`` of issue 13.  Steps within a ratio of 1.5 (2 and 3,
    3 and 4, ...) are free (default): alternating them is how the discrete search plays a speed between its
    grid's (2/3 x is 3, 3, 2 quarter-frames of a free-length search), and the smoothing (§3.4) makes that a
    steady speed, so there is no pop to prevent.  Penalised, the search snapped to the grid instead: measured,
    free length against a 1.5x slower copy of the clip came out 1.38-1.40x the length (CMU 01_01, CMU 131_01,
    bandai_kick, xia neutral walk at 30 Hz) against 1.42-1.45x free; compressions and their pops unchanged
    (airborne speed 1.02-1.03 on CMU 01_01, 95th percentile pops <= 0.12 per 1/30 s).  Ratio 2 (1 and 2) and
    beyond stay penalised: those are the bursts the penalty is for."""
    a = np.arange(1, int(skip) + 1, dtype=float)
    L = np.abs(np.log(a[None, :] / a[:, None])) - np.log(float(free_ratio))
    return np.maximum(L, 0.0) ** 2


def _check_speed_penalty(speed_penalty) -> float:
    if isinstance(speed_penalty, bool) or not isinstance(speed_penalty, (int, float, np.integer, np.floating)) \
            or not np.isfinite(speed_penalty) or speed_penalty < 0:
        raise ValueError(f"speed_penalty must be a non-negative number, got {speed_penalty!r}")
    return float(speed_penalty)


def solve_warp(tables: WarpTables, num_frames: int | None, keytimes=None, *, coarse: int | None = None,
               band: float | None = None, speed_penalty: float = SPEED_PENALTY, free_objective: str = FREE_OBJECTIVE,
               penalty_scale: str = "doubling", weighting: str = "input_time", penalty_free_ratio: float | None = None,
               progress=None, sweep: LengthSweep | None = None) -> WarpSolution:
    """The optimal discrete warp for a target length and keytimes (§3.3), from precomputed tables.

    Parameters
    ----------
    tables : from :func:`prepare_warp`
    num_frames : m, output frame count, or None for free length (no keytimes): the path of least mean score
        per output frame (``free_objective="mean"``, default, :func:`.dp.mean_cost_dp`) or whose local score
        integrated over input time is least (``"input_time"``, :func:`.dp.input_time_dp`). Both deviate from
        the paper's plain sum (§3.3/V8), which always prefers fewer frames and plays a self-referenced clip at
        0.70x its length; which one fits depends on the reference (see :func:`guided_warp`). Prepare its tables
        with ``k=FREE_K`` and ``upsample=FREE_UPSAMPLE`` (what :func:`guided_warp` does by default)
    keytimes : list of (input_time_s, output_time_s) pairs or None
    coarse : subsampling factor of the coarse-to-fine heuristic (the paper uses 8), or None for the exact DP
        (None means 8 above ``AUTO_COARSE_FRAMES`` searched frames, where the exact DP would not fit).
        The full-resolution search is restricted to ``band`` searched-input frames (default
        ``4 * max(coarse, skip)``; self-referenced compressions have many near-ties, and a narrower band loses
        a few per cent of the objective) either side of the interpolated coarse solution; it falls back to the
        exact DP if that band has no path. The coarse problem samples the input every ~``coarse`` frames and
        takes the reference's differences over the same span from every reference frame.
    speed_penalty : lambda >= 0. The DP minimises eq. (1) plus ``lambda * u * (log b - log a)^2`` for
        every pair of consecutive steps ``a, b`` (an addition to the paper, issue 13 item 11), ``u`` =
        :func:`penalty_unit`: without it a self-referenced compression is bang-bang, 74 % of the frames at
        speed 1 and bursts at ``skip`` x (many near-ties of the objective), which playback shows as pops.
        0 is the paper's objective. ``cost`` is always eq. (1) (with the end terms) without the penalty.
    penalty_scale : "doubling" (default) or "median", the unit ``u`` (:func:`penalty_unit`)
    penalty_free_ratio : consecutive steps within this ratio are not penalised (None: :data:`PENALTY_FREE_RATIO`
        = 1.5; 1: every change, issue 13's form), see :func:`speed_change_penalty`
    weighting : what the constrained search sums (an addition to the paper, issue 25). ``"output"`` is eq. (1):
        one local score per output frame. Then an output frame that a compression removes takes its whole
        score with it, also the part no speed could avoid: with k = 3 the score of a real-time frame is the
        spacing of its nearest reference frames, high where the motion is fast, so eq. (1) compresses fast
        motion first -- a jump's flight: on the procedural jump (self reference, 65 % length) the flight
        played at 2.05x while the walk stayed at 1x (CMU 01_01: 1.06).  ``"input_time"`` (default) weights
        each output frame's score by the input time it stands for, ``(a + b) / 2`` (and half the first /
        last step at the ends), so every stretch of input is charged once whatever its speed and the
        unavoidable part cancels out of the comparison: the same free-length objective as
        :func:`.dp.input_time_dp`.  Measured (heading features, 65 %, 30 Hz): airborne speed 1.00 on the
        procedural jump, 1.01 on CMU 01_01, 0.90-1.09 on 13 standing jumps and single hops of 1.25-2 s
        (with ``"output"`` 0.92-1.37, three outside 0.85-1.15); pops 95th percentile <= 0.11 / max <= 0.25
        per 1/30 s on CMU 01_01, CMU 131_01, bandai_kick and the jump.
    progress : callable(fraction) or None
    sweep : a :func:`length_sweep` of these tables, or None: where it serves the search (the exact DP, the same
        search options, ``num_frames`` in its range, the same keytimes) the search is its backtrack, the same
        frames and cost (:mod:`.sweep`); otherwise it is ignored

    Raises ``ValueError`` naming ``num_frames`` (too short for ``skip``, longer than the searched input) or
    ``keytimes`` (out of range or order, infeasible segment).
    """
    n = tables.n_up
    s = tables.skip
    lam = _check_speed_penalty(speed_penalty)
    ratio = PENALTY_FREE_RATIO if penalty_free_ratio is None else float(penalty_free_ratio)
    if not np.isfinite(ratio) or ratio < 1:
        raise ValueError(f"penalty_free_ratio must be a number >= 1, got {penalty_free_ratio!r}")
    if num_frames is None:
        if keytimes:
            raise ValueError("keytimes need num_frames: the unconstrained search chooses the output length itself")
        if free_objective == "input_time":
            frames, _ = input_time_dp(_penalised(tables, lam, penalty_scale, "output", ratio), ends=tables.ends)
        elif free_objective == "mean":
            frames, _ = mean_cost_dp(_penalised(tables, lam, penalty_scale, "output", ratio), ends=tables.ends)
        else:
            raise ValueError(f"free_objective must be 'input_time' or 'mean', got {free_objective!r}")
        cost = path_cost(tables.scores, frames, tables.ends)
        pinned = (0, frames.size - 1)
    else:
        if tables.out_step != 1:
            raise ValueError(f"tables: out_step={tables.out_step} tables serve free length only (num_frames=None)")
        m = validate_num_frames(num_frames)
        if m > n:
            raise ValueError(f"num_frames={m} is more than the {n} searched input frames (upsample={tables.upsample}); "
                             f"prepare the tables with upsample >= {required_upsample(tables.motion.num_frames, m)}")
        keys = _frame_keys(tables, m, keytimes)
        validate_keys(n, m, s, keys)
        lo = hi = None
        if coarse is None and n > AUTO_COARSE_FRAMES:
            coarse = 8      # the exact DP's backpointers grow as m x (band width) x s: the paper's heuristic
        if coarse is not None:
            if isinstance(coarse, bool) or not isinstance(coarse, (int, np.integer)) or coarse < 2:
                raise ValueError(f"coarse must be an integer factor >= 2 or None, got {coarse!r}")
            b = _coarse_band(tables, m, keys, int(coarse), band, weighting)
            if b is not None:
                lo, hi = b
        if lo is None and coarse is None and isinstance(sweep, LengthSweep) and sweep.n == n and sweep.skip == s \
                and sweep.options == (lam, penalty_scale, weighting, ratio) and sweep.covers(m, keys):
            frames, cost = sweep.solve(m)
            if progress is not None:
                progress(1.0)
            pinned = tuple(q for q, _ in keys)
            return _solution(tables, frames, cost, pinned)
        S = _penalised(tables, lam, penalty_scale, weighting, ratio)
        ends = _weighted(tables, weighting)[1]
        frames, cost = constrained_dp(S, m, keys=keys, lo=lo, hi=hi, progress=progress, ends=ends)
        if lo is not None and not np.isfinite(cost):
            frames, cost = constrained_dp(S, m, keys=keys, progress=progress, ends=ends)
        pinned = tuple(q for q, _ in keys)
    return _solution(tables, frames, cost, pinned)


def _solution(tables: WarpTables, frames: np.ndarray, cost: float, pinned: tuple) -> WarpSolution:
    if np.isfinite(cost):
        cost = path_cost(tables.scores, frames, tables.ends)
    times = frames * tables.search_frame_time
    if tables.reverse:
        times = tables.motion.duration - times
    return WarpSolution(frames, times, float(cost), pinned, tables.out_step)


def length_sweep(tables: WarpTables, m_lo: int, m_hi: int, keytimes=None, *, speed_penalty: float = SPEED_PENALTY,
                 penalty_scale: str = "doubling", weighting: str = "input_time",
                 penalty_free_ratio: float | None = None, progress=None) -> LengthSweep:
    """The exact search of :func:`solve_warp` (§3.3, no coarse-to-fine) for every output length ``m_lo .. m_hi``
    through ``keytimes`` at once (:class:`.sweep.LengthSweep`, one forward pass over the union of their bands):
    ``solve_warp(tables, m, keytimes, sweep=...)`` is then a backtrack for each, the same frames and cost as
    without it. The search options as :func:`solve_warp`'s. Raises ``ValueError`` naming the parameter (a
    length or keytime the search refuses, a sweep over :data:`.sweep.MAX_SWEEP_BYTES`, no C kernel)."""
    if tables.out_step != 1:
        raise ValueError(f"tables: out_step={tables.out_step} tables serve free length only (num_frames=None)")
    n = tables.n_up
    lam = _check_speed_penalty(speed_penalty)
    ratio = PENALTY_FREE_RATIO if penalty_free_ratio is None else float(penalty_free_ratio)
    if not np.isfinite(ratio) or ratio < 1:
        raise ValueError(f"penalty_free_ratio must be a number >= 1, got {penalty_free_ratio!r}")
    lo_m, hi_m = validate_num_frames(m_lo), validate_num_frames(m_hi)
    if hi_m > n:
        raise ValueError(f"m_hi: {hi_m} is more than the {n} searched input frames (upsample={tables.upsample})")
    keys = _frame_keys(tables, lo_m, keytimes)
    inner = tuple(k for k in keys[1:-1])
    S = _penalised(tables, lam, penalty_scale, weighting, ratio)
    return LengthSweep(S, max(3, lo_m), max(3, hi_m), keys=inner, ends=_weighted(tables, weighting)[1],
                       progress=progress, options=(lam, penalty_scale, weighting, ratio))
