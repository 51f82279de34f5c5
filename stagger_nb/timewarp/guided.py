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

Keytimes: a list of ``(input_time_s, output_time_s)`` pairs, end points implied; each is rounded to the
nearest (upsampled) input frame and output frame. See :mod:`.postprocess`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.motion import Motion
from .dp import constrained_dp, unconstrained_dp, validate_keys
from .features import feature_weights, pose_features, prefilter_frames
from .linear import validate_num_frames
from .objective import knn_scores, validate_skip
from .postprocess import apply_warp, parse_keytimes, smooth_warp

__all__ = ["WarpTables", "WarpSolution", "prepare_warp", "solve_warp", "guided_warp", "required_upsample",
           "reverse_motion"]


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

    @property
    def n_up(self) -> int:
        return int(self.X.shape[0])

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


def reverse_motion(m: Motion) -> Motion:
    """The time-reversed motion (same frame time)."""
    lt = None if m.local_translations is None else m.local_translations[::-1]
    return m.replace(root_positions=m.root_positions[::-1], local_quats=m.local_quats[::-1], local_translations=lt)


def required_upsample(n: int, num_frames: int | None) -> int:
    """Default upsampling factor: 1 for compressions, otherwise ``ceil(2 (num_frames - 1) / (n - 1))`` so the
    output uses about half of the upsampled frames and the search keeps room to vary the speed."""
    if num_frames is None or num_frames <= n:
        return 1
    return int(np.ceil(2.0 * (num_frames - 1) / (n - 1)))


def _validate_upsample(upsample) -> int:
    if isinstance(upsample, bool) or not isinstance(upsample, (int, np.integer)) or upsample < 1:
        raise ValueError(f"upsample must be a positive integer, got {upsample!r}")
    return int(upsample)


