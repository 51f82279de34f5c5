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
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from ..core.digest import content_key
from ..core.motion import Motion
from .dp import constrained_dp, input_time_dp, mean_cost_dp, path_cost, step_weights, validate_keys
from .features import check_frame, feature_weights, pose_features, prefilter_frames
from .linear import check_output_size, validate_num_frames
from .objective import candidate_scores, end_scores, knn_scores, validate_skip
from .postprocess import apply_warp, meet_keytimes, parse_keytimes, smooth_warp

__all__ = ["WarpTables", "WarpSolution", "prepare_warp", "slice_tables", "solve_warp", "guided_warp",
           "required_upsample", "reverse_motion", "warp_memory", "MAX_WARP_BYTES", "FREE_UPSAMPLE", "FREE_K",
           "SPEED_PENALTY", "SMOOTHING", "MAX_SEARCH_FRAMES", "cached_prepare_warp", "clear_tables_cache",
           "TABLES_CACHE", "TABLES_CACHE_BYTES", "FREE_OBJECTIVE", "free_length_search", "FREE_SEARCH_TIME",
           "penalty_unit", "PENALTY_SCALES", "WEIGHTINGS", "speed_change_penalty", "PENALTY_FREE_RATIO"]

MAX_WARP_BYTES = 2 << 30   # refuse (ValueError) a search whose tables would need more memory than this
SPEED_PENALTY = 0.3        # default speed_penalty (see solve_warp)
FREE_OBJECTIVE = "input_time"   # default free_objective (see guided_warp)
SMOOTHING = 0.2            # default smoothing, seconds (applied twice: a triangular kernel, see guided_warp)
MAX_SEARCH_FRAMES = 40000  # longest searched input (after upsampling) guided_warp accepts
AUTO_APPROX_PAIRS = 3000 * 3000   # knn="auto": the approximate kNN above this many (input, reference) pairs
DEFAULT_CANDIDATES = 32    # reference frames per input frame of the approximate kNN
FREE_UPSAMPLE = 4          # free length: default upsampling (speeds 1/4 .. skip/4 x, slower and faster than m)
FREE_K = 1                 # free length: kNN count (k = 3 averages away the speed the length is read from)
AUTO_COARSE_FRAMES = 6000  # solve_warp: the coarse-to-fine heuristic by default above this many searched frames
TABLES_CACHE = 4           # tables guided_warp keeps between calls (cached_prepare_warp) ...
TABLES_CACHE_BYTES = 64 << 20   # ... holding at most this many bytes together


@dataclass(frozen=True, eq=False)
class WarpTables:
    """The precomputable head of a guided warp (everything but the output length and keytimes).

    Attributes
    ----------
    motion : the input Motion (n frames, as given, not reversed)
    reference : the reference Motion resampled to ``motion.frame_time``
    skip : s, largest step in (upsampled) input frames between consecutive output frames
    upsample : integer factor u; the searched input has ``n_up = (n - 1) u + 1`` frames ``frame_time / u`` apart
    reverse : True for a backward warp (the searched input is the reversed motion)
    k, weights : kNN count and the effective (pose, velocity, acceleration) weights of the per-output-frame
        features (the ``time_unit`` scaling included)
    X : (n_up, D) pose features of the searched input; R : (r, D) of the reference
    scores : (n_up, s, s) local scores, ``scores[j, a-1, b-1] = f(j-a, j, j+b)`` (inf if not admissible)
    knn : "exact" (:func:`.objective.knn_scores`) or "approx" (:func:`.objective.candidate_scores` with
        ``candidates`` reference frames per input frame)
    ends : ``(start (s,), end (s,))`` scores of the first / last output frame per first / last step
        (:func:`.objective.end_scores`), or None (eq. 1 as printed: the end frames uncharged)
    out_step : output frames per searched output frame (1; ``r > 1`` searches a free-length warp at
        ``frame_time * r``, see :func:`free_length_search`): the features' differences span ``r`` frames
    reverse_reference : True when the reference was reversed too (backward warps, see :func:`prepare_warp`)
    """

    motion: Motion
    reference: Motion
    skip: int
    upsample: int
    reverse: bool
    k: int
    weights: tuple
    X: np.ndarray
    R: np.ndarray
    scores: np.ndarray
    knn: str = "exact"
    candidates: int = 0
    ends: tuple | None = None
    out_step: int = 1
    reverse_reference: bool = False

    @property
    def n_up(self) -> int:
        return int(self.X.shape[0])

    @property
    def search_output_time(self) -> float:
        """Seconds between searched output frames (``frame_time * out_step``)."""
        return self.motion.frame_time * self.out_step

    @property
    def search_frame_time(self) -> float:
        """Seconds between searched (upsampled) input frames."""
        return self.motion.frame_time / self.upsample


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


