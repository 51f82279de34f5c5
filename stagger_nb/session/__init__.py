"""Edit sessions: a source motion plus an ordered list of JSON-serialisable operations.

An *op* is a plain dict such as ``{"op": "succession", "root": "LeftShoulder", "s": 0.03, "l": 2.0}``;
inside the session it is a typed frozen dataclass (:mod:`.ops`). Replaying the ops in order on the source
motion gives the edited motion; this is what makes a notebook's edits reproducible (DESIGN.md, "session").
The state flowing through the ops is a :class:`~stagger_nb.core.Motion` or a staggered-pose representation
(``staggered.StaggeredMotion``): staggered ops extract first (Coleman et al. 2008, §4; the extraction is
cached), motion ops evaluate first (§3).

One module per job:

- :mod:`.ops` — one frozen dataclass per op, ``from_json`` / ``to_json``, every field checked;
- :mod:`.runners` — op -> function over the state, and the cached expensive heads;
- :mod:`.history` — the op list, undo/redo, observers;
- :mod:`.cache` — the one cache (one lock, compute-once futures, content/weakref keys, bounded);
- :mod:`.files` — save/load/export and the JSON motion format, with the path and overwrite guards;
- :mod:`.warm` — the session's background worker for :meth:`Session.warm`;
- :mod:`.progress` — :func:`progress_bar`, a tqdm bar as the ``progress`` callback of ``edited``/``warm``.

Replay is linear in the number of ops: each prefix is named by a digest chained from the previous one
(``digest_i = H(digest_{i-1}, op_i)``), so changing the last op (a slider move) replays only the tail and
nothing is re-serialised per prefix. Ops are validated on the way in (``add``/``set_ops``) and when a session
file is loaded: an unknown op, an unknown or missing field or a wrongly typed value raises ``ValueError``
naming the field (e.g. ``ops[2].s``).

This package does not import ipywidgets; the widgets build on it.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import threading
import warnings
from collections import OrderedDict
from concurrent.futures import Future
from typing import Any, Callable

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_to_rotvec
from ..io._common import atomic_write_bytes, file_path, read_regular_file
from ..io.bvh import write_bvh
from . import ops as _ops_module
from .cache import Cache
from .files import (SESSION_FORMAT, SESSION_VERSION, check_export_target, check_save_target, export_gltf,
                    motion_from_json, motion_to_json, read_session_json, read_source,
                    session_bytes)
from .history import Flag, History
from .ops import OPS, Op, _fail, check_extract_options, number, text, validate_op
from .runners import RUNNERS, Heads, Run, apply_pose_deltas, convert, warp_k, warp_size, warp_table_key
from .progress import ProgressBar, progress_bar
from .warm import Worker

__all__ = ["Session", "Op", "OPS", "validate_op", "apply_pose_deltas", "joint_rotation_degrees",
           "SESSION_FORMAT", "SESSION_VERSION", "progress_bar", "ProgressBar"]

_percent = number(0.0, 100.0, open_lo=True)
_sigma = _ops_module.optional(number(0.0, open_lo=True))


_REQUIRED = dataclasses.MISSING


def register_op(name: str, needs: str, fields: dict, run: Callable) -> type:
    """Deprecated: define an :class:`~.ops.Op` subclass and add its runner to ``runners.RUNNERS``.

    Kept for old code: builds that subclass from ``fields`` (``{field: (check(value, field) or None,
    default)}``, ``Session.REQUIRED`` for a required field) and registers ``run(state, params: dict, run)``,
    which now receives the op's JSON dict and a :class:`~.runners.Run` (``run.heads`` has the cached heads)."""
    warnings.warn("register_op is deprecated: subclass stagger_nb.session.ops.Op and add the runner to "
                  "stagger_nb.session.runners.RUNNERS", DeprecationWarning, stacklevel=2)
    if needs not in ("staggered", "motion", "any"):
        raise ValueError(f"needs: expected 'staggered', 'motion' or 'any', got {needs!r}")
    order = sorted(fields.items(), key=lambda kv: kv[1][1] is not _REQUIRED)  # required fields first
    spec = [(k, Any, dataclasses.field(default=d, metadata={"check": c}) if d is not _REQUIRED
             else dataclasses.field(metadata={"check": c})) for k, (c, d) in order]
    cls = dataclasses.make_dataclass(f"_Registered_{name}", spec, bases=(Op,), frozen=True,
                                     namespace={"name": name, "needs": needs, "__annotations__": {}})
    RUNNERS[cls] = lambda state, op, r: run(state, op.to_json(), r)
    return cls