def prepare_warp(m: Motion, reference: Motion, skip: int = 8, upsample: int = 1, *, reverse: bool = False,
                 k: int = 3, weights=(1.0, 1.0, 1.0), joint_weights=None, prefilter: float = 0.1,
                 time_unit: float = 1.0 / 30.0, dtype=np.float32, progress=None) -> WarpTables:
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
    time_unit : seconds; velocities and accelerations are expressed per ``time_unit`` (default 1/30 s, the
        paper's 30 Hz), so the balance of pose against timing in the features does not depend on the clip's
        frame rate (the derivative weights are scaled by ``time_unit / frame_time`` and its square)
    dtype : float32 or float64 for the kNN search (see :func:`.objective.knn_scores`)
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
    c = float(time_unit) / m.frame_time
    weights = (weights[0], weights[1] * c, weights[2] * c * c)   # per-output-frame differences -> per time_unit
    prefilter_frames(prefilter, m.frame_time)  # validates prefilter
    ref = reference
    if abs(ref.frame_time - m.frame_time) > 1e-9 * m.frame_time:
        ref = ref.resample(m.frame_time)
    if ref.num_frames < k + 2:
        raise ValueError(f"reference has {ref.num_frames} frames at the input's frame time; k={k} needs >= {k + 2}")
    src = reverse_motion(m) if reverse else m
    if upsample > 1:
        n_up = (m.num_frames - 1) * upsample + 1
        src = src.sample(np.arange(n_up) / upsample, m.frame_time / upsample)
    X = pose_features(src, joint_weights, prefilter)
    R = pose_features(ref, joint_weights, prefilter)
    scores = knn_scores(X, R, skip, k, weights, dtype=dtype, progress=progress)
    return WarpTables(m, ref, skip, upsample, bool(reverse), int(k), weights, X, R, scores)


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


def _coarse_band(tables: WarpTables, m: int, keys, factor: int, band: float | None):
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
    Sc = knn_scores(Xc, tables.R, s, tables.k, (wp, wv / dt_out, wa / dt_out ** 2), ref_step=dt_out)
    fc, cost_c = constrained_dp(Sc, m_c, keys=ckeys)
    if not np.isfinite(cost_c):
        return None
    yhat = np.interp(np.arange(m), np.arange(m_c) * dt_out, fc * dt_in)
    half = 4.0 * max(factor, s) if band is None else float(band)
    return np.floor(yhat - half).astype(np.int64), np.ceil(yhat + half).astype(np.int64)


def solve_warp(tables: WarpTables, num_frames: int | None, keytimes=None, *, coarse: int | None = None,
               band: float | None = None, progress=None) -> WarpSolution:
    """The optimal discrete warp for a target length and keytimes (§3.3), from precomputed tables.

    Parameters
    ----------
    tables : from :func:`prepare_warp`
    num_frames : m, output frame count, or None for the unconstrained shortest path (any length; no keytimes)
    keytimes : list of (input_time_s, output_time_s) pairs or None
    coarse : subsampling factor of the coarse-to-fine heuristic (the paper uses 8), or None for the exact DP.
        The full-resolution search is restricted to ``band`` searched-input frames (default
        ``4 * max(coarse, skip)``; self-referenced compressions have many near-ties, and a narrower band loses
        a few per cent of the objective) either side of the interpolated coarse solution; it falls back to the
        exact DP if that band has no path. The coarse problem samples the input every ~``coarse`` frames and
        takes the reference's differences over the same span from every reference frame.
    progress : callable(fraction) or None

    Raises ``ValueError`` naming ``num_frames`` (too short for ``skip``, longer than the searched input) or
    ``keytimes`` (out of range or order, infeasible segment).
    """
    n = tables.n_up
    s = tables.skip
    to_seconds = tables.search_frame_time
    if num_frames is None:
        if keytimes:
            raise ValueError("keytimes need num_frames: the unconstrained search chooses the output length itself")
        frames, cost = unconstrained_dp(tables.scores)
        pinned = (0, frames.size - 1)
    else:
        m = validate_num_frames(num_frames)
        if m > n:
            raise ValueError(f"num_frames={m} is more than the {n} searched input frames (upsample={tables.upsample}); "
                             f"prepare the tables with upsample >= {required_upsample(tables.motion.num_frames, m)}")
        keys = _frame_keys(tables, m, keytimes)
        validate_keys(n, m, s, keys)
        lo = hi = None
        if coarse is not None:
            if isinstance(coarse, bool) or not isinstance(coarse, (int, np.integer)) or coarse < 2:
                raise ValueError(f"coarse must be an integer factor >= 2 or None, got {coarse!r}")
            b = _coarse_band(tables, m, keys, int(coarse), band)
            if b is not None:
                lo, hi = b
        frames, cost = constrained_dp(tables.scores, m, keys=keys, lo=lo, hi=hi, progress=progress)
        if lo is not None and not np.isfinite(cost):
            frames, cost = constrained_dp(tables.scores, m, keys=keys, progress=progress)
        pinned = tuple(q for q, _ in keys)
    times = frames * to_seconds
    if tables.reverse:
        times = tables.motion.duration - times
    return WarpSolution(frames, times, float(cost), pinned)


def guided_warp(m: Motion, reference: Motion, num_frames: int | None, skip: int = 8, keytimes=None, *,
                upsample: int | None = None, reverse: bool = False, k: int = 3, weights=(1.0, 1.0, 1.0),
                joint_weights=None, prefilter: float = 0.1, time_unit: float = 1.0 / 30.0,
                coarse: int | None = None, band: float | None = None,
                smoothing: float = 0.1, adaptive: bool = True, tables: WarpTables | None = None,
                progress=None):
    """Retime ``m`` to ``num_frames`` frames through ``keytimes`` so its local timing matches ``reference``.

    Parameters
    ----------
    m : input Motion (n frames, ``frame_time`` seconds apart); the output has the same frame time
    reference : Motion with the same joints giving the desired timing (``m`` itself to preserve timing, §4.1)
    num_frames : output frame count m (``n / skip <= m``; ``m > n`` upsamples), or None: unconstrained length.
        ``m == n`` without upsampling (the default, ``upsample=None`` or 1) returns the identity warp: the only
        complete subsequence of n input frames is all of them (§3.1). With an explicit ``upsample > 1`` the
        search has ``(n - 1) u + 1`` frames and may choose any warp of the same duration for ``m == n``.
    skip : s, largest input-frame step per output frame (the fastest playback is s times real time)
    keytimes : list of (input_time_s, output_time_s) pairs or None; end points ``(0, 0)`` and
        ``(m.duration, (num_frames - 1) * frame_time)`` are implied; both times strictly increasing
    upsample : integer upsampling of the input (default :func:`required_upsample`); 1 forbids expansion
    reverse : backward warp (play the input backwards); keytimes stay on the original input clock
    k, weights, joint_weights, prefilter, time_unit : objective options, see :func:`prepare_warp`
    coarse, band : coarse-to-fine heuristic, see :func:`solve_warp`
    smoothing : seconds, moving-average window applied to the discrete warp (§3.4); 0 disables
    adaptive : adaptive smoothing of the resampled motion under compression (§3.4)
    tables : precomputed :func:`prepare_warp` result to reuse; then ``reference``, ``skip``, ``upsample``,
        ``reverse`` and the objective options are the ones the tables were prepared with (the editor's cheap
        tail: cache one table per upsampling factor, :func:`required_upsample` says which one a length needs)
    progress : callable(fraction in [0, 1]) or None

    Returns
    -------
    out : Motion with ``num_frames`` frames (the warped motion)
    warp : (num_frames,) input time in seconds of each output frame (the smoothed warp curve)
    """
    if not isinstance(m, Motion):
        raise ValueError(f"m must be a Motion, got {type(m).__name__}")
    if num_frames is not None:
        num_frames = validate_num_frames(num_frames)
    if isinstance(smoothing, bool) or not isinstance(smoothing, (int, float, np.integer, np.floating)) \
            or not np.isfinite(smoothing) or smoothing < 0:
        raise ValueError(f"smoothing must be a non-negative number of seconds, got {smoothing!r}")
    if tables is None:
        u = required_upsample(m.num_frames, num_frames) if upsample is None else _validate_upsample(upsample)
        if num_frames is not None and num_frames > (m.num_frames - 1) * u + 1:
            raise ValueError(f"num_frames={num_frames} is more than the {m.num_frames} input frames and "
                             f"upsample={u} gives only {(m.num_frames - 1) * u + 1}: expansion needs upsampling")
        head = None if progress is None else (lambda f: progress(0.9 * f))
        tables = prepare_warp(m, reference, skip, u, reverse=reverse, k=k, weights=weights,
                              joint_weights=joint_weights, prefilter=prefilter, time_unit=time_unit,
                              progress=head)
    elif tables.motion is not m and (tables.motion.num_frames != m.num_frames
                                     or tables.motion.num_joints != m.num_joints):
        raise ValueError("tables were prepared for a different input motion")
    tail = None if progress is None else (lambda f: progress(0.9 + 0.1 * f))
    sol = solve_warp(tables, num_frames, keytimes, coarse=coarse, band=band, progress=tail)
    ft = m.frame_time
    window = prefilter_frames(smoothing, ft) if smoothing else 1
    warp = smooth_warp(sol.times, window, pinned=sol.pinned)
    warp = np.clip(warp, 0.0, m.duration)
    out = apply_warp(m, warp, ft, adaptive=adaptive)
    if progress is not None:
        progress(1.0)
    return out, warp
