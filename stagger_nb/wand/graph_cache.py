"""The one-call functions' pose-graph cache: :func:`cached_pose_graph`, small, bounded and keyed by content, so
``wand.falloff``, ``wand.propagate`` and :func:`~.greens.greens_basis` do not rebuild the graph when only sigma
changes; :func:`clear_graph_cache` empties it."""
from __future__ import annotations

import threading
from collections import OrderedDict

from ..core.digest import content_key
from ..core.motion import Motion
from .graph import PoseGraph, pose_graph

__all__ = ["cached_pose_graph", "clear_graph_cache", "GRAPH_CACHE"]

GRAPH_CACHE = 4          # PoseGraphs the one-call functions (falloff, propagate, greens_basis) keep, see below


_GRAPHS: OrderedDict[bytes, PoseGraph] = OrderedDict()
_GRAPHS_LOCK = threading.Lock()


def _graph_key(motion: Motion, options: dict) -> bytes:
    """Content key of (motion rotations, skeleton, options) (:func:`..core.digest.content_key`), never ``id()``."""
    opts = tuple((name, options[name]) for name in sorted(options))
    return content_key(motion.local_quats, motion.skeleton.parents,
                       (motion.num_frames, motion.frame_time, motion.skeleton.names), opts)


def cached_pose_graph(motion: Motion, **options) -> PoseGraph:
    """:func:`pose_graph` through a small module cache, so the one-call functions (:func:`greens_basis`,
    ``wand.falloff``, ``wand.propagate``) do not rebuild the sigma-independent graph when only sigma changes.

    Explicit and bounded: keyed by the content of ``motion.local_quats``, the skeleton and ``options`` (a
    BLAKE2b digest; about 1 ms per MB of rotations), holds the last :data:`GRAPH_CACHE` graphs, least recently
    used out first; :func:`clear_graph_cache` empties it.  Graphs are immutable, so sharing them is safe.
    Callers that manage their own caching (the session) call :func:`pose_graph` directly."""
    key = _graph_key(motion, options)
    with _GRAPHS_LOCK:
        g = _GRAPHS.get(key)
        if g is not None:
            _GRAPHS.move_to_end(key)
            return g
    g = pose_graph(motion, **options)
    with _GRAPHS_LOCK:
        _GRAPHS[key] = g
        while len(_GRAPHS) > GRAPH_CACHE:
            _GRAPHS.popitem(last=False)
    return g


def clear_graph_cache() -> None:
    """Empty the module cache of :func:`cached_pose_graph`."""
    with _GRAPHS_LOCK:
        _GRAPHS.clear()