def __getattr__(attr):  # deprecated module attributes
    if attr == "OP_REGISTRY":
        warnings.warn("OP_REGISTRY is deprecated: use stagger_nb.session.OPS (op classes by name)",
                      DeprecationWarning, stacklevel=2)
        return OPS
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


def joint_rotation_degrees(motion: Motion, joint) -> np.ndarray:
    """Local rotation of ``joint`` (name or index) over time as a rotation vector, shape (F, 3), degrees."""
    j = motion.skeleton.index(joint) if isinstance(joint, str) else int(joint)
    return np.degrees(quat_to_rotvec(motion.local_quats[:, j]))


class _Info:
    """What the replay remembers of one step besides its state (small; kept for every op of recent
    replays): the warp curve it computed (if a warp), its notes, whether its state is staggered, and the
    timing-warning summary of that state (filled on demand)."""

    __slots__ = ("warp", "notes", "staggered", "summary", "warnings")

    def __init__(self, warp, notes, staggered: bool):
        self.warp, self.notes, self.staggered = warp, tuple(notes), staggered
        self.summary = self.warnings = None


def _share(progress: Callable | None, done: int, total: int, a: float, b: float, label: str):
    """``report(fraction)`` mapping an op's step onto ``progress(done + a + (b - a) * fraction, total, label)``
    (None without ``progress``)."""
    if progress is None:
        return None
    return lambda f: progress(done + a + (b - a) * min(max(float(f), 0.0), 1.0), total, label)


def _timing_summary(state, found) -> str:
    """One plain sentence about the timing edits of the staggered ``state`` ('' when none needs saying):
    ``staggered.timing_summary`` (a limited delay, or knots that cross), §5.2; ``found`` (the detailed
    ``timing_warnings``) is shown beside it on demand."""
    from .. import staggered
    summarize = getattr(staggered, "timing_summary", None)
    if summarize is not None:
        return summarize(state)
    return staggered.summarize_timing_warnings(found)


def _chain(previous: str, op: Op) -> str:
    return hashlib.blake2b(f"{previous}\n{op.key}".encode(), digest_size=16).hexdigest()


