"""Op runners: each op type -> a function ``(state, op, run) -> state`` over the replay state.

The state is a :class:`~stagger_nb.core.Motion` or a ``staggered.StaggeredMotion``; the replay converts it to
what the op ``needs`` before calling the runner (:func:`convert`). Runners call the technique packages' pure
functions; the expensive heads they need (the staggered extraction, culls, the magic wand's pose graph and
per-sigma eigenbases, guided warping's kNN tables, warp references) come from :class:`Heads`, which keeps
them in the session's one :class:`~.cache.Cache`. A runner may leave plain notes for the user
(``run.note(text)``) and the warp curve it computed (``run.warp``).
"""
from __future__ import annotations

import inspect
from typing import Callable

import numpy as np

from ..core.kinematics import forward_kinematics
from ..core.motion import _UNIT_TOL, Motion
from ..core.rotations import quat_mul, quat_normalize, rotvec_to_quat
from ..core.skeleton import Skeleton
from ..io.bvh import read_bvh
from . import ops as O
from .cache import Cache

__all__ = ["RUNNERS", "BATCHED", "Heads", "Run", "convert", "apply_pose_deltas", "warp_size", "warp_k",
           "warp_table_key", "pose_spread", "falloff_at_poses", "even_upsample", "MAX_WARP_RATIO"]

MAX_WARP_RATIO = 100  # output frames per input frame: far past the papers' 10x slow motion


def _staggered():
    from .. import staggered  # late import: the technique packages load only when an op needs them
    return staggered


def _wand():
    from .. import wand
    return wand


def _timewarp():
    from .. import timewarp
    return timewarp


