"""The session's one cache: compute-once entries under one lock, bounded per kind.

Keys are ``(kind, owner, param)``. ``owner`` is a *content* key (a string such as the digest of the op
prefix a state came from) or a token handed out per live object through a ``weakref.WeakKeyDictionary``
(:meth:`Cache.token`): a token is never reused, so an entry can never be confused with one computed for a
dead object whose memory was recycled (the ``id()`` pitfall). ``param`` is any hashable value.

Each entry is a :class:`concurrent.futures.Future`. The first caller of a missing entry runs ``make()`` in
its own thread, outside the lock; a second caller of the same entry waits for that future (computed
once); callers of other entries are never blocked. A failed computation is not kept: the next caller
computes it again. Each kind keeps at most ``bound`` finished entries, least recently used dropped first;
a kind with a byte budget (:data:`BUDGETS`) also drops its least recently used finished entries while the
arrays they hold (:func:`nbytes`) exceed it (the most recent entry always stays).
"""
from __future__ import annotations

import dataclasses
import itertools
import threading
import weakref
from collections import OrderedDict
from collections.abc import Callable, Hashable
from concurrent.futures import Future

import numpy as np

__all__ = ["Cache", "BOUNDS", "BUDGETS", "nbytes"]

#: Entries kept per kind (finished entries; pending ones are never dropped).
BOUNDS = {
    "extract": 4,     # staggered extractions (one per distinct input motion)
    "cull": 40,       # cull results: every position of a 2.5 %-step slider on one extraction
    "graph": 4,       # magic-wand pose graphs (sigma-independent head)
    "basis": 64,      # magic-wand eigenbases: every position of a sigma slider (F x 50 floats each)
    "warp": 8,        # guided-warp kNN tables
    "warp_solution": 32,  # their searches per output length (a duration slider's recent steps: ~50 KB each)
    "warp_sweep": 2,  # ... and one forward pass serving +- 128 lengths (timewarp.length_sweep; 5-15 MB on CMU 01_01)
    "reference": 8,   # resolved warp references (segments, files)
    "curve": 16,      # comparison falloff curves (ISOMAP, diffusion, spline)
    "compare": 8,     # their frame-independent heads: ISOMAP's kNN graph, diffusion coordinates per sigma
    "falloff": 64,    # Green's falloffs (F floats) of the pose edits and timing regions that propagate
    "offset_basis": 8,  # exaggeration bases, one per pre-exaggerate state (~100 B per grid sample)
    "positions": 4,   # forward kinematics of a source motion (keep_contacts' targets)
    "quality_source": 4,  # quality.prepare of a source motion (Session.quality: the source's figures, once)
    "quality": 64,    # Session.quality reports by op-list digest (small: figures and names)
    "step": 512,      # (state content name, op) -> the op-prefix digest of the state it gave (strings)
    "state": 64,      # replay steps by op-prefix digest (a slider sweep touches a handful; the editor's
                      # warm-up replays every cull position: 2-3 steps each)
}

#: Bytes of arrays kept per kind (finished entries), besides the count bound: replay states are whole motions
#: (F x J x 4 floats and more), so a long clip keeps fewer of them (a 27,510-frame take: ~10, not 64).
BUDGETS = {"state": 384 * 2**20, "compare": 128 * 2**20, "warp_sweep": 128 * 2**20}

# not reported to ``busy`` (replay steps and heads about one evaluate long, a falloff one row product, a warp's
# search: the replay reports its own progress)
QUIET = {"state", "step", "warp_solution", "warp_sweep", "offset_basis", "positions", "falloff", "quality_source",
         "quality"}


