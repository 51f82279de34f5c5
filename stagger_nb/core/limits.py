"""Limits of the editing parameters, each declared once for every layer: the technique functions check them,
the session's typed ops and the editor models read them from here (core is the one layer all of them import).
"""
from __future__ import annotations

__all__ = ["MAX_TAU", "TIMING_LIMIT", "MAX_TIMING_LIMIT"]

#: Largest random-timing spread τ (seconds, §5.2), the bound of ``staggered.random_timing``, of the
#: ``random_timing`` op and of the StaggerEditor model's ``tau`` (τ >= 0 everywhere): a minute, far beyond
#: any take's pose spacing (< 1 s), far below where numpy's ``uniform(-τ, τ)`` overflows (~1e308).
MAX_TAU = 60.0

#: Default ``limit`` of ``staggered.succession`` / ``random_timing`` and of their ops: no segment of a joint's
#: curve plays more than this many times faster than in the source (its fastest segments at most 1.1 times, its
#: peak speed at most 1.25 times; ``None`` / ``null``: the paper's raw offsets). ``limit`` must be > 1 and at
#: most ``MAX_TIMING_LIMIT``.
TIMING_LIMIT = 1.5
MAX_TIMING_LIMIT = 1000.0