# --------------------------------------------------------------------------------------------------
# cached heads
# --------------------------------------------------------------------------------------------------
class Heads:
    """The expensive heads of the techniques, computed once each in ``cache``.

    Parameters
    ----------
    cache : Cache
    source : Motion, the session's source ("self" warp reference; segments are cut from it)
    extract_options : dict, keyword arguments of ``staggered.extract`` (already checked)
    """

    def __init__(self, cache: Cache, source: Motion, extract_options: dict):
        self.cache = cache
        self.source = source
        self.extract_options = dict(extract_options)
        self.memory_references: dict[str, Motion] = {}  # Session.use_reference: never evicted
        cache.name(source, "source")

    def key(self, obj) -> str:
        return self.cache.token(obj)

    def extract(self, motion: Motion, progress: Callable | None = None):
        """``staggered.extract(motion, **extract_options)``, once per motion (``progress(fraction)`` is passed
        to the computation when this call computes it)."""
        def make():
            try:
                return _staggered().extract(motion, progress=progress, **self.extract_options)
            except (TypeError, ArithmeticError) as e:  # the options are checked already: a bad value
                raise ValueError(f"extract_options: {type(e).__name__}: {e}") from None
        return self.cache.get("extract", self.key(motion), None, make)

    def cull(self, sm, percent: float | None = None, count: int | None = None, progress: Callable | None = None):
        """``staggered.cull(sm, percent)`` or ``cull(sm, count=count)`` (a refit of the splines, the slow step
        of the cull slider), once per (representation, kept poses): the entry is keyed by
        ``staggered.cull_keep`` (cheap), so every percent or count keeping the same poses shares one refit."""
        st = _staggered()
        count = None if count is None else int(count)
        percent = None if count is not None or percent is None else float(percent)
        keep = tuple(int(k) for k in st.cull_keep(sm, percent, count=count))
        return self.cache.get("cull", self.key(sm), ("keep", keep),
                              lambda: st.cull(sm, percent, count=count, progress=progress))

    def offset_basis(self, sm, origin: Motion | None = None):
        """``staggered.pose_offset_basis(sm, origin)``: the offset-independent half of an exaggeration of ``sm``
        (§5.1), once per pre-exaggerate state (keyed by its content name): a ``w_r`` slider move reuses it.
        ``origin``: the Motion ``sm`` was extracted from (it reads the rotations on frames from it while
        ``sm`` reproduces it; a ``pose_offset_basis`` without that parameter, an older one or a wrapper, is
        called with ``sm`` alone). None when this version of staggered has no such function."""
        make = getattr(_staggered(), "pose_offset_basis", None)
        if make is None:
            return None
        try:
            takes = origin is not None and "reproduced" in inspect.signature(make).parameters
        except (TypeError, ValueError):
            takes = False
        return self.cache.get("offset_basis", self.key(sm), None,
                              lambda: make(sm, reproduced=origin) if takes else make(sm))

    def positions(self, motion: Motion):
        """World joint positions ``(F, J, 3)`` of ``motion`` (``forward_kinematics(motion)[0]``, read-only),
        once per motion: ``keep_contacts`` reads the source's on every replay."""
        def make():
            p = forward_kinematics(motion)[0]
            p.setflags(write=False)
            return p
        return self.cache.get("positions", self.key(motion), None, make)

    def wand_graph(self, motion: Motion):
        """The sigma-independent pose graph of ``motion`` (Dean et al. 2018, §3.1), once per motion."""
        return self.cache.get("graph", self.key(motion), None, lambda: _wand().pose_graph(motion))

    def wand_basis(self, motion: Motion, sigma: float | None):
        """The Green's eigenbasis of ``motion`` for ``sigma`` (§3.2), once per (motion, sigma); the graph is
        shared by every sigma."""
        sigma = None if sigma is None else float(sigma)
        return self.cache.get("basis", self.key(motion), sigma,
                              lambda: self.wand_graph(motion).basis(sigma))

    def falloff(self, motion: Motion, frame: int, sigma: float | None, frame_range=None):
        """The magic wand's falloff ``(F,)`` of ``motion`` around ``frame`` (Dean et al. 2018, §3.3), from the
        cached basis of ``sigma``, once per (motion, frame, sigma, frame range): a slider that replays a
        propagated pose edit or a timing region reads it, it does not recompute it."""
        sigma = None if sigma is None else float(sigma)
        fr = None if frame_range is None else (int(frame_range[0]), int(frame_range[1]))

        def make():
            w = _wand().greens_falloff(self.wand_basis(motion, sigma), int(frame), fr)
            w.setflags(write=False)
            return w
        return self.cache.get("falloff", self.key(motion), (int(frame), sigma, fr), make)

    def reference(self, ref) -> Motion:
        """The warp reference ``ref`` (``"self"``, ``("segment", a, b)`` or ``("path", p)``) as a Motion."""
        if ref == "self":
            return self.source
        if ref[0] == "path" and ref[1] in self.memory_references:
            return self.memory_references[ref[1]]
        return self.cache.get("reference", ref, None, lambda: self._load_reference(ref))

    def _load_reference(self, ref) -> Motion:
        if ref[0] == "segment":
            a, b = ref[1:]
            src = self.source
            start = max(0, int(round(a / src.frame_time)))
            stop = min(src.num_frames, int(round(b / src.frame_time)) + 1)
            if stop - start < 3:
                raise ValueError(f"reference.segment: [{a}, {b}] s holds fewer than 3 frames")
            return src.slice(start, stop)
        try:
            return read_bvh(ref[1])  # a regular file within the size limit (io._common.read_regular_file)
        except ValueError as e:
            raise ValueError(f"reference.path: {e}") from None

    def warp_tables(self, motion: Motion, ref, skip: int, upsample: int, reverse: bool = False, k: int = 3,
                    progress: Callable | None = None):
        """Guided time warping's features and kNN score tables (Hsu et al. 2007, §3.2), once per (input,
        reference, skip, upsampling, direction, kNN count); not per duration: a duration change re-runs only
        the DP. A finished exact table of a larger skip (e.g. the slider's largest, warmed by ``Session.warm``) serves a
        smaller skip by slicing (:func:`~stagger_nb.timewarp.slice_tables`, the same numbers), uncached."""
        reference = self.reference(ref)  # keyed by the resolved clip: a re-registered in-memory name is new
        owner, rkey, skip = self.key(motion), self.key(reference), int(skip)
        rest = (int(upsample), bool(reverse)) + (() if k == 3 else (int(k),))
        own = self.cache.peek("warp", owner, (rkey, skip) + rest)
        if own is not None:
            self.cache.touch("warp", [(owner, (rkey, skip) + rest)])
            return own
        for s in range(127, skip, -1):   # the largest skip validate_skip allows
            big = self.cache.peek("warp", owner, (rkey, s) + rest)
            if big is not None and big.knn == "exact":
                self.cache.touch("warp", [(owner, (rkey, s) + rest)])
                return _timewarp().slice_tables(big, skip)
        return self.cache.get("warp", owner, (rkey, skip) + rest,
                              lambda: _timewarp().prepare_warp(motion, reference, skip, int(upsample),
                                                               reverse=bool(reverse), k=int(k), progress=progress))


