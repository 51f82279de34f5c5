"""The expensive head of guided time warping (Hsu et al. 2007, §3.1-3.2): :func:`prepare_warp` builds the
:class:`WarpTables` (pose features, the kNN local-score table of every admissible triple) of an input, a
reference, a skip and an upsampling; :func:`required_upsample`, :func:`free_length_search` and
:func:`warp_memory` choose and size them before anything is allocated; :func:`slice_tables` reuses them
for a smaller skip."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.motion import Motion
from .features import check_frame, feature_weights, pose_features, prefilter_frames
from .objective import candidate_scores, end_scores, knn_scores, validate_skip
from .postprocess import parse_keytimes

MAX_WARP_BYTES = 2 << 30   # refuse (ValueError) a search whose tables would need more memory than this


MAX_SEARCH_FRAMES = 40000  # longest searched input (after upsampling) guided_warp accepts


AUTO_APPROX_PAIRS = 3000 * 3000   # knn="auto": the approximate kNN above this many (input, reference) pairs


DEFAULT_CANDIDATES = 32    # reference frames per input frame of the approximate kNN


FREE_UPSAMPLE = 4          # free length: default upsampling (speeds 1/4 .. skip/4 x, slower and faster than m)


FREE_K = 1                 # free length: kNN count (k = 3 averages away the speed the length is read from)


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