def reverse_motion(m: Motion) -> Motion:
    """The time-reversed motion (same frame time)."""
    lt = None if m.local_translations is None else m.local_translations[::-1]
    return m.replace(root_positions=m.root_positions[::-1], local_quats=m.local_quats[::-1], local_translations=lt)


def required_upsample(n: int, num_frames: int | None, reference_differs: bool = False, *, keytimes=None,
                      frame_time: float | None = None, skip: int | None = None) -> int:
    """Default upsampling factor: :data:`FREE_UPSAMPLE` for free length (``num_frames=None``, the search may
    play slower or faster than ``m``; :func:`free_length_search` gives the factor and the output step that
    :func:`guided_warp` uses), 1 for compressions, otherwise ``ceil(2 (num_frames - 1) / (n - 1))`` so the
    output uses about half of the upsampled frames and the search keeps room to vary the speed.

    ``num_frames == n`` (a same-duration warp) gives 1 for a self reference (the only complete subsequence of
    n frames is the identity, §3.1) and 2 when ``reference_differs`` (a *style* warp: the search then
    compresses 2 n - 1 half-frames to n, playing each stretch at 0.5x to ``skip / 2`` x).

    **Keytimes** (with ``frame_time``, the input's): every segment between consecutive keys (end points
    included) must be played at its own mean speed ``v = input seconds / output seconds``; where some segment
    is slower than real time (``v_min < 1``) the search needs upsampling even when the whole warp compresses,
    as the paper's expansions do (§4.1 V5, §4.3): the factor is at least ``ceil(2 / v_min)`` (the same
    "room to vary" rule), capped at ``floor(skip / v_max)`` when ``skip`` is given so the fastest segment stays
    reachable, and never below ``ceil(1 / v_min)``.  Example (issue 26): CMU 01_01 (2,751 frames at 120 Hz) to
    22.83 s with the keytime 2 s -> 1.5 s plays 0-2 s at 1.33x and the rest at 0.98x: factor 3, where 1 (the
    whole warp is a compression) left no warp at all."""
    if n < 2:
        raise ValueError(f"the input motion needs at least 2 frames, got {n}")
    if num_frames is None:
        return FREE_UPSAMPLE
    if num_frames < n or (num_frames == n and not reference_differs):
        u = 1
    else:
        u = max(2, int(np.ceil(2.0 * (num_frames - 1) / (n - 1))))
    if keytimes is None or not len(keytimes) or frame_time is None:
        return u
    ft = float(frame_time)
    keys = parse_keytimes(keytimes, (n - 1) * ft, (num_frames - 1) * ft)
    v = np.diff(keys[:, 0]) / np.diff(keys[:, 1])
    vmin, vmax = float(v.min()), float(v.max())
    if vmin >= 1.0:
        return u
    need = int(np.ceil(1.0 / vmin - 1e-9))
    want = max(u, int(np.ceil(2.0 / vmin - 1e-9)))
    if skip is not None:
        want = min(want, max(need, int(np.floor(int(skip) / vmax + 1e-9))))
    return max(want, need)


FREE_SEARCH_TIME = 1.0 / 30.0   # free length: the search's output frames at least this far apart (the paper's 30 Hz)


