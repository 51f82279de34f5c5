"""What the contact layer (:mod:`stagger_nb.staggered.plants`) reads of the source, once per source (a slider's
replays share it): the world positions and rotations of the limbs' chains, each limb's share of its length per
frame, hinge axes, backward bends and floor (:func:`_source_tables`), and the per-frame turn of each joint the
pop cap measures against (:func:`_source_steps`). Kept in :data:`_SOURCE_CACHE`, weakly keyed by the source.
"""
from __future__ import annotations

import weakref

import numpy as np

from ..core.motion import Motion
from .limbs import _fk_joints
from .plants_ik import _hinge_local, _source_back
from .plants_pops import source_steps
from .plants_sample import _length

_SOURCE_CACHE = weakref.WeakKeyDictionary()


def _source_tables(source: Motion, limbs: dict):
    """What the layer reads of the source, once per (source, limbs) (a slider's replays share it): world
    positions and rotations of the limbs' and feet's chains, the share of each limb's length it uses per
    frame, each limb's hinge axis, and the floor (the lowest height of the feet's joints)."""
    key = tuple(sorted((lim.upper, lim.mid, lim.eff) + lim.foot for lim in limbs.values()))
    per = _SOURCE_CACHE.setdefault(source, {})
    if key not in per:
        joints = {x for lim in limbs.values() for x in (lim.upper, lim.mid, lim.eff) + lim.foot}
        spos, swq = _fk_joints(source, joints)
        share = {e: np.linalg.norm(spos[:, e] - spos[:, lim.upper], axis=-1) / _length(spos, lim)
                 for e, lim in limbs.items()}
        hinges = {e: _hinge_local(spos, swq, lim) for e, lim in limbs.items()}
        backs = {e: _source_back(spos, swq, lim, hinges[e]) for e, lim in limbs.items()}
        feet = [x for lim in limbs.values() if lim.leg for x in (lim.eff,) + lim.foot]
        floor = float(np.min(spos[:, feet, 1])) if feet else -np.inf
        if len(per) > 8:
            per.clear()
        per[key] = (spos, swq, share, hinges, floor, backs)
    return per[key]


def _source_steps(source: Motion) -> np.ndarray:
    """:func:`source_steps` of the source's local rotations (scale 1), once per source (the slider's replays
    share it; the caller scales it by the edited frame time over the source's)."""
    per = _SOURCE_CACHE.setdefault(source, {})
    if "steps" not in per:
        per["steps"] = source_steps(source.local_quats, 1.0)
    return per["steps"]