class Session:
    """A source motion plus an ordered list of ops; :meth:`edited` replays them.

    Parameters
    ----------
    source : Motion
        The unedited motion (never modified).
    ops : list of op dicts (or :class:`~.ops.Op`), optional
        Validated with :meth:`Op.from_json <stagger_nb.session.ops.Op.from_json>`.
    source_path : str, optional
        The file ``source`` was read from; saved sessions refer to it (with its SHA-256) instead of
        embedding the motion, and :meth:`save` / :meth:`export_bvh` refuse to overwrite it.
    extract_options : dict, optional
        Keyword arguments for ``staggered.extract`` (checked: names, types, ranges; saved with the session).

    Notes
    -----
    Each op list change (``add``, ``set_ops``, ``replace``, ``remove``, ``clear``) is one undo step.
    Listeners registered with :meth:`observe` are called as ``listener(session)`` after every change.
    """

    REQUIRED = _REQUIRED  # deprecated with register_op

    def __init__(self, source: Motion, ops=None, source_path=None, extract_options=None):
        if not isinstance(source, Motion):
            raise ValueError(f"source: expected a Motion, got {type(source).__name__}")
        self.source = source
        self.source_path = None if source_path is None else os.path.abspath(file_path(source_path, "source_path"))
        self.extract_options = check_extract_options(extract_options)
        self._busy_listeners: list[Callable] = []
        self._ctx = Heads(Cache(busy=self._busy), source, self.extract_options)
        self._history = History(self._typed_list(ops or [], "ops"), owner=self)
        self._keys_of: tuple = ()       # the op tuple self._keys was computed for
        self._keys: list[str] = []      # digest of each op prefix (ops[:i + 1])
        self._info: OrderedDict = OrderedDict()   # prefix digest -> _Info, LRU (bounded in _walk)
        self._held: dict[str, Any] = {}  # strong refs: the last replay's final and last staggered state
        self._replayed = False
        self._replay_lock = threading.RLock()
        self._worker = Worker()

    @classmethod
    def from_bvh(cls, path, ops=None, **kwargs) -> "Session":
        """Read ``path`` as the source motion (remembering the path)."""
        motion, _ = read_source(file_path(path, "path"), "path")
        return cls(motion, ops, source_path=path, **kwargs)

    # -- ops ---------------------------------------------------------------------------------------
    @staticmethod
    def _typed(op, where: str) -> Op:
        return op if isinstance(op, Op) else Op.from_json(op, where)

    @classmethod
    def _typed_list(cls, ops, where) -> tuple:
        if not isinstance(ops, (list, tuple)):
            _fail(where, "a list of op objects", ops)
        _ops_module._limit(ops, where)
        return tuple(cls._typed(op, f"{where}[{i}]") for i, op in enumerate(ops))

    @property
    def ops(self) -> list:
        """The current op list as JSON dicts (fresh copies: editing them does not edit the session)."""
        return [op.to_json() for op in self._history.ops]

    @property
    def typed_ops(self) -> tuple:
        """The current op list as typed, immutable :class:`~.ops.Op` objects."""
        return self._history.ops

    def __len__(self) -> int:
        return len(self._history.ops)

    def set_ops(self, ops) -> bool:
        """Replace the whole op list (one undo step); returns False when nothing changed."""
        return self._history.commit(self._typed_list(ops, "ops"))

    def add(self, op) -> bool:
        """Append one op."""
        cur = self._history.ops
        return self._history.commit(cur + (self._typed(op, f"ops[{len(cur)}]"),))

    def _index(self, index: int) -> int:
        n = len(self._history.ops)
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or not -n <= index < n:
            raise ValueError(f"index: {index!r} is outside the {n} ops")
        return int(index) % n

    def replace(self, index: int, op) -> bool:
        """Replace op ``index`` (negative indices count from the end)."""
        i = self._index(index)
        new = list(self._history.ops)
        new[i] = self._typed(op, f"ops[{i}]")
        return self._history.commit(new)

    def remove(self, index: int) -> bool:
        i = self._index(index)
        new = list(self._history.ops)
        del new[i]
        return self._history.commit(new)

    def clear(self) -> bool:
        return self._history.commit(())

    @property
    def can_undo(self) -> Flag:
        """Whether :meth:`undo` would change something (a bool that may also be called: ``can_undo()``)."""
        return Flag(self._history.can_undo)

    @property
    def can_redo(self) -> Flag:
        return Flag(self._history.can_redo)

    def undo(self) -> bool:
        """Go back one change; returns False when there is nothing to undo."""
        return self._history.undo()

    def redo(self) -> bool:
        return self._history.redo()

    def observe(self, listener: Callable) -> None:
        """Call ``listener(session)`` after every change of the op list (undo and redo included)."""
        self._history.observe(listener)

    def unobserve(self, listener: Callable) -> None:
        self._history.unobserve(listener)

    def observe_busy(self, listener: Callable) -> None:
        """Call ``listener(kind, started)`` around expensive cached computations (``"extract"``, ``"cull"``,
        ``"graph"``, ``"basis"``, ``"warp"``, ``"reference"``), e.g. to show a progress bar. Called from the
        computing thread (the :meth:`warm` worker included)."""
        self._busy_listeners.append(listener)

    def _busy(self, kind: str, started: bool) -> None:
        for f in list(self._busy_listeners):
            f(kind, started)

    # -- replay ------------------------------------------------------------------------------------
    def _prefix_keys(self) -> list[str]:
        """Digest of each op prefix, chained (O(1) per op; recomputed only from the first changed op)."""
        ops = self._history.ops
        if ops is not self._keys_of:
            old_ops, old = self._keys_of, self._keys
            same = 0
            while same < min(len(ops), len(old_ops)) and ops[same] is old_ops[same]:
                same += 1
            keys = old[:same]
            prev = keys[-1] if keys else "source"
            for op in ops[same:]:
                prev = _chain(prev, op)
                keys.append(prev)
            self._keys_of, self._keys = ops, keys
        return self._keys

    def _available(self, key: str):
        """The state after the prefix ``key`` if held or cached, else None."""
        hit = self._held.get(key)
        return hit if hit is not None else self._ctx.cache.peek("state", key)

    def _walk(self, upto: int, keep_all: bool = False, progress: Callable | None = None):
        """The state after ``ops[:upto]`` of the session's op list (with ``keep_all``, the list of states after
        each of them): :meth:`_run` on the current ops; the last replay's final state is held."""
        with self._replay_lock:
            ops, keys = self._history.ops, self._prefix_keys()
            out = self._run(ops, keys, upto, keep_all, progress)
            if upto:
                self._held = {keys[upto - 1]: out[-1] if keep_all else out}
            if upto == len(ops):
                self._replayed = True
            return out

    def _run(self, ops: tuple, keys: list, upto: int, keep_all: bool = False, progress: Callable | None = None):
        """The state after ``ops[:upto]`` (``keys``: their chained prefix digests), resuming from the latest
        prefix whose state is held or cached and whose earlier steps are known. Linear in ``upto``: each state
        is computed at most once; every computed state goes to the cache under its prefix digest (so any op
        list sharing that prefix, e.g. the session's after an undo or a warmed one, finds it)."""
        with self._replay_lock:
            info, cache = self._info, self._ctx.cache
            known = 0  # steps whose _Info is known, from the start
            while known < upto and keys[known] in info:
                known += 1
            states = [None] * upto
            r = 0
            if keep_all:
                for i in range(known):
                    states[i] = self._available(keys[i])
                r = next((i for i in range(known) if states[i] is None), known)
            else:
                for i in range(known, 0, -1):
                    hit = self._available(keys[i - 1])
                    if hit is not None:
                        states[i - 1], r = hit, i
                        break
            todo = [i for i in range(r, upto) if states[i] is None]
            total = len(todo)
            state = self.source if r == 0 else states[r - 1]
            origin = (lambda r=r, st=list(states[:r]): self._origin(ops, keys[:r], st))  # noqa: E731 (lazy)
            done = 0
            for i in range(r, upto):
                if states[i] is not None:  # keep_all: a cached step past a missing one
                    state = states[i]
                    continue
                op = ops[i]
                if progress is not None:
                    progress(done, total, op.name)
                # the same op on the same state (another prefix reached it: two cull percents keeping the same
                # poses, an undo to an equal edit) is the state computed then: found by the state's content
                # name and the op, not recomputed
                src = cache.token(state)
                seen = cache.peek("step", src, op.key)
                hit = None if seen is None or seen not in info else self._available(seen)
                if hit is not None:
                    if op.needs == "staggered" and isinstance(state, Motion):
                        origin = state   # what convert() would have recorded
                    state, step_info = hit, info[seen]
                else:
                    # an op extracting first reports the extraction as its first half, its own work as the rest
                    split = 0.5 if op.needs == "staggered" and isinstance(state, Motion) else 0.0
                    run = Run(self._ctx, origin, _share(progress, done, total, 0.0, split, f"{op.name} (extract)"))
                    try:
                        state = convert(state, op.needs, run)
                        run.progress = _share(progress, done, total, split, 1.0, op.name)
                        state = RUNNERS[type(op)](state, op, run)
                    except ValueError as e:
                        raise ValueError(f"ops[{i}] ({op.name}): {e}") from None
                    except ArithmeticError as e:  # e.g. a parameter so extreme that the technique divides by 0
                        raise ValueError(f"ops[{i}] ({op.name}): {type(e).__name__}: {e}") from None
                    origin = run._origin
                    step_info = _Info(run.warp, run.notes, not isinstance(state, Motion))
                    cache.put("step", src, op.key, keys[i])
                cache.name(state, keys[i])
                cache.put("state", keys[i], None, state)
                info[keys[i]] = step_info
                if keep_all:
                    states[i] = state  # otherwise only the bounded cache holds it (memory stays flat)
                done += 1
            if progress is not None and total:
                progress(total, total, "done")
            for k in keys[:upto]:  # recently used; the oldest infos go (bounded: a few replays' worth)
                if k in info:
                    info.move_to_end(k)
            while len(info) > max(4096, 2 * len(keys)):
                info.popitem(last=False)
            return states if keep_all else (state if upto else self.source)

    def _origin(self, ops, keys, states) -> Motion:
        """The Motion the staggered state after ``keys`` (prefixes of ``ops``) was extracted from (the source
        by default): the latest Motion state before the last run of staggered states."""
        origin = self.source
        for i in range(len(keys) - 1, -1, -1):
            if not self._info[keys[i]].staggered:
                if i == len(keys) - 1:
                    return origin  # the state is a Motion: an extraction would start from it
                st = states[i] if states[i] is not None else self._run(ops, keys, i + 1)
                return st
        return origin

    def states(self, progress: Callable | None = None) -> list:
        """The state after each op (``len(ops)`` items; Motion or StaggeredMotion).

        ``progress(done, total, label)`` is called before each op that is actually computed.
        """
        with self._worker.foreground():   # the warm-up gives way (session/warm.py)
            return self._walk(len(self._history.ops), keep_all=True, progress=progress)

    def edited(self, progress: Callable | None = None) -> Motion:
        """The source motion with every op applied (a Motion; staggered states are evaluated).

        ``progress(done, total, label)`` is called before each op actually computed, with a fractional
        ``done`` while the op's long step reports (the staggered extraction, a cull refit, guided warping's
        tables and solve), and with ``"done"`` at the end; :func:`progress_bar` makes a tqdm bar of it."""
        n = len(self._history.ops)
        if not n:
            return self.source
        with self._worker.foreground():   # the warm-up gives way (session/warm.py)
            last = self._walk(n, progress=progress)
            if isinstance(last, Motion):
                return last
            try:
                cache = self._ctx.cache   # keyed by the state's content name: every prefix reaching it shares it
                return cache.get("state", cache.token(last), "motion", lambda: convert(last, "motion", None))
            except (ValueError, ArithmeticError) as e:  # evaluating the last staggered state
                raise ValueError(f"ops[{n - 1}] ({self._history.ops[n - 1].name}): evaluating the result: "
                                 f"{e}") from None

    def _last_staggered_index(self) -> int | None:
        n = len(self._history.ops)
        if n:
            self._walk(n)
        keys = self._keys
        return next((i for i in range(n - 1, -1, -1) if self._info[keys[i]].staggered), None)

    def staggered(self, progress: Callable | None = None):
        """The last staggered representation of the replay (after the last staggered op), or the
        extraction of the source when no op is staggered."""
        n = len(self._history.ops)
        if n:
            self._walk(n, progress=progress)
        j = self._last_staggered_index()
        if j is None:
            return self.extraction()
        st = self._walk(j + 1)
        self._held[self._keys[j]] = st
        return st

    def extraction(self):
        """The (cached) staggered extraction of the source motion."""
        return self._ctx.extract(self.source)

    def messages(self) -> list[str]:
        """Plain notes from the last replay, for the user: what a runner reported (an unreachable IK target,
        …) and the one plain timing sentence of the last staggered state (``staggered.timing_summary``: a
        timing edit limited to keep the poses in order, or knots that cross).
        Empty before the first replay."""
        if not self._replayed:
            return []
        with self._replay_lock:
            n = len(self._history.ops)
            keys = self._prefix_keys()
            if any(k not in self._info for k in keys):
                return []  # the op list changed since the last replay
            out = [note for k in keys for note in self._info[k].notes]
            summary, _ = self._warnings_of(n)
            if summary:
                out.append(summary)
        return out

    def timing_warnings(self) -> tuple[str, tuple]:
        """``(summary, warnings)`` of the last staggered state of the replay (§5.2): the one plain sentence
        of :meth:`messages` (``staggered.timing_summary``; '' when none) and ``staggered.timing_warnings`` of
        that state (a tuple of ``TimingWarning``). Both are computed once per state (keyed by the digest of
        the op prefix that made it: a slider move that leaves that state alone, or returns to it, does not
        recompute them); empty when no op is staggered."""
        n = len(self._history.ops)
        if n:
            self._walk(n)
        with self._replay_lock:
            return self._warnings_of(n)

    def _warnings_of(self, n: int) -> tuple[str, tuple]:  # under the replay lock, ops[:n] replayed
        keys = self._prefix_keys()
        j = next((i for i in range(n - 1, -1, -1) if self._info[keys[i]].staggered), None)
        if j is None:
            return "", ()
        inf = self._info[keys[j]]
        if inf.warnings is None:
            from .. import staggered
            state = self._walk(j + 1)
            found = tuple(staggered.timing_warnings(state))
            inf.summary, inf.warnings = _timing_summary(state, found), found
        return inf.summary, inf.warnings

    def warp_curve(self, index: int = -1):
        """The time warp computed by the warp op at ``index``: (N,) input seconds of each output frame
        (None when that op is not a warp)."""
        i = self._index(index)
        self._walk(len(self._history.ops))
        return self._info[self._keys[i]].warp

    # -- cached heads --------------------------------------------------------------------------------
    def precompute_cull(self, percents, stop: Callable | None = None) -> int:
        """Compute and cache ``cull`` of the source's extraction for each of ``percents`` in this thread;
        stops early when ``stop()`` is true. Returns how many were computed or already cached.
        (Prefer :meth:`warm`, which runs on the session's executor.)"""
        n = 0
        sm = self.extraction()
        for pc in percents:
            if stop is not None and stop():
                break
            self._ctx.cull(sm, _percent(pc, "percents[]"))
            n += 1
        return n

    def precompute_wand_bases(self, sigmas, stop: Callable | None = None, motion: Motion | None = None) -> int:
        """Compute and cache the magic-wand eigenbasis for each of ``sigmas`` in this thread; stops early when
        ``stop()`` is true. Returns how many. (Prefer :meth:`warm`.)"""
        n = 0
        for sg in sigmas:
            if stop is not None and stop():
                break
            self.wand_basis(_sigma(sg, "sigmas[]"), motion)
            n += 1
        return n

    def use_reference(self, path: str, motion: Motion) -> dict:
        """Resolve the op reference ``{"path": path}`` to ``motion`` in this session (e.g. an in-memory clip
        under a name like ``"<memory:name>"``) instead of reading the file; returns that reference.
        A saved session keeps only the path: a new process reads the file."""
        if not isinstance(motion, Motion):
            raise ValueError(f"motion: expected a Motion, got {type(motion).__name__}")
        self._ctx.memory_references[text(path, "path")] = motion
        return {"path": path}

    def wand_basis(self, sigma: float | None = None, motion: Motion | None = None):
        """The (cached) magic-wand eigenbasis of ``motion`` (default: the source) for ``sigma``."""
        return self._ctx.wand_basis(self.source if motion is None else motion, sigma)

    def wand_graph(self, motion: Motion | None = None):
        """The (cached) sigma-independent pose graph of ``motion`` (default: the source)."""
        return self._ctx.wand_graph(self.source if motion is None else motion)

    def falloff_curves(self, frame: int, sigma: float | None = None, frame_range=None, compare=(),
                       spline_extent: float | None = None, motion: Motion | None = None) -> dict:
        """Falloff weights around ``frame`` (1 there, 0 far away), each (F,), for the views.

        ``"green"``: the magic wand's Green's-function falloff (Dean et al. 2018, §3.3) with the cached
        basis; ``compare`` may add ``"isomap"`` and ``"diffusion"`` (``1 - normalised distance``, Fig. 3)
        and ``"spline"`` (a generic smoothstep falloff of ``spline_extent`` frames, Fig. 6).
        """
        from .. import wand
        m = self.source if motion is None else motion
        fr = None if frame_range is None else tuple(frame_range)
        f = int(frame)
        out = {"green": wand.greens_falloff(self._ctx.wand_basis(m, sigma), f, fr)}
        sg = None if sigma is None else float(sigma)
        for name in compare:
            if name == "isomap":
                make = lambda: 1.0 - wand.normalize_distance(wand.isomap_distance(m, f), fr)  # noqa: E731
            elif name == "diffusion":
                make = lambda: 1.0 - wand.normalize_distance(wand.diffusion_distance(m, f, sigma=sg), fr)  # noqa: E731
            elif name == "spline":
                extent = spline_extent or max(2.0, m.num_frames / 10)
                make = lambda: wand.spline_falloff(m.num_frames, f, extent)  # noqa: E731
            else:
                raise ValueError(f"compare: unknown curve {name!r}; use 'isomap', 'diffusion', 'spline'")
            key = (name, f, sg, fr, spline_extent if name == "spline" else None)
            out[name] = self._ctx.cache.get("curve", self._ctx.key(m), key, make)
        return out

    # -- background cache fills --------------------------------------------------------------------
    def warm(self, *jobs, progress: Callable | None = None) -> Future:
        """Fill the caches in the background, on the session's own executor (one worker thread).

        Each job is one of

        - ``"extract"``: the staggered extraction of the source;
        - ``("cull", percents)``: ``cull`` of that extraction for each percent (a slider's positions);
        - ``("wand_basis", sigmas)``: the magic wand's pose graph of the source, then its basis per sigma
          (``None`` = the default sigma);
        - ``("warp_tables", warps)``: guided warping's kNN tables of the source for each warp, a
          ``guided_warp`` op (dict or :class:`~.ops.GuidedWarp`) whose reference, skip, duration, free_length,
          backward and upsample choose the table; a table also serves every smaller skip (sliced), so an
          editor warms its skip slider's largest value only.
        - ``("replay", op_lists)``: the replay of each op list (a list of op dicts, checked like
          :meth:`set_ops`) into the cache, step by step under the digest of each op prefix, without changing
          this session's op list or history: a later ``set_ops`` to one of them (a slider's next positions)
          replays nothing. Lists share their common prefixes' states. Bounded by the cache (count and bytes).

        Jobs are checked now (ValueError naming ``jobs[i]``); they run in order, one item at a time.
        ``progress(done, total, label)`` is called from the worker before each item, with a fractional
        ``done`` while an extraction, cull refit or warp table reports how far it is, and once at the end
        (e.g. ``progress=progress_bar("warm")``, a tqdm bar).

        Returns a :class:`concurrent.futures.Future` whose result is the number of items computed (or found
        cached). ``future.cancel()`` stops the work before its next item (the item running finishes and is
        cached) and makes the future cancelled; ``running()`` stays False until it is done. The worker is a
        daemon thread: an interpreter exit does not wait for it. Everything warmed is also computed on
        demand: warming only moves the wait.
        """
        return self._worker.submit(self._warm_items(jobs), progress)

    def _warm_items(self, jobs) -> list:
        items = []
        for i, job in enumerate(jobs):
            where = f"jobs[{i}]"
            name, values = (job, None) if isinstance(job, str) else (
                tuple(job) if isinstance(job, (list, tuple)) and len(job) == 2 else (None, None))
            if name == "extract" and values is None:
                # not held back while the user moves a slider: every replay of theirs waits for it anyway
                items.append(("extract", lambda p: self._ctx.extract(self.source, p), False))
            elif name == "cull" and isinstance(values, (list, tuple, range, np.ndarray)):
                pcs = [_percent(v, f"{where}[1][{k}]") for k, v in enumerate(list(values))]
                items += [(f"cull {p:g} %", lambda r, p=p: self._ctx.cull(self.extraction(), p, progress=r))
                          for p in pcs]
            elif name == "wand_basis" and isinstance(values, (list, tuple, range, np.ndarray)):
                sgs = [_sigma(v, f"{where}[1][{k}]") for k, v in enumerate(list(values))]
                items.append(("pose graph", lambda r: self.wand_graph()))
                items += [(f"basis sigma={'default' if s is None else format(s, 'g')}",
                           lambda r, s=s: self.wand_basis(s)) for s in sgs]
            elif name == "replay" and isinstance(values, (list, tuple)):
                for k, ops in enumerate(values):
                    typed = self._typed_list(ops, f"{where}[1][{k}]")
                    items.append((f"replay {k + 1}/{len(values)}", lambda r, ops=typed: self._replay_into_cache(ops, r)))
            elif name == "warp_tables" and isinstance(values, (list, tuple)):
                for k, w in enumerate(values):
                    op = self._typed(dict(w, op="guided_warp") if isinstance(w, dict) and "op" not in w else w,
                                     f"{where}[1][{k}]")
                    if not isinstance(op, _ops_module.GuidedWarp):
                        _fail(f"{where}[1][{k}]", "a guided_warp op", w)
                    items.append((f"warp tables {k}", lambda r, op=op: self._ctx.warp_tables(
                        self.source, op.reference, op.skip, warp_size(self.source, op)[1], op.backward,
                        warp_k(warp_size(self.source, op)[0]), r)))
            else:
                _fail(where, '"extract", ("cull", percents), ("wand_basis", sigmas), ("warp_tables", warps) or '
                             '("replay", op_lists)', job)
        return items

    def _replay_into_cache(self, ops: tuple, report: Callable | None = None) -> None:
        """Replay ``ops`` (typed) into the cache (each step under its op-prefix digest, and the evaluated
        result), leaving the session's own op list, history and held states alone. An op list that fails is
        skipped: the same failure is reported when a user's replay reaches it."""
        keys, prev = [], "source"
        for op in ops:
            prev = _chain(prev, op)
            keys.append(prev)
        progress = None if report is None else (lambda d, t, label: report(d / t if t else 1.0))
        try:
            last = self._run(ops, keys, len(ops), progress=progress)
            if keys and not isinstance(last, Motion):
                cache = self._ctx.cache
                cache.get("state", cache.token(last), "motion", lambda: convert(last, "motion", None))
        except (ValueError, ArithmeticError):
            pass

    def close(self, wait: bool = False) -> None:
        """Cancel pending warm-ups (each stops before its next item); with ``wait``, also wait until the
        item running now has finished (the worker is then idle: e.g. before timing something else in this
        process, whose CPU time would otherwise include it)."""
        self._worker.cancel_all()
        if wait:
            self._worker.submit([]).result()   # runs after the cancelled lists have stopped

    # -- files -------------------------------------------------------------------------------------
    def to_json(self, embed_source: bool | None = None) -> dict:
        """The session as a JSON-ready dict. The source is referenced by path (+ SHA-256) when the
        session has one, otherwise embedded (``embed_source=True`` forces embedding)."""
        if embed_source is None:
            embed_source = self.source_path is None
        if embed_source:
            source = {"motion": motion_to_json(self.source)}
        else:
            if self.source_path is None:
                raise ValueError("embed_source: False needs a session with a source_path")
            raw = read_regular_file(self.source_path, what="source file")
            source = {"path": self.source_path, "sha256": hashlib.sha256(raw).hexdigest()}
        return {"format": SESSION_FORMAT, "version": SESSION_VERSION, "source": source,
                "extract_options": json.loads(json.dumps(self.extract_options)), "ops": self.ops}

    def save(self, path, embed_source: bool | None = None) -> None:
        """Write the session as JSON, atomically (temporary file + rename). Refuses to replace the source
        clip or any existing file that is not a session file."""
        path = file_path(path, "path")
        check_save_target(path, self.source_path)
        atomic_write_bytes(path, session_bytes(self.to_json(embed_source)))  # refused over the size limit

    @classmethod
    def from_json(cls, data: Any, source: Motion | None = None) -> "Session":
        """Validate ``data`` (a parsed session file) and build the session. ``source`` overrides the
        stored source (for a moved file)."""
        if not isinstance(data, dict):
            _fail("session", "a JSON object", data)
        for k in data:
            if k not in ("format", "version", "source", "extract_options", "ops"):
                raise ValueError(f"{k}: unknown field in a session file")
        if data.get("format") != SESSION_FORMAT:
            _fail("format", repr(SESSION_FORMAT), data.get("format"))
        if type(data.get("version")) is not int or data.get("version") != SESSION_VERSION:  # true == 1
            _fail("version", str(SESSION_VERSION), data.get("version"))
        opts = check_extract_options(data.get("extract_options", {}))
        ops = cls._typed_list(data.get("ops"), "ops")
        src = data.get("source")
        path = None
        if source is None:
            if not isinstance(src, dict):
                _fail("source", '{"path": ..., "sha256": ...} or {"motion": {...}}', src)
            if "path" in src and "motion" in src:
                raise ValueError("source: give either path or motion, not both")
            if "path" in src:
                path = text(src["path"], "source.path")
                source, digest = read_source(path, "source.path")
                want = src.get("sha256")
                if want is not None and text(want, "source.sha256") != digest:
                    raise ValueError(f"source.sha256: {path} changed since the session was saved")
            elif "motion" in src:
                source = motion_from_json(src["motion"], "source.motion")
            else:
                _fail("source", '{"path": ...} or {"motion": {...}}', src)
        elif isinstance(src, dict) and "path" in src:
            path = src["path"] if isinstance(src["path"], str) else None
        return cls(source, ops, source_path=path, extract_options=opts)

    @classmethod
    def load(cls, path, source: Motion | None = None) -> "Session":
        """Read a session file written by :meth:`save` (validated; ValueError names the bad field)."""
        return cls.from_json(read_session_json(path), source=source)

    def export_bvh(self, path) -> None:
        """Write the edited motion as BVH, atomically; refuses to overwrite the source file."""
        path = file_path(path, "path")
        check_export_target(path, self.source_path)
        write_bvh(self.edited(), path)

    def export_gltf(self, path, units="auto") -> None:
        """Write the edited motion as glTF 2.0 (``.glb`` or ``.gltf``: a skinned skeleton and one animation,
        metres; :func:`stagger_nb.io.gltf.write_gltf`), atomically; refuses to overwrite the source file."""
        export_gltf(self.edited(), path, self.source_path, units)

    def __repr__(self) -> str:
        src = os.path.basename(self.source_path) if self.source_path else repr(self.source)
        names = [o.name for o in self._history.ops]
        shown = ", ".join(names[:12]) + (f", … ({len(names) - 12} more)" if len(names) > 12 else "")
        return f"Session({src}, {len(names)} ops: {shown or '-'})"
