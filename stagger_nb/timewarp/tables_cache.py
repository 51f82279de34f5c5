"""A small, thread-safe module cache of :class:`~.tables.WarpTables` (bounded in count and bytes), so that repeated
one-call :func:`~.guided.guided_warp` calls on the same motions prepare their tables once."""
from __future__ import annotations

import threading
from collections import OrderedDict

from ..core.digest import content_key
from ..core.motion import Motion
from .tables import WarpTables, prepare_warp

TABLES_CACHE = 4           # tables guided_warp keeps between calls (cached_prepare_warp) ...


TABLES_CACHE_BYTES = 64 << 20   # ... holding at most this many bytes together


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
