"""The body scale every length of :mod:`stagger_nb.quality` is read on: :func:`body_height` and
:func:`scaled`."""
from __future__ import annotations

import numpy as np

from ..core.body import up_axis
from ..core.kinematics import forward_kinematics
from ..core.motion import Motion
from ..core.skeleton import Skeleton
from .bounds import _number
from .constants import HEIGHT_PERCENTILE


def _heights(pos: np.ndarray, up: np.ndarray) -> np.ndarray:
    return pos @ up


def body_height(motion: Motion, positions: np.ndarray | None = None) -> float:
    """The body height of ``motion`` (file units): the 90th percentile over frames of the vertical extent
    of its joints (highest minus lowest along :func:`~stagger_nb.core.body.up_axis`, End Sites left out).

    ``positions`` (F, J, 3): ``forward_kinematics(motion)[0]`` when the caller has it. A motion whose joints
    never spread vertically (every frame flat) is a ValueError.
    """
    if not isinstance(motion, Motion):
        raise ValueError(f"motion must be a Motion, got {type(motion).__name__}")
    pos = forward_kinematics(motion)[0] if positions is None else positions
    h = _heights(pos, up_axis(motion, pos))
    ext = float(np.percentile(h.max(axis=1) - h.min(axis=1), HEIGHT_PERCENTILE))
    if not ext > 0:
        raise ValueError("motion: its joints have no vertical extent; a body height cannot be measured")
    return ext


def scaled(motion: Motion, factor: float | None = None, *, height: float | None = None) -> Motion:
    """``motion`` scaled uniformly by ``factor`` (root positions, offsets, End Sites, animated translations),
    or so that its :func:`body_height` becomes ``height`` (e.g. ``scaled(m, height=170)``). Rotations and
    timing are unchanged; a new Motion (``motion`` is not modified)."""
    if not isinstance(motion, Motion):
        raise ValueError(f"motion must be a Motion, got {type(motion).__name__}")
    if (factor is None) == (height is None):
        raise ValueError("give exactly one of factor= or height=")
    if height is not None:
        height = _number(height, "height")
        if height <= 0:
            raise ValueError(f"height must be > 0, got {height}")
        factor = height / body_height(motion)
    factor = _number(factor, "factor")
    if factor <= 0:
        raise ValueError(f"factor must be > 0, got {factor}")
    sk = motion.skeleton
    skel = Skeleton(sk.names, sk.parents, sk.offsets * factor, sk.channels,
                    {j: o * factor for j, o in sk.end_sites.items()})
    lt = None if motion.local_translations is None else motion.local_translations * factor
    return Motion(skel, motion.frame_time, motion.root_positions * factor, motion.local_quats, lt)


_body_height = body_height   # (compare's parameter of the same name shadows it)