def free_length_search(frame_time: float) -> tuple[int, int]:
    """``(upsample, out_step)`` of a free-length search on a clip of ``frame_time``: the product is always
    :data:`FREE_UPSAMPLE` (speeds ``a / 4`` for steps of ``a`` searched frames: 1/4 .. skip/4), and the search's
    output frames are ``out_step * frame_time`` apart, the largest divisor of :data:`FREE_UPSAMPLE` that keeps
    them at most :data:`FREE_SEARCH_TIME` apart.  At 30 Hz (the paper's rate) ``(4, 1)``: the input upsampled
    4x; at 120 Hz ``(1, 4)``: the input as it is, output frames searched every 1/30 s and interpolated in
    between, a quarter of the searched frames (CMU 01_01, 2,751 frames: 2,751 instead of 11,001; the tail
    of a first free-length or backward change 1.2-3.1 s -> see ``benchmarks/bench_claims.py``)."""
    best = 1
    for r in range(1, FREE_UPSAMPLE + 1):
        if FREE_UPSAMPLE % r == 0 and r * float(frame_time) <= FREE_SEARCH_TIME * (1 + 1e-6):
            best = r
    return FREE_UPSAMPLE // best, best


def _knn_mode(knn: str, n_up: int, r: int) -> str:
    if knn not in ("auto", "exact", "approx"):
        raise ValueError(f"knn must be 'auto', 'exact' or 'approx', got {knn!r}")
    if knn == "auto":
        return "approx" if n_up * r > AUTO_APPROX_PAIRS else "exact"
    return knn


def warp_memory(n: int, r: int, skip: int, upsample: int = 1, dims: int = 93, knn: str = "auto",
                candidates: int = DEFAULT_CANDIDATES) -> int:
    """Bytes the tables of a guided warp need (an estimate, before allocating), ``n_up = (n - 1) upsample + 1``:
    the ``(n_up, s, s)`` float64 score table and the ``(n_up, dims)`` features, plus for the exact kNN search
    three ``(r, n_up + 2 s)`` float32 partial-sum matrices, for the approximate one the ``(n_up, C)`` candidate
    table and one chunk of gathered reference blocks."""
    n_up = (int(n) - 1) * int(upsample) + 1
    base = n_up * skip * skip * 8 + 8 * dims * (n_up + 4 * r)
    if _knn_mode(knn, n_up, r) == "exact":
        return int(base + 3 * 4 * r * (n_up + 2 * skip))
    C = int(candidates)
    return int(base + 16 * n_up * C + 8 * 1024 * C * (3 * dims + 4 * skip * skip))


def _check_warp_size(n: int, r: int, skip: int, upsample: int, dims: int, what: str, knn: str = "auto",
                     candidates: int = DEFAULT_CANDIDATES) -> None:
    n_up = (n - 1) * upsample + 1
    remedy = ("ask for fewer output frames, or shorten the clips first (m.slice(start, stop), or "
              "m.resample(frame_time) with a longer frame time)")
    if n_up > MAX_SEARCH_FRAMES:
        raise ValueError(f"{what}: the search over {n_up} input frames (n={n}, upsample={upsample}) is longer than "
                         f"the {MAX_SEARCH_FRAMES} frames guided warping handles (its time grows with the length); "
                         + remedy)
    need = warp_memory(n, r, skip, upsample, dims, knn, candidates)
    if need > MAX_WARP_BYTES:
        raise ValueError(f"{what}: the search over {n_up} input frames (n={n}, upsample={upsample}) against "
                         f"{r} reference frames needs about {need / 2**30:.1f} GiB, more than the "
                         f"{MAX_WARP_BYTES / 2**30:.0f} GiB limit; " + remedy)


def _validate_upsample(upsample) -> int:
    if isinstance(upsample, bool) or not isinstance(upsample, (int, np.integer)) or upsample < 1:
        raise ValueError(f"upsample must be a positive integer, got {upsample!r}")
    return int(upsample)


