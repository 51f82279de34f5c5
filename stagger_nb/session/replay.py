"""The replay of an op list: the state after each op prefix, computed once and found again by its digest.

Each prefix of an op list is named by a digest chained from the previous one (``digest_i = H(digest_{i-1},
op_i)``), so changing the last op (a slider move) replays only the tail and nothing is re-serialised per
prefix. Every computed state goes to the session's one cache under its prefix digest, so any op list sharing
that prefix (the session's own after an undo, or one warmed by :meth:`Session.warm
<stagger_nb.session.Session.warm>`) finds it; the same op on the same state, reached by another prefix, is
found by the state's content name and the op. :class:`Replay` also remembers, per step, the small things the
views ask for afterwards (the warp curve, runner notes, the timing-warning summary): :class:`_Info`. A
background replay (the next slider step, session/warm.py) passes ``stop``: it gives way between two ops when the
user's replay starts or waits for the lock (:attr:`Replay.waiting`), raising :class:`Stopped`.

The state flowing through the ops is a :class:`~stagger_nb.core.Motion` or a ``staggered.StaggeredMotion``;
:func:`~.run.convert` turns it into what the next op needs (Coleman et al. 2008, §3-§4).
"""
from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable
from contextlib import contextmanager
from typing import Any

from ..core.motion import Motion
from .heads import Heads
from .ops import Op
from .run import Run, convert
from .runners import BATCHED, RUNNERS

__all__ = ["Replay", "ReplayError", "Stopped", "chain_keys"]


class ReplayError(ValueError):
    """An op that failed while replaying: ``str()`` is ``"ops[i] (name): cause"``; ``index`` is ``i``,
    ``op`` the typed op, ``cause`` the technique's own sentence (no op index)."""

    def __init__(self, index: int, op: Op, cause: str):
        super().__init__(f"ops[{index}] ({op.name}): {cause}")
        self.index, self.op, self.cause = index, op, cause