class Run:
    """What a runner may use while running one op: the cached ``heads``, the Motion the current staggered
    representation was extracted from (``origin``), where to leave notes and the warp curve, and
    ``progress``: ``callable(fraction in [0, 1])`` or None, passed to the long computations of the op (the
    staggered extraction and cull refits, guided warping's tables and solve)."""

    def __init__(self, heads: Heads, origin, progress: Callable | None = None):
        self.heads = heads
        self.progress = progress
        self._origin = origin  # a Motion, or a callable giving it (found only when a runner asks)
        self.notes: list[str] = []
        self.warp: np.ndarray | None = None

    @property
    def origin(self) -> Motion:
        if callable(self._origin):
            self._origin = self._origin()
        return self._origin

    @origin.setter
    def origin(self, motion: Motion) -> None:
        self._origin = motion

    def origin_or_lazy(self):
        """The origin as held now: a Motion, or the callable that finds it (not called: the next op's run
        takes it over and calls it only if its runner asks)."""
        return self._origin

    def note(self, message: str) -> None:
        if message:
            self.notes.append(message)


def convert(state, needs: str, run: Run):
    """``state`` as the kind the op ``needs``: a Motion is extracted (cached), a staggered state evaluated."""
    is_motion = isinstance(state, Motion)
    if needs == "motion":
        return state if is_motion else _staggered().evaluate(state)
    if needs == "staggered" and is_motion:
        run.origin = state
        return run.heads.extract(state, run.progress if run is not None else None)
    return state


# --------------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------------
def _joint(skeleton: Skeleton, name: str, field: str) -> int:
    try:
        return skeleton.index(name)
    except KeyError:
        raise ValueError(f"{field}: no joint named {name!r} in this skeleton") from None


def apply_pose_deltas(pose_quats: np.ndarray, skeleton: Skeleton, deltas, field: str = "deltas") -> np.ndarray:
    """Rotate joints of one pose in their own frames: ``q_j <- q_j * exp(r_j)``.

    Parameters
    ----------
    pose_quats : ndarray, shape (J, 4), local rotations (x, y, z, w)
    deltas : {joint name: [rx, ry, rz]} (or ``((name, (rx, ry, rz)), ...)``) rotation vectors in **degrees**,
        in the joint's local frame

    Returns
    -------
    ndarray, shape (J, 4): edited local rotations (a new array)
    """
    out = np.array(pose_quats, dtype=float)
    for name, rv in (deltas.items() if isinstance(deltas, dict) else deltas):
        j = _joint(skeleton, name, f"{field}.{name}")
        out[j] = quat_mul(out[j], rotvec_to_quat(np.radians(np.asarray(rv, dtype=float))))
    return out


def _frame(m: Motion, f: int, field: str = "frame") -> int:
    if f >= m.num_frames:
        raise ValueError(f"{field}: {f} is outside the motion's {m.num_frames} frames")
    return f


def _pose(sm, k: int, field: str = "pose") -> int:
    if k >= sm.num_poses:
        raise ValueError(f"{field}: {k} is outside the {sm.num_poses} poses")
    return k


def _warp_frames(m: Motion, duration: float) -> int:
    """Output frames of a warp to ``duration`` seconds at the input's frame time (at most
    ``MAX_WARP_RATIO`` times the input's frames: an absurd duration must not allocate memory for it)."""
    n = duration / m.frame_time
    if n > MAX_WARP_RATIO * m.num_frames:
        raise ValueError(f"duration: {duration:g} s is more than {MAX_WARP_RATIO} times the input's "
                         f"{m.duration:g} s")
    return max(2, int(round(n)) + 1)


def _needs(name: str) -> Callable:
    """The staggered function ``name`` (a clear error while another engineer's function has not landed)."""
    f = getattr(_staggered(), name, None)
    if f is None:
        raise ValueError(f"op needs staggered.{name}, which this version of stagger_nb does not have yet")
    return f


# --------------------------------------------------------------------------------------------------
# runners
# --------------------------------------------------------------------------------------------------
def _extract(st, op, run):
    if isinstance(st, Motion):
        return convert(st, "staggered", run)
    return st


