"""Limits of the editing parameters, each declared once for every layer: the technique functions check them,
the session's typed ops and the editor models read them from here (core is the one layer all of them import).
"""
from __future__ import annotations

__all__ = ["MAX_TAU"]

#: Largest random-timing spread τ (seconds, §5.2), the bound of ``staggered.random_timing``, of the
#: ``random_timing`` op and of the StaggerEditor model's ``tau`` (τ >= 0 everywhere): a minute, far beyond
#: any take's pose spacing (< 1 s), far below where numpy's ``uniform(-τ, τ)`` overflows (~1e308).
MAX_TAU = 60.0
