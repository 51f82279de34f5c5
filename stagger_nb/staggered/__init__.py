"""Staggered poses (Coleman, Bibliowicz, Singh & Gleicher 2008): extraction, representation, editing.

Public names: :func:`extract`, :func:`evaluate`, :func:`cull`, :func:`detect_contacts`,
:class:`StaggeredMotion` (``sm.pose_times (K,)``, ``sm.refinements (K, J)`` in seconds).
The editing tools (§5) and the constraint layer live in ``editing.py`` / ``constraints.py``; their
``__all__`` names are re-exported here when those modules exist.
"""
from __future__ import annotations

import importlib
import importlib.util

from .contacts import detect_contacts, end_effectors
from .extraction import PoseEvidence, cull, extract, locate_poses, pose_priorities
from .features import motion_trail_curvature
from .fitting import fit_staggered
from .representation import StaggeredMotion, evaluate, evaluate_arrays, knot_times

__all__ = ["StaggeredMotion", "extract", "evaluate", "cull", "detect_contacts", "end_effectors", "locate_poses",
           "PoseEvidence", "pose_priorities", "motion_trail_curvature", "fit_staggered", "evaluate_arrays",
           "knot_times"]

for _name in ("editing", "constraints"):
    if importlib.util.find_spec(f"{__name__}.{_name}") is not None:
        _mod = importlib.import_module(f"{__name__}.{_name}")
        for _n in getattr(_mod, "__all__", ()):
            globals()[_n] = getattr(_mod, _n)
            __all__.append(_n)