class Stopped(Exception):
    """A background replay stopped between two ops because a foreground replay wants the lock (the steps it
    finished are cached)."""


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
    ``staggered.timing_summary`` (a timing edit limited to keep the poses in order, or knots that cross),
    §5.2; ``found`` (the detailed ``timing_warnings``) is shown beside it on demand."""
    from .. import staggered
    return staggered.timing_summary(state)


def _chain(previous: str, op: Op) -> str:
    return hashlib.blake2b(f"{previous}\n{op.key}".encode(), digest_size=16).hexdigest()


def chain_keys(ops) -> list[str]:
    """The chained digest of each prefix ``ops[:i + 1]`` of the typed ``ops``."""
    keys, prev = [], "source"
    for op in ops:
        prev = _chain(prev, op)
        keys.append(prev)
    return keys


class Replay:
    """Replays typed op tuples on ``source`` with the cached ``heads`` (one per :class:`Session`).

    The methods take the op tuple to replay (the session's current one); the last replay's final state and
    the last staggered state asked for are held strongly, everything else lives in the bounded cache.
    """

    def __init__(self, heads: Heads, source: Motion):
        self.heads = heads
        self.source = source
        self.lock = threading.RLock()
        self.waiting = 0                 # threads waiting for the lock now (a background replay gives way)
        self._count = threading.Lock()
        self._keys_of: tuple = ()       # the op tuple self._keys was computed for
        self._keys: list[str] = []      # digest of each op prefix (ops[:i + 1])
        self._info: OrderedDict = OrderedDict()   # prefix digest -> _Info, LRU (bounded in run)
        self._held: dict[str, Any] = {}  # strong refs: the last replay's final and last staggered state
        self.replayed = False            # whether the current op list was replayed to its end once

    @contextmanager
    def _locked(self):
        """``self.lock``, counting in :attr:`waiting` while another thread holds it (a warm-up replay asks
        ``waiting`` between two ops and stops: the user's replay does not wait for it)."""
        if not self.lock.acquire(blocking=False):
            with self._count:
                self.waiting += 1
            try:
                self.lock.acquire()
            finally:
                with self._count:
                    self.waiting -= 1
        try:
            yield
        finally:
            self.lock.release()

    def prefix_keys(self, ops: tuple) -> list[str]:
        """Digest of each op prefix, chained (O(1) per op; recomputed only from the first changed op)."""
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
        return hit if hit is not None else self.heads.cache.peek("state", key)

    def known_state(self, ops: tuple, upto: int):
        """The state after ``ops[:upto]`` when it is held or cached (the source for ``upto == 0``), else None;
        computes nothing."""
        if upto == 0:
            return self.source
        return self._available(chain_keys(ops[:upto])[-1])

    def walk(self, ops: tuple, upto: int, keep_all: bool = False, progress: Callable | None = None):
        """The state after ``ops[:upto]`` (with ``keep_all``, the list of states after each of them); the
        final state is held."""
        with self._locked():
            keys = self.prefix_keys(ops)
            out = self.run(ops, keys, upto, keep_all, progress)
            if upto:
                self._held = {keys[upto - 1]: out[-1] if keep_all else out}
            if upto == len(ops):
                self.replayed = True
            return out

    def run(self, ops: tuple, keys: list, upto: int, keep_all: bool = False, progress: Callable | None = None,
            stop: Callable | None = None):
        """The state after ``ops[:upto]`` (``keys``: their chained prefix digests), resuming from the latest
        prefix whose state is held or cached and whose earlier steps are known. Linear in ``upto``: each state
        is computed at most once; every computed state goes to the cache under its prefix digest. ``stop()``
        is asked before each op computed: True raises :class:`Stopped` (a background replay giving way)."""
        with self._locked():
            info, cache = self._info, self.heads.cache
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
                        # recently used: the state a slider's replays resume from stays cached while each move
                        # adds newer states (a long clip's take a few MB each against the byte budget)
                        cache.touch("state", [(keys[i - 1], None)])
                        break
            todo = [i for i in range(r, upto) if states[i] is None]
            total = len(todo)
            state = self.source if r == 0 else states[r - 1]
            origin = (lambda r=r, st=list(states[:r]): self._origin(ops, keys[:r], st))  # noqa: E731 (lazy)
            done = 0
            i = r - 1
            while i + 1 < upto:
                i += 1
                if states[i] is not None:  # keep_all: a cached step past a missing one
                    state = states[i]
                    continue
                op = ops[i]
                if stop is not None and stop():
                    raise Stopped(i)
                if progress is not None:
                    progress(done, total, op.name)
                # a run of ops one batched runner applies in one pass (10^5 edit_frame ops), but its last op:
                # that one runs alone, so a change of the last op (a slider) replays one op
                j = (self._batch_end(ops, i, upto, state) if not keep_all else i + 1) - 1
                if j > i + 1:
                    try:
                        state = BATCHED[type(op)](state, ops[i:j])
                    except ValueError as e:
                        k = i + getattr(e, "offset", 0)
                        raise ReplayError(k, ops[k], str(e)) from None
                    for k in range(i, j):   # the steps are known; only the run's last state is cached
                        info[keys[k]] = _Info(None, (), False)
                    i, done = j - 1, done + (j - i)
                    cache.name(state, keys[i])
                    cache.put("state", keys[i], None, state)
                    continue
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
                    run = Run(self.heads, origin, _share(progress, done, total, 0.0, split, f"{op.name} (extract)"))
                    try:
                        state = convert(state, op.needs, run)
                        run.progress = _share(progress, done, total, split, 1.0, op.name)
                        state = RUNNERS[type(op)](state, op, run)
                    except ValueError as e:
                        raise ReplayError(i, op, str(e)) from None
                    except ArithmeticError as e:  # e.g. a parameter so extreme that the technique divides by 0
                        raise ReplayError(i, op, f"{type(e).__name__}: {e}") from None
                    origin = run.origin_or_lazy()
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

    @staticmethod
    def _batch_end(ops: tuple, i: int, upto: int, state) -> int:
        """End (exclusive) of the run of ops from ``i`` that one batched runner applies together: consecutive
        ops of the same batchable kind on a Motion (``i + 1`` when there is no such run)."""
        kind = type(ops[i])
        if kind not in BATCHED or not isinstance(state, Motion):
            return i + 1
        j = i + 1
        while j < upto and type(ops[j]) is kind:
            j += 1
        return j

    def _origin(self, ops, keys, states) -> Motion:
        """The Motion the staggered state after ``keys`` (prefixes of ``ops``) was extracted from (the source
        by default): the latest Motion state before the last run of staggered states."""
        origin = self.source
        for i in range(len(keys) - 1, -1, -1):
            if not self._info[keys[i]].staggered:
                if i == len(keys) - 1:
                    return origin  # the state is a Motion: an extraction would start from it
                st = states[i] if states[i] is not None else self.run(ops, keys, i + 1)
                return st
        return origin

    def edited(self, ops: tuple, progress: Callable | None = None) -> Motion:
        """The source with every op of ``ops`` applied, as a Motion (the last staggered state evaluated)."""
        n = len(ops)
        if not n:
            return self.source
        last = self.walk(ops, n, progress=progress)
        if isinstance(last, Motion):
            return last
        try:
            cache = self.heads.cache   # keyed by the state's content name: every prefix reaching it shares it
            return cache.get("state", cache.token(last), "motion", lambda: convert(last, "motion", None))
        except (ValueError, ArithmeticError) as e:  # evaluating the last staggered state
            raise ReplayError(n - 1, ops[n - 1], f"evaluating the result: {e}") from None

    def check(self, ops: tuple, report: Callable | None = None, stop: Callable | None = None) -> None:
        """Replay ``ops`` into the cache (each step under its op-prefix digest, and the evaluated result),
        holding nothing: a later replay of ``ops`` (or of a list sharing a prefix) finds every state.
        Raises :class:`ReplayError` naming the op that fails (:class:`Stopped` when ``stop()`` turns True
        between two ops, see :meth:`run`)."""
        keys = chain_keys(ops)
        progress = None if report is None else (lambda d, t, label: report(d / t if t else 1.0))
        last = self.run(ops, keys, len(ops), progress=progress, stop=stop)
        if stop is not None and stop():
            raise Stopped(len(ops))
        if keys and not isinstance(last, Motion):
            cache = self.heads.cache
            try:
                cache.get("state", cache.token(last), "motion", lambda: convert(last, "motion", None))
            except (ValueError, ArithmeticError) as e:
                raise ReplayError(len(ops) - 1, ops[-1], f"evaluating the result: {e}") from None

    def into_cache(self, ops: tuple, report: Callable | None = None, stop: Callable | None = None) -> None:
        """:meth:`check` that skips an op list that fails (the same failure is reported when a user's replay
        reaches it) or is stopped (``stop``)."""
        try:
            self.check(ops, report, stop)
        except (ValueError, ArithmeticError, Stopped):
            pass

    def last_staggered_index(self, ops: tuple) -> int | None:
        """Index of the last op of ``ops`` whose state is staggered (None when none is)."""
        n = len(ops)
        if n:
            self.walk(ops, n)
        keys = self._keys
        return next((i for i in range(n - 1, -1, -1) if self._info[keys[i]].staggered), None)

    def staggered(self, ops: tuple, extraction: Callable, progress: Callable | None = None):
        """The last staggered state of the replay of ``ops`` (``extraction()`` when none is staggered)."""
        n = len(ops)
        if n:
            self.walk(ops, n, progress=progress)
        j = self.last_staggered_index(ops)
        if j is None:
            return extraction()
        st = self.walk(ops, j + 1)
        self._held[self._keys[j]] = st
        return st

    def origin(self, ops: tuple) -> Motion:
        """The Motion the last staggered state of the replay of ``ops`` was extracted from (the source when no
        state is staggered)."""
        j = self.last_staggered_index(ops)
        if j is None:
            return self.source
        return self._origin(ops, self._keys[:j + 1], [None] * (j + 1))

    def messages(self, ops: tuple) -> list[str]:
        """The runners' notes and the timing summary of the last replay of ``ops`` ([] when the op list
        changed since, or before the first replay)."""
        if not self.replayed:
            return []
        with self._locked():
            keys = self.prefix_keys(ops)
            if any(k not in self._info for k in keys):
                return []  # the op list changed since the last replay
            out = [note for k in keys for note in self._info[k].notes]
            summary, _ = self._warnings_of(ops, len(ops))
            if summary:
                out.append(summary)
        return out

    def timing_warnings(self, ops: tuple) -> tuple[str, tuple]:
        """``(summary, warnings)`` of the last staggered state of the replay of ``ops``, once per state."""
        n = len(ops)
        if n:
            self.walk(ops, n)
        with self._locked():
            return self._warnings_of(ops, n)

    def _warnings_of(self, ops: tuple, n: int) -> tuple[str, tuple]:  # under the lock, ops[:n] replayed
        keys = self.prefix_keys(ops)
        j = next((i for i in range(n - 1, -1, -1) if self._info[keys[i]].staggered), None)
        if j is None:
            return "", ()
        inf = self._info[keys[j]]
        if inf.warnings is None:
            from .. import staggered
            state = self.walk(ops, j + 1)
            found = tuple(staggered.timing_warnings(state))
            inf.summary, inf.warnings = _timing_summary(state, found), found
        return inf.summary, inf.warnings

    def warp_curve(self, ops: tuple, i: int):
        """The warp curve computed by op ``i`` of ``ops`` (None when it is not a warp)."""
        self.walk(ops, len(ops))
        return self._info[self._keys[i]].warp