def prepare_warp(m: Motion, reference: Motion, skip: int = 8, upsample: int = 1, *, reverse: bool = False,
                 k: int = 3, weights=(1.0, 1.0, 1.0), joint_weights=None, prefilter: float = 0.1,
                 time_unit: float = 1.0 / 30.0, dtype=np.float32, knn: str = "auto",
                 candidates: int = DEFAULT_CANDIDATES, frame: str = "pelvis_height", end_terms: bool = True,
                 out_step: int = 1, reverse_reference: bool | None = None, progress=None) -> WarpTables:
    """Features and the kNN score table (§3.2) for warping ``m`` guided by ``reference``.

    Parameters
    ----------
    m : input Motion, n >= 2 frames
    reference : Motion with the same joints (any frame time; resampled to ``m.frame_time``), >= k + 2 frames
    skip : s in [1, 127], largest step in searched input frames between consecutive output frames (§3.1)
    upsample : integer factor u >= 1 (needed for outputs longer than the input)
    reverse : search the time-reversed input (backward warps)
    k : nearest neighbours averaged in eq. (2) (paper: 3)
    weights : (pose, velocity, acceleration) block weights of the feature vector
    joint_weights : (J,) per-joint weights of the squared distances, or None
    prefilter : seconds, width of the box low-pass filter applied to joint positions
    frame : body frame of the pose features, "pelvis_height" (default), "heading" or "pelvis" (the paper's
        torso frame); see :mod:`.features`
    time_unit : seconds; velocities and accelerations are expressed per ``time_unit`` (default 1/30 s, the
        paper's 30 Hz), so the balance of pose against timing in the features does not depend on the clip's
        frame rate (the derivative weights are scaled by ``time_unit / frame_time`` and its square)
    dtype : float32 or float64 for the exact kNN search (see :func:`.objective.knn_scores`)
    knn : "exact", "approx" (:func:`.objective.candidate_scores`: the k nearest among the ``candidates``
        reference frames of nearest pose; for long takes) or "auto" (approx above ``AUTO_APPROX_PAIRS``
        input x reference frames, i.e. beyond about 3,000 x 3,000)
    candidates : C of the approximate search
    end_terms : score the first and last output frame too (:func:`.objective.end_scores`; default) or not
        (eq. 1 as printed)
    out_step : integer r >= 1: tables for a search whose output frames are ``r * frame_time`` apart (free
        length on high-frame-rate clips, :func:`free_length_search`); the reference's differences then span
        ``r`` frames and the speeds of a step of ``a`` searched frames are ``a / (upsample r)``
    reverse_reference : with ``reverse``, reverse the reference too (None = ``reverse``, the default).  A
        backward warp then plays the input backwards with the reference's timing played backwards: each pose's
        speed is compared, not the sign of its velocity.  ``False`` is the paper's reduction (§3.1: "reversing
        the input"), where every velocity of a backward-played input opposes the reference's: measured, the
        free-length backward warp of a clip against itself came out 2.4-4.0x longer than the clip (CMU 01_01
        2.38, xia neutral walk 3.28, CMU 131_01 3.99: the slowest the search allows), 1.00x with the default
    progress : callable(fraction) or None

    Returns
    -------
    WarpTables
    """
    if not isinstance(m, Motion):
        raise ValueError(f"m must be a Motion, got {type(m).__name__}")
    if not isinstance(reference, Motion):
        raise ValueError(f"reference must be a Motion, got {type(reference).__name__}")
    if reference.num_joints != m.num_joints:
        raise ValueError(f"reference has {reference.num_joints} joints but the input has {m.num_joints}; "
                         "guided time warping needs the same skeleton (§4.2)")
    if m.num_frames < 2:
        raise ValueError(f"m needs at least 2 frames, got {m.num_frames}")
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"k must be a positive integer, got {k!r}")
    skip = validate_skip(skip)
    upsample = _validate_upsample(upsample)
    weights = feature_weights(weights)
    if not np.isfinite(time_unit) or time_unit <= 0:
        raise ValueError(f"time_unit must be a positive number of seconds, got {time_unit!r}")
    if isinstance(out_step, bool) or not isinstance(out_step, (int, np.integer)) or out_step < 1:
        raise ValueError(f"out_step must be a positive integer, got {out_step!r}")
    out_step = int(out_step)
    c = float(time_unit) / (m.frame_time * out_step)
    weights = (weights[0], weights[1] * c, weights[2] * c * c)   # per-output-frame differences -> per time_unit
    prefilter_frames(prefilter, m.frame_time)  # validates prefilter
    frame = check_frame(frame)
    ref = reference
    if abs(ref.frame_time - m.frame_time) > 1e-9 * m.frame_time:
        ref = ref.resample(m.frame_time)
    if ref.num_frames < k + 2 * out_step:
        raise ValueError(f"reference has {ref.num_frames} frames at the input's frame time; k={k} needs >= "
                         f"{k + 2 * out_step}" + (f" (out_step={out_step})" if out_step > 1 else ""))
    rev_ref = bool(reverse) if reverse_reference is None else bool(reverse_reference)
    if rev_ref:
        ref = reverse_motion(ref)
    if isinstance(candidates, bool) or not isinstance(candidates, (int, np.integer)) or candidates < k:
        raise ValueError(f"candidates must be an integer >= k = {k}, got {candidates!r}")
    n_up = (m.num_frames - 1) * upsample + 1
    mode = _knn_mode(knn, n_up, ref.num_frames)
    _check_warp_size(m.num_frames, ref.num_frames, skip, upsample, 3 * m.num_joints,
                     "upsample" if upsample > 1 else "m", mode, candidates)
    src = reverse_motion(m) if reverse else m
    if upsample > 1:
        n_up = (m.num_frames - 1) * upsample + 1
        src = src.sample(np.arange(n_up) / upsample, m.frame_time / upsample)
    X = pose_features(src, joint_weights, prefilter, frame)
    # a self reference (the common case, §4.1) has the same features: compute them once
    R = X if _same_content(src, ref) else pose_features(ref, joint_weights, prefilter, frame)
    if mode == "exact":
        scores = knn_scores(X, R, skip, k, weights, dtype=dtype, progress=progress, ref_step=out_step)
    else:
        scores = candidate_scores(X, R, skip, k, weights, candidates=int(candidates), progress=progress,
                                  ref_step=out_step)
    ends = end_scores(X, R, skip, k, weights, ref_step=out_step) if end_terms else None
    return WarpTables(m, ref, skip, upsample, bool(reverse), int(k), weights, X, R, scores, mode,
                      int(candidates) if mode == "approx" else 0, ends, out_step, rev_ref)


