"""An editor's ops into the session's op list: :func:`merge_ops` (every other op kept in place) and where an
editor's first op goes in a list that holds none of its ops (its *home*).

Ownership. Each editor *owns* some op names (``STAGGER_OPS``, ``WAND_OPS``, ``WARP_OPS``); every other op of the
session is foreign and is kept, in place, by :func:`merge_ops`. Inside an owned op, fields the editor does not
control (e.g. ``exaggerate.poses``) are kept as well. Only the owned ops whose parameters changed are rewritten,
so an op the editor cannot represent (two ``succession`` ops, a ``cull`` by a field it shows differently)
survives until the user moves the matching control.
"""
from __future__ import annotations

import copy
import inspect
from collections.abc import Callable

from ..ops import OPS
from ._base import _canon
from .stagger_ops import STAGGER_OPS
from .wand import WAND_OPS
from .warp import WARP_OPS

__all__ = ["merge_ops"]

# fields of each owned op the editor controls (others, e.g. exaggerate.poses, are kept as they are)
_CONTROLLED = {
    "cull": ("percent", "count", "keep"),
    "succession": ("root", "s", "l", "joints", "falloff"),
    "random_timing": ("tau", "seed", "joints", "falloff"),
    "exaggerate": ("w_r", "reference"),
    "edit_pose": ("pose", "deltas", "targets", "mode", "propagate", "sigma", "frame_range"),
    "retime": ("pose", "time"),
    "ik_pose": ("pose", "joint", "target", "propagate", "sigma", "frame_range"),
    "refine": ("pose", "joint", "time"),
    "keep_contacts": (),
    "propagate": ("frame", "frames", "deltas", "sigma", "frame_range", "repetitions"),
    "edit_frame": ("frame", "deltas"),
    "guided_warp": ("duration", "free_length", "skip", "reference", "keytimes", "backward"),
    "guide_poses": ("duration", "free_length", "skip", "reference", "keytimes"),
    "linear_warp": ("duration", "keytimes"),
}


def _edit_prefix(ops: list) -> str:
    """The ops before the StaggerEditor's first owned op past the cull (what its pose edits apply to), as
    canonical JSON."""
    i = next((n for n, o in enumerate(ops) if o["op"] in STAGGER_OPS and o["op"] != "cull"), len(ops))
    return _canon(list(ops[:i]))


def _key(op: dict):
    """Which instance of an owned op this is: one per name, per pose, per (pose, joint) or per frame."""
    name = op["op"]
    if name == "edit_pose":
        return (name, op["pose"], "targets" if "targets" in op else "deltas")
    if name == "retime":
        return (name, op["pose"])
    if name in ("ik_pose", "refine"):
        return (name, op["pose"], op["joint"])
    if name == "edit_frame":
        return (name, op["frame"])
    if name == "guide_poses":
        return (name,)     # a warp of the pose times sits among the staggered ops, not at the end
    if name in WARP_OPS:
        return ("warp",)
    return (name,)


def _rank(op: dict, owned: tuple) -> tuple:
    """Order of an owned op: by name (``owned``), then by instance (pose, frame...)."""
    return (owned.index(op["op"]),) + _key(op)[1:]


def merge_ops(current: list, old_owned: list, new_owned: list, owned: tuple,
              home: Callable[[list], int] | None = None) -> list:
    """The session's op list after an editor changes its ops from ``old_owned`` to ``new_owned``.

    Only instances (see ``_key``) whose op differs between ``old_owned`` and ``new_owned`` are touched; each is
    replaced in place (its last occurrence in ``current``; fields the editor does not control are kept),
    removed, or inserted next to the owned ops of neighbouring rank (``owned`` gives the order), or at
    ``home(ops, op)`` when the list holds none of them (default: the end). Every other op keeps its place.
    """
    old = {_key(o): o for o in old_owned}
    new = {_key(o): o for o in new_owned}
    out = copy.deepcopy(list(current))
    order = [k for k in list(old) + list(new)]
    seen = set()
    for k in order:
        if k in seen:
            continue
        seen.add(k)
        a, b = old.get(k), new.get(k)
        if a is not None and b is not None and _canon(a) == _canon(b):
            continue
        at = [i for i, o in enumerate(out) if o["op"] in owned and _key(o) == k]
        if b is None:
            if at:
                del out[at[-1]]
            continue
        if at:
            prev = out[at[-1]]
            keep = {f: v for f, v in prev.items() if f not in _CONTROLLED.get(prev["op"], ()) and f != "op"}
            out[at[-1]] = {**keep, **copy.deepcopy(b)}
            continue
        r = _rank(b, owned)
        mine = [(i, _rank(o, owned)) for i, o in enumerate(out) if o["op"] in owned]
        before = [i for i, ro in mine if ro <= r]
        after = [i for i, ro in mine if ro > r]
        if before:
            pos = before[-1] + 1
        elif after:
            pos = after[0]
        else:
            pos = len(out) if home is None else _at_home(home, out, b)
        out.insert(pos, copy.deepcopy(b))
    return out


def _at_home(home: Callable, ops: list, op: dict) -> int:
    """``home(ops, op)``, or ``home(ops)`` for a home that takes only the list."""
    try:
        takes_op = len(inspect.signature(home).parameters) >= 2
    except (TypeError, ValueError):
        takes_op = False
    return home(ops, op) if takes_op else home(ops)


def _stagger_home(ops, op=None):
    return 0


def _warp_home(ops, op=None):
    """Where a warp op goes in a list without one: a warp of the motion at the end; ``guide_poses`` (the pose
    times, a staggered op) after the staggered ops, before the contact layer and the motion ops."""
    if op is None or op["op"] != "guide_poses":
        return len(ops)
    pos = 0
    for i, o in enumerate(ops):
        if o["op"] == "keep_contacts":
            return i
        cls = OPS.get(o["op"])
        if cls is not None and cls.needs == "staggered":
            pos = i + 1
    return pos


def _wand_home(ops, op=None):
    for i, o in enumerate(ops):
        if o["op"] in ("guided_warp", "linear_warp", "resample"):
            return i
    return len(ops)


def _wand_input_frames(session) -> int:
    """Frames of the motion the WandEditor's ops see: the source's, unless an op that changes the length
    comes before them (then 0, unknown: the replay checks the frame)."""
    ops = session.ops
    first = next((i for i, o in enumerate(ops) if o["op"] in WAND_OPS), _wand_home(ops))
    return session.source.num_frames if _wand_home(ops[:first]) == first else 0