class Cache:
    """One lock, compute-once futures, LRU-bounded per kind.

    Parameters
    ----------
    busy : callable(kind, started) or None
        Called around each ``make()`` of a kind not in :data:`QUIET` (e.g. to show a progress bar); from the
        computing thread.
    bounds : dict kind -> int, optional
        Overrides of :data:`BOUNDS`; unknown kinds keep 16 entries.
    budgets : dict kind -> bytes, optional
        Overrides of :data:`BUDGETS` (kinds without one are bounded by count only).
    """

    def __init__(self, busy: Callable | None = None, bounds: dict | None = None, budgets: dict | None = None):
        self._lock = threading.Lock()
        self._entries: dict[str, OrderedDict] = {}
        self._sizes: dict[str, dict] = {}   # kind -> {key: nbytes} of finished entries of budgeted kinds
        self._tokens: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
        self._counter = itertools.count(1)
        self._busy = busy
        self._bounds = dict(BOUNDS, **(bounds or {}))
        self._budgets = dict(BUDGETS, **(budgets or {}))

    def token(self, obj) -> str:
        """A key for the live object ``obj`` (held weakly; never reused for another object)."""
        with self._lock:
            t = self._tokens.get(obj)
            if t is None:
                t = self._tokens[obj] = f"obj{next(self._counter)}"
            return t

    def name(self, obj, key: str) -> None:
        """Give ``obj`` the content key ``key`` (e.g. the digest of the ops that produced it), so entries
        computed from it are found again from any object with the same key (an object already named or
        tokened keeps its first key)."""
        with self._lock:
            self._tokens.setdefault(obj, key)  # the first name stays: entries already keyed by it stay valid

    def get(self, kind: str, owner: Hashable, param: Hashable = None, make: Callable | None = None):
        """The value of entry ``(kind, owner, param)``, computed by ``make()`` once when missing (``None``
        when missing and ``make`` is None)."""
        store = self._store(kind)
        key = (owner, param)
        with self._lock:
            fut = store.get(key)
            if fut is None and make is None:
                return None
            compute = fut is None
            if compute:
                fut = store[key] = Future()
                fut.set_running_or_notify_cancel()
            else:
                store.move_to_end(key)
        if not compute:
            return fut.result()  # finished, or being computed by another thread: wait for it
        busy = self._busy if kind not in QUIET else None
        try:
            if busy is not None:
                busy(kind, True)
            try:
                value = make()
            finally:
                if busy is not None:
                    busy(kind, False)
        except BaseException as e:
            with self._lock:
                if store.get(key) is fut:
                    del store[key]
            fut.set_exception(e)
            raise
        fut.set_result(value)
        size = nbytes(value) if kind in self._budgets else 0
        with self._lock:
            if kind in self._budgets and store.get(key) is fut:
                self._sizes.setdefault(kind, {})[key] = size
            self._trim(kind, store)
        return value

    def put(self, kind: str, owner: Hashable, param: Hashable, value) -> None:
        """Store a value computed elsewhere."""
        store = self._store(kind)
        fut = Future()
        fut.set_running_or_notify_cancel()
        fut.set_result(value)
        size = nbytes(value) if kind in self._budgets else 0
        with self._lock:
            store[(owner, param)] = fut
            store.move_to_end((owner, param))
            if kind in self._budgets:
                self._sizes.setdefault(kind, {})[(owner, param)] = size
            self._trim(kind, store)

    def peek(self, kind: str, owner: Hashable, param: Hashable = None):
        """A finished entry's value without waiting or computing (None when missing or pending)."""
        with self._lock:
            fut = self._store(kind).get((owner, param))
        if fut is None or not fut.done() or fut.exception() is not None:
            return None
        return fut.result()

    def touch(self, kind: str, keys) -> None:
        """Mark entries ``(owner, param)`` of ``kind`` as recently used."""
        store = self._store(kind)
        with self._lock:
            for k in keys:
                if k in store:
                    store.move_to_end(k)

    def pending(self) -> int:
        """Entries being computed now (for tests and diagnostics)."""
        with self._lock:
            return sum(not f.done() for s in self._entries.values() for f in s.values())

    def __len__(self) -> int:
        with self._lock:
            return sum(len(s) for s in self._entries.values())

    def _store(self, kind: str) -> OrderedDict:
        s = self._entries.get(kind)
        if s is None:  # dict.setdefault is atomic: two threads get the same store (callers may hold the lock)
            s = self._entries.setdefault(kind, OrderedDict())
        return s

    def nbytes(self, kind: str) -> int:
        """Bytes of arrays held by the finished entries of a budgeted ``kind`` (0 for other kinds)."""
        with self._lock:
            return sum(self._sizes.get(kind, {}).values())

    def _trim(self, kind: str, store: OrderedDict) -> None:  # under the lock
        excess = len(store) - self._bounds.get(kind, 16)
        if excess > 0:   # the oldest finished entries (a pass over the oldest only: a long replay puts many)
            drop = []
            for k, f in store.items():
                if f.done():
                    drop.append(k)
                    if len(drop) == excess:
                        break
            for k in drop:
                del store[k]
        sizes = self._sizes.get(kind)
        if sizes is None:
            return
        for k in [k for k in sizes if k not in store]:   # dropped above or failed
            del sizes[k]
        total, budget = sum(sizes.values()), self._budgets[kind]
        if total <= budget:
            return
        last = next(reversed(store), None)
        for k in [k for k, f in store.items() if f.done() and k != last]:
            if total <= budget:
                break
            total -= sizes.pop(k, 0)
            del store[k]


def nbytes(value, _depth: int = 0) -> int:
    """Bytes of the numpy arrays ``value`` holds: itself, or its fields (dataclass or attributes), items of its
    lists, tuples and dicts, two levels deep (an estimate for the cache's budgets: an array shared by two
    values counts twice)."""
    if isinstance(value, np.ndarray):
        return int(value.nbytes)
    if _depth > 2 or value is None or isinstance(value, (str, bytes, int, float, bool)):
        return 0
    if isinstance(value, dict):
        items = dict.values(value)   # (a dict subclass's lazy entries, e.g. timing warnings, stay unread)
    elif isinstance(value, (list, tuple)):
        items = value
    elif dataclasses.is_dataclass(value):
        items = [getattr(value, f.name, None) for f in dataclasses.fields(value) if not f.metadata.get("shared")]
    else:
        items = list(getattr(value, "__dict__", {}).values())
    return sum(nbytes(v, _depth + 1) for v in items)