_TABLES: OrderedDict[bytes, WarpTables] = OrderedDict()
_TABLES_LOCK = threading.Lock()


def _table_bytes(t: WarpTables) -> int:
    return int(t.scores.nbytes + t.X.nbytes + (0 if t.R is t.X else t.R.nbytes))


def cached_prepare_warp(m: Motion, reference: Motion, skip: int = 8, upsample: int = 1, **options) -> WarpTables:
    """:func:`prepare_warp` through a small module cache, so that repeated one-call :func:`guided_warp` calls with
    the same input, reference and objective options (another length, other keytimes, the same call again)
    skip the expensive head (features + kNN table, ~80 % of a Table-1-size call).

    Explicit and bounded like the magic wand's graph cache: keyed by the *content* of both motions and every
    option (:func:`..core.digest.content_key`, ~1 ms per MB, never ``id()``); holds at most
    :data:`TABLES_CACHE` tables of at most :data:`TABLES_CACHE_BYTES` together, least recently used out first
    (larger tables, e.g. long takes, are not kept); :func:`clear_tables_cache` empties it.  Tables are
    frozen and the cached ones' arrays read-only, so sharing them is safe.  Callers
    that manage their own caching (the session) call :func:`prepare_warp` directly."""
    progress = options.pop("progress", None)
    key = content_key(m, "self" if reference is m else reference, skip, upsample, tuple(sorted(options.items())))
    with _TABLES_LOCK:
        t = _TABLES.get(key)
        if t is not None:
            _TABLES.move_to_end(key)
    if t is not None:
        if progress is not None:
            progress(1.0)
        return t
    t = prepare_warp(m, reference, skip, upsample, progress=progress, **options)
    size = _table_bytes(t)
    if size <= TABLES_CACHE_BYTES:
        for a in (t.X, t.R, t.scores) + (t.ends or ()):   # shared from now on: an in-place write raises
            a.setflags(write=False)
        with _TABLES_LOCK:
            _TABLES[key] = t
            while len(_TABLES) > TABLES_CACHE or sum(map(_table_bytes, _TABLES.values())) > TABLES_CACHE_BYTES:
                _TABLES.popitem(last=False)
    return t


def clear_tables_cache() -> None:
    """Empty the module cache of :func:`cached_prepare_warp`."""
    with _TABLES_LOCK:
        _TABLES.clear()


