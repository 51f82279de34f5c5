"""Staggered poses (Coleman, Bibliowicz, Singh & Gleicher 2008): extraction, representation, editing.

Public names: :func:`extract`, :func:`evaluate`, :func:`cull`, :func:`detect_contacts`,
:class:`StaggeredMotion` (``sm.pose_times (K,)``, ``sm.refinements (K, J)`` in seconds).
The editing tools (§5) and the constraint layer live in ``editing.py`` / ``constraints.py``; their
``__all__`` names are re-exported here when those modules exist.
"""
from __future__ import annotations

import importlib
import importlib.util

from .fitting import fit_staggered
from .representation import StaggeredMotion, evaluate, knot_times

__all__ = ["StaggeredMotion", "evaluate", "fit_staggered", "knot_times"]

try:
    from .extraction import cull, extract  # noqa: F401
    from .contacts import detect_contacts  # noqa: F401
    __all__ += ["extract", "cull", "detect_contacts"]
except ModuleNotFoundError as _e:  # pragma: no cover - only while extraction is being written
    if _e.name not in (f"{__name__}.extraction", f"{__name__}.contacts"):
        raise

for _name in ("editing", "constraints"):
    if importlib.util.find_spec(f"{__name__}.{_name}") is not None:
        _mod = importlib.import_module(f"{__name__}.{_name}")
        for _n in getattr(_mod, "__all__", ()):
            globals()[_n] = getattr(_mod, _n)
            __all__.append(_n)