def _cull(sm, op: O.Cull, run):
    if op.keep is None:
        return run.heads.cull(sm, op.percent, op.count, run.progress)
    K = sm.num_poses
    for i, k in enumerate(op.keep):
        _pose(sm, k, f"keep[{i}]")
    drop = sorted(set(range(1, K - 1)) - set(op.keep), reverse=True)  # the first and last pose stay
    delete = _staggered().delete_pose
    for k in drop:  # from the end: lower indices stay valid
        sm = delete(sm, k)
    return sm


# -- the magic wand's falloff on the staggered poses (issue 24) ---------------------------------------
def _pose_source_frames(sm, origin: Motion) -> np.ndarray:
    """Source frame (fractional) of every pose of ``sm``: its time in ``origin`` (the motion it was extracted
    from, frame f at ``f * frame_time``), before any retiming (``staggered.source_pose_times``)."""
    st = _staggered()
    times = st.source_pose_times(sm) if hasattr(st, "source_pose_times") else np.asarray(sm.pose_times)
    return np.asarray(times, dtype=float) / origin.frame_time


def falloff_at_poses(sm, run, frame: int, sigma, frame_range, field: str) -> np.ndarray:
    """The falloff of ``run.origin`` around source ``frame`` read at every pose's source time (linear between
    frames; 0 outside ``frame_range``), shape (K,)."""
    origin = run.origin
    F = origin.num_frames
    if frame_range is not None and frame_range[1] > F:
        raise ValueError(f"{field}frame_range: [{frame_range[0]}, {frame_range[1]}) runs past the "
                         f"{F} frames of the motion the poses were extracted from")
    if not 0 <= frame < F:
        raise ValueError(f"{field}frame: {frame} is outside the {F} frames of the motion the poses were "
                         "extracted from")
    if frame_range is not None and not frame_range[0] <= frame < frame_range[1]:
        raise ValueError(f"{field}frame_range: the edited pose's source frame {frame} is outside "
                         f"[{frame_range[0]}, {frame_range[1]})")
    w = run.heads.falloff(origin, frame, sigma, frame_range)
    return np.interp(_pose_source_frames(sm, origin), np.arange(F), w, left=0.0, right=0.0)


def pose_spread(sm, poses, run, sigma, frame_range) -> np.ndarray:
    """Weights ``(E, K)`` spreading the edits of ``poses`` (E pose indices) to every pose: each edited pose's
    falloff (Dean et al. 2018, §3.3) at the poses' source times, combined as the wand combines several edits
    (``wand.propagate_logs``, ``combine="interpolate"``): each edited pose gets exactly its own change (1 on its
    own column, 0 on the other edited poses'), the others the falloff-weighted sum (Eq. 5 in the log map)."""
    poses = [int(k) for k in poses]
    frames = np.rint(_pose_source_frames(sm, run.origin)[poses]).astype(int)
    F = run.origin.num_frames
    frames = np.clip(frames, 0, F - 1)
    W = np.stack([falloff_at_poses(sm, run, int(f), sigma, frame_range, "") for f in frames])
    W[np.arange(len(poses)), poses] = 1.0          # the edited pose itself (its own frame: 1, §3.3)
    if len(poses) > 1:
        M = W[:, poses].T                          # M[a, e] = w_e(pose a)
        W = np.linalg.lstsq(M, np.eye(len(poses)), rcond=1e-10)[0].T @ W
        W[:, poses] = np.eye(len(poses))           # exactly (rounding of the solve)
    return W


def _timing_weights(sm, op, run):
    """``op.falloff``'s weights at the poses, (K,), or None without a region."""
    if op.falloff is None:
        return None
    r = dict(op.falloff)
    return falloff_at_poses(sm, run, r["frame"], r["sigma"], r["frame_range"], "falloff.")


def _weights_kw(weights) -> dict:
    return {} if weights is None else {"weights": weights}


def _succession(sm, op: O.Succession, run):
    return _staggered().succession(sm, root=op.root, s=op.s, l=op.l, joints=_list(op.joints), limit=op.limit,
                                   **_weights_kw(_timing_weights(sm, op, run)))


def _random_timing(sm, op: O.RandomTiming, run):
    return _staggered().random_timing(sm, joints=_list(op.joints), tau=op.tau, seed=op.seed, limit=op.limit,
                                      **_weights_kw(_timing_weights(sm, op, run)))