def slice_tables(tables: WarpTables, skip: int) -> WarpTables:
    """The tables of a smaller skip limit, cut from exact-kNN tables of a larger one: ``scores[j, a-1, b-1] =
    f(j-a, j, j+b)`` does not depend on the skip, so ``scores[:, :skip, :skip]`` is what :func:`prepare_warp`
    computes for ``skip`` (bit for bit for ``knn="exact"``; tested). A session warms the largest skip of a
    slider once and serves every smaller one by slicing (~1 ms instead of 0.07-0.4 s on 900 frames).

    Raises ValueError naming ``skip`` when it is larger than ``tables.skip``, and ``tables`` for approximate
    tables (their candidate search is not checked to be skip-independent)."""
    skip = validate_skip(skip)
    if skip > tables.skip:
        raise ValueError(f"skip={skip} is larger than the tables' skip {tables.skip}; prepare_warp it instead")
    if tables.knn != "exact":
        raise ValueError(f"tables: only exact-kNN tables can be sliced, got knn={tables.knn!r}")
    if skip == tables.skip:
        return tables
    scores = np.ascontiguousarray(tables.scores[:, :skip, :skip])
    ends = None if tables.ends is None else tuple(np.ascontiguousarray(e[:skip]) for e in tables.ends)
    return WarpTables(tables.motion, tables.reference, skip, tables.upsample, tables.reverse, tables.k,
                      tables.weights, tables.X, tables.R, scores, tables.knn, tables.candidates, ends,
                      tables.out_step, tables.reverse_reference)


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
               progress=None) -> WarpSolution:
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

    Raises ``ValueError`` naming ``num_frames`` (too short for ``skip``, longer than the searched input) or
    ``keytimes`` (out of range or order, infeasible segment).
    """
    n = tables.n_up
    s = tables.skip
    to_seconds = tables.search_frame_time
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
        S = _penalised(tables, lam, penalty_scale, weighting, ratio)
        ends = _weighted(tables, weighting)[1]
        frames, cost = constrained_dp(S, m, keys=keys, lo=lo, hi=hi, progress=progress, ends=ends)
        if lo is not None and not np.isfinite(cost):
            frames, cost = constrained_dp(S, m, keys=keys, progress=progress, ends=ends)
        pinned = tuple(q for q, _ in keys)
    if np.isfinite(cost):
        cost = path_cost(tables.scores, frames, tables.ends)
    times = frames * to_seconds
    if tables.reverse:
        times = tables.motion.duration - times
    return WarpSolution(frames, times, float(cost), pinned, tables.out_step)


def _same_content(a: Motion, b: Motion) -> bool:
    """Same frames, rig and frame time (so the same pose features)."""
    if a is b:
        return True
    lt_a, lt_b = a.local_translations, b.local_translations
    return (a.num_frames == b.num_frames and a.num_joints == b.num_joints
            and abs(a.frame_time - b.frame_time) <= 1e-12 * a.frame_time
            and (a.skeleton is b.skeleton or (np.array_equal(a.skeleton.parents, b.skeleton.parents)
                                              and np.array_equal(a.skeleton.offsets, b.skeleton.offsets)))
            and np.array_equal(a.local_quats, b.local_quats)
            and np.array_equal(a.root_positions, b.root_positions)
            and ((lt_a is None and lt_b is None) or (lt_a is not None and lt_b is not None
                                                     and np.array_equal(lt_a, lt_b))))


def guided_warp(m: Motion, reference: Motion, num_frames: int | None, skip: int = 8, keytimes=None, *,
                upsample: int | None = None, reverse: bool = False, backward: bool | None = None, k: int | None = None,
                weights=(1.0, 1.0, 1.0), joint_weights=None, prefilter: float = 0.1, time_unit: float = 1.0 / 30.0,
                coarse: int | None = None, band: float | None = None, speed_penalty: float = SPEED_PENALTY,
                smoothing: float = SMOOTHING, adaptive: bool = True, knn: str = "auto",
                candidates: int = DEFAULT_CANDIDATES, tables: WarpTables | None = None,
                free_objective: str = FREE_OBJECTIVE, frame: str = "pelvis_height", end_terms: bool = True,
                penalty_scale: str = "doubling", reverse_reference: bool | None = None,
                weighting: str = "input_time", penalty_free_ratio: float | None = None, progress=None):
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
