"""The contact layer on a rig whose world is not +Y up (a Z-up export): the layer (:mod:`.plants`) works with +Y
up, so the source and the edited motion are turned so that their up axis (:func:`~stagger_nb.core.body.up_axis`
of the source) is +Y, held, and turned back. A world rotation moves only the root's rotation and translation
(every other joint's rotation and translation is relative to its parent), and the layer never changes the
root's rotation: the result keeps the edit's root rotation exactly and its root translation wherever the layer
left it unchanged, so an unedited motion still comes back bit for bit.
"""
from __future__ import annotations

import numpy as np

from ..core.body import up_axis
from ..core.motion import Motion
from ..core.rotations import quat_between_vectors, quat_conj, quat_mul, quat_rotate
from .plants_source import _SOURCE_CACHE

_Y = np.array([0.0, 1.0, 0.0])


def to_y_up(source: Motion):
    """The rotation ``(4,)`` that turns the source's up axis onto +Y, or None when it already is +Y (once per
    source: the slider's replays share it)."""
    per = _SOURCE_CACHE.setdefault(source, {})
    if "up" not in per:
        up = up_axis(source)
        if np.allclose(up, _Y):
            per["up"] = None
        elif np.allclose(up, -_Y):
            per["up"] = np.array([1.0, 0.0, 0.0, 0.0])             # half a turn about X
        else:
            per["up"] = quat_between_vectors(up, _Y)
    return per["up"]


def turned(motion: Motion, r: np.ndarray) -> Motion:
    """``motion`` with the whole world turned by ``r (4,)``: the root's rotation and translation."""
    q = np.array(motion.local_quats)
    q[:, 0] = quat_mul(np.broadcast_to(r, q[:, 0].shape), q[:, 0])
    rp = quat_rotate(np.broadcast_to(r, motion.root_positions.shape[:-1] + (4,)), motion.root_positions)
    return Motion._trusted(motion.skeleton, motion.frame_time, rp, q, motion.local_translations)


def turned_source(source: Motion, r: np.ndarray) -> Motion:
    """:func:`turned` of the source, once per source (its tables in the layer's cache are then reused)."""
    per = _SOURCE_CACHE.setdefault(source, {})
    if "y_up" not in per:
        per["y_up"] = turned(source, r)
    return per["y_up"]


def turned_back(held: Motion, turned_edit: Motion, edit: Motion, r: np.ndarray) -> Motion:
    """The layer's result ``held`` (on ``turned_edit = turned(edit, r)``) in ``edit``'s world again."""
    if held is turned_edit:
        return edit
    q = np.array(held.local_quats)
    q[:, 0] = edit.local_quats[:, 0]                    # the layer does not turn the root
    same = np.all(held.root_positions == turned_edit.root_positions, axis=-1)
    back = quat_rotate(np.broadcast_to(quat_conj(r), held.root_positions.shape[:-1] + (4,)), held.root_positions)
    rp = np.where(same[:, None], edit.root_positions, back)
    return Motion._trusted(edit.skeleton, edit.frame_time, rp, q, held.local_translations)