def _list(x):
    return None if x is None else list(x)


def _exaggerate(sm, op: O.Exaggerate, run):
    poses = list(range(sm.num_poses)) if op.poses is None else [_pose(sm, k, "poses") for k in op.poses]
    if isinstance(op.reference, int):
        _pose(sm, op.reference, "reference")
    basis = run.heads.offset_basis(sm, run.origin)
    spread = pose_spread(sm, poses, run, op.sigma, op.frame_range) if op.propagate else None
    return _staggered().exaggerate(sm, poses, op.w_r, reference=op.reference, mode=op.mode,
                                   joints=_list(op.joints), **({} if basis is None else {"basis": basis}),
                                   **_weights_kw(spread))


def _radians(deltas) -> dict:
    return {name: np.radians(np.asarray(rv, dtype=float)) for name, rv in deltas}


def _edit_pose(sm, op: O.EditPose, run):
    k = _pose(sm, op.pose)
    kw = _weights_kw(pose_spread(sm, [k], run, op.sigma, op.frame_range)[0] if op.propagate else None)
    if op.targets is not None:
        for name, _ in op.targets:
            _joint(sm.skeleton, name, f"targets.{name}")
        return _staggered().edit_pose(sm, k, target={n: np.asarray(q, dtype=float) for n, q in op.targets},
                                      mode=op.mode, **kw)
    return _staggered().edit_pose(sm, k, deltas=_radians(op.deltas), mode=op.mode, **kw)


def _retime(sm, op: O.Retime, run):
    return _staggered().retime(sm, {_pose(sm, op.pose): op.time})


def _refine(sm, op: O.Refine, run):
    _joint(sm.skeleton, op.joint, "joint")
    return _needs("refine")(sm, _pose(sm, op.pose), op.joint, op.time)


def _insert_pose(sm, op: O.InsertPose, run):
    return _staggered().insert_pose(sm, op.time)


def _delete_pose(sm, op: O.DeletePose, run):
    return _staggered().delete_pose(sm, _pose(sm, op.pose))


def _keep_contacts(state, op: O.KeepContacts, run):
    origin = run.origin
    hold = getattr(_staggered(), "hold_plants", None)
    if hold is None:              # a staggered without the plants layer's result form
        return _needs("keep_contacts")(state, origin, source_positions=run.heads.positions(origin))
    res = hold(state, origin, source_positions=run.heads.positions(origin))
    for note in res.notes:        # no legs found, plants out of reach: Session.messages() shows them
        run.note(note)
    return res.motion


def _ik_pose(sm, op: O.IKPose, run):
    k = _pose(sm, op.pose)
    kw = _weights_kw(pose_spread(sm, [k], run, op.sigma, op.frame_range)[0] if op.propagate else None)
    res = _needs("ik_pose")(sm, k, op.joint, np.asarray(op.target, dtype=float), **kw)
    run.note(getattr(res, "message", ""))
    return res.staggered


def _edit_frame(m, op: O.EditFrame, run):
    f = _frame(m, op.frame)
    q = np.array(m.local_quats)
    q[f] = apply_pose_deltas(q[f], m.skeleton, op.deltas)
    return m.replace(local_quats=q)


def _edit_frames(m: Motion, ops) -> Motion:
    """A run of ``edit_frame`` ops in one pass, O(F J + n) instead of O(n F J): the deltas of every op are
    turned into quaternions at once, then applied in layers (the t-th rotation of each (frame, joint) in
    layer t, so each joint's rotations compose in op order), each product renormalised as a Motion
    renormalises (only what is off unit); one Motion at the end. A failing op raises ValueError with
    ``offset``, its place in ``ops``."""
    sk, F = m.skeleton, m.num_frames
    rows_f, rows_j, rows_r = [], [], []
    for k, op in enumerate(ops):
        try:
            f = _frame(m, op.frame)
            for name, rv in op.deltas:
                rows_j.append(_joint(sk, name, f"deltas.{name}"))
                rows_f.append(f)
                rows_r.append(rv)
        except ValueError as e:
            e.offset = k
            raise
    q = np.array(m.local_quats)
    if not rows_f:
        return m
    fj = np.asarray(rows_f) * sk.num_joints + np.asarray(rows_j)
    e = rotvec_to_quat(np.radians(np.asarray(rows_r, dtype=float)))
    order = np.argsort(fj, kind="stable")                 # each (frame, joint)'s rows, in op order
    sorted_fj = fj[order]
    start = np.r_[0, np.flatnonzero(np.diff(sorted_fj)) + 1]
    rank = np.empty(len(fj), dtype=int)
    rank[order] = np.arange(len(fj)) - np.repeat(start, np.diff(np.r_[start, len(fj)]))
    flat = q.reshape(F * sk.num_joints, 4)
    for t in range(int(rank.max()) + 1):
        idx = np.flatnonzero(rank == t)
        row = quat_mul(flat[fj[idx]], e[idx])
        off = np.abs(np.sqrt(np.einsum("ji,ji->j", row, row)) - 1.0) > _UNIT_TOL
        if off.any():
            row[off] = quat_normalize(row[off])
        flat[fj[idx]] = row
    return m.replace(local_quats=q)


def _propagate(m, op: O.Propagate, run):
    edits = op.edits
    frames = [_frame(m, f, "frame" if op.frames is None else f"frames[{i}]") for i, (f, _) in enumerate(edits)]
    edited = np.stack([apply_pose_deltas(m.local_quats[f], m.skeleton, d, "deltas") for f, d in edits])
    fr = None if op.frame_range is None else tuple(op.frame_range)
    return _wand().propagate(m, frames if op.frames is not None else frames[0],
                             edited if op.frames is not None else edited[0], frame_range=fr,
                             repetitions=op.repetitions == "keep", basis=run.heads.wand_basis(m, op.sigma))


def warp_size(m: Motion, op: O.GuidedWarp) -> tuple[int | None, int]:
    """``(output frames or None for free length, upsampling factor)`` of a guided warp of ``m``."""
    n = None if op.free_length else _warp_frames(m, op.duration)
    u = op.upsample
    if u is None:
        u = _timewarp().required_upsample(m.num_frames, n)
        if n == m.num_frames:
            u = max(u, 2)  # same duration: without upsampling the only warp is the identity (§3.1)
    if n is not None and n > (m.num_frames - 1) * u + 1:
        raise ValueError(f"upsample: {u} gives {(m.num_frames - 1) * u + 1} searched frames, fewer than the "
                         f"{n} output frames of duration {op.duration:g} s")
    return n, u


def warp_table_key(m: Motion, op) -> tuple:
    """``(reference JSON, upsample, backward, k)``: what chooses a guided warp's tables besides the skip (an
    editor re-warms its skip slider's tables only when this changes). ``op`` is a guided_warp dict or op."""
    op = op if isinstance(op, O.GuidedWarp) else O.Op.from_json(dict(op, op="guided_warp"), "op")
    n, u = warp_size(m, op)
    return (repr(op.to_json().get("reference")), u, bool(op.backward), warp_k(n))


def warp_k(num_frames: int | None) -> int:
    """kNN count of a guided warp's tables: ``timewarp.FREE_K`` for free length (``num_frames`` None), else 3."""
    return _timewarp().FREE_K if num_frames is None else 3


def _guided_warp(m, op: O.GuidedWarp, run):
    tw = _timewarp()
    n, u = warp_size(m, op)
    p = run.progress
    k = warp_k(n)
    tables = run.heads.warp_tables(m, op.reference, op.skip, u, op.backward, k,
                                   None if p is None else (lambda f: p(0.9 * f)))
    out, warp = tw.guided_warp(m, tables.reference, n, skip=op.skip, keytimes=_pairs(op.keytimes),
                               upsample=u, reverse=op.backward, k=k, tables=tables, progress=p)  # 0.9 .. 1 here
    run.warp = warp
    return out


def even_upsample(n: int, num_frames: int, u: int, most: int = 16) -> int:
    """The upsampling factor of a guided warp of ``n`` input frames to ``num_frames`` near the default ``u``
    (``u - 1 .. u + 1``, at least what the length needs) whose mean step ``(n - 1) u' / (num_frames - 1)``
    upsampled frames per output frame is nearest a whole number: the search's speeds are multiples of ``1 / u'``,
    so a reference timed uniformly (a take played 1.5x slower) is followed at one speed instead of alternating
    two (measured on CMU 131_01, 994 frames to 1491: ``u = 4`` plays 0.75x for 18 s, then 0.25x; ``u = 3``
    plays 0.667x throughout, pose spacings 1.49-1.56x). Ties go to the default."""
    need = max(1, -(-(num_frames - 1) // (n - 1)))

    def off(c):  # distance of the mean step from a whole number of upsampled frames
        step = (n - 1) * c / (num_frames - 1)
        return abs(step - round(step))
    best = min(range(max(need, u - 1), min(most, u + 1) + 1), key=lambda c: (round(off(c), 9), c != u, c))
    if num_frames == n:
        best = max(best, 2)        # same duration: without upsampling the only warp is the identity (§3.1)
    return best


def _guide_poses(sm, op: O.GuidePoses, run):
    """The pose times ``t_k`` of ``sm`` mapped through the guided warp of ``run.origin`` (the motion the poses
    were extracted from) to the reference: ``t̂_k = W⁻¹(t_k)`` with ``W`` the warp (output time -> input time,
    Hsu et al. 2007), then ``staggered.retime`` (§5.2): refinements, splines and displacement maps follow."""
    tw = _timewarp()
    origin = run.origin
    reference = run.heads.reference(op.reference)
    wop = op.warp_op(reference.duration)
    n, u = warp_size(origin, wop)
    if n is not None and op.upsample is None:
        u = even_upsample(origin.num_frames, n, u)
    k = warp_k(n)
    p = run.progress
    tables = run.heads.warp_tables(origin, wop.reference, wop.skip, u, False, k,
                                   None if p is None else (lambda f: p(0.9 * f)))
    _, warp = tw.guided_warp(origin, tables.reference, n, skip=wop.skip, keytimes=_pairs(wop.keytimes),
                             upsample=u, k=k, tables=tables, progress=p)
    run.warp = warp
    t = np.asarray(sm.pose_times, dtype=float)
    end = origin.duration
    if t[-1] > end + 1e-9 or t[0] < -1e-9:
        raise ValueError(f"the pose times run over [{t[0]:g}, {t[-1]:g}] s, outside the {end:g} s the warp maps "
                         "(an op before this one stretched them; guide the poses before retiming them)")
    xs, inverse = np.unique(np.maximum.accumulate(warp), return_inverse=True)
    out_times = np.arange(warp.size) * origin.frame_time
    ys = np.bincount(inverse, out_times) / np.bincount(inverse)   # a pause in the warp: its middle
    new = np.interp(t, xs, ys)
    if not np.all(np.diff(new) > 0):
        bad = int(np.argmin(np.diff(new)))
        raise ValueError(f"the warp plays poses {bad} and {bad + 1} at the same time ({new[bad]:.4f} s); "
                         "a smaller skip or more keytimes keep them apart")
    return _staggered().retime(sm, new)


def _pairs(keytimes):
    return None if keytimes is None else [list(p) for p in keytimes]


def _linear_warp(m, op: O.LinearWarp, run):
    out, warp = _timewarp().linear_warp(m, _warp_frames(m, op.duration), keytimes=_pairs(op.keytimes))
    run.warp = warp
    return out


def _resample(m, op: O.Resample, run):
    if m.duration / op.frame_time > MAX_WARP_RATIO * m.num_frames:
        raise ValueError(f"frame_time: {op.frame_time:g} s gives more than {MAX_WARP_RATIO} times the "
                         f"input's {m.num_frames} frames")
    return m.resample(op.frame_time)


#: Runner of each op type. A new op is an :class:`~.ops.Op` subclass plus an entry here.
RUNNERS: dict[type, Callable] = {
    O.Extract: _extract, O.Cull: _cull, O.Succession: _succession, O.RandomTiming: _random_timing,
    O.Exaggerate: _exaggerate, O.EditPose: _edit_pose, O.Retime: _retime, O.Refine: _refine,
    O.InsertPose: _insert_pose, O.DeletePose: _delete_pose, O.KeepContacts: _keep_contacts, O.IKPose: _ik_pose,
    O.GuidePoses: _guide_poses,
    O.EditFrame: _edit_frame, O.Propagate: _propagate, O.GuidedWarp: _guided_warp,
    O.LinearWarp: _linear_warp, O.Resample: _resample,
}

#: Runners over a run of consecutive ops of one kind on a Motion, ``(motion, ops) -> motion``: the replay uses
#: them for runs of two or more (a session of 10^5 ``edit_frame`` ops replays in seconds, not a minute).
BATCHED: dict[type, Callable] = {O.EditFrame: _edit_frames}
