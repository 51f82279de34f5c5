"""What an op runner works with: the replay state converted to what the op needs (:func:`convert`), the
:class:`Run` of one op (the cached heads, the motion a staggered state was extracted from, notes, the warp
curve, progress) and the checks every runner shares (a joint name, a frame, a pose index), all in the field's
words. The technique packages are imported late: they load only when an op needs them.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from ..core.motion import Motion
from ..core.rotations import quat_mul, rotvec_to_quat
from ..core.skeleton import Skeleton

if TYPE_CHECKING:
    from .heads import Heads

__all__ = ["Run", "convert", "apply_pose_deltas"]


def _staggered():
    from .. import staggered  # late import: the technique packages load only when an op needs them
    return staggered


def _wand():
    from .. import wand
    return wand


def _timewarp():
    from .. import timewarp
    return timewarp


class Run:
    """What a runner may use while running one op: the cached ``heads``, the Motion the current staggered
    representation was extracted from (``origin``), where to leave notes and the warp curve, and
    ``progress``: ``callable(fraction in [0, 1])`` or None, passed to the long computations of the op (the
    staggered extraction and cull refits, guided warping's tables and solve)."""

    def __init__(self, heads: Heads, origin, progress: Callable | None = None):
        self.heads = heads
        self.progress = progress
        self._origin = origin  # a Motion, or a callable giving it (found only when a runner asks)
        self.notes: list[str] = []
        self.warp: np.ndarray | None = None

    @property
    def origin(self) -> Motion:
        if callable(self._origin):
            self._origin = self._origin()
        return self._origin

    @origin.setter
    def origin(self, motion: Motion) -> None:
        self._origin = motion

    def origin_or_lazy(self):
        """The origin as held now: a Motion, or the callable that finds it (not called: the next op's run
        takes it over and calls it only if its runner asks)."""
        return self._origin

    def note(self, message: str) -> None:
        if message:
            self.notes.append(message)


def convert(state, needs: str, run: Run):
    """``state`` as the kind the op ``needs``: a Motion is extracted (cached), a staggered state evaluated."""
    is_motion = isinstance(state, Motion)
    if needs == "motion":
        return state if is_motion else _staggered().evaluate(state)
    if needs == "staggered" and is_motion:
        run.origin = state
        return run.heads.extract(state, run.progress if run is not None else None)
    return state



def _joint(skeleton: Skeleton, name: str, field: str) -> int:
    try:
        return skeleton.index(name)
    except KeyError:
        raise ValueError(f"{field}: no joint named {name!r} in this skeleton") from None


def apply_pose_deltas(pose_quats: np.ndarray, skeleton: Skeleton, deltas, field: str = "deltas") -> np.ndarray:
    """Rotate joints of one pose in their own frames: ``q_j <- q_j * exp(r_j)``.

    Parameters
    ----------
    pose_quats : ndarray, shape (J, 4), local rotations (x, y, z, w)
    deltas : {joint name: [rx, ry, rz]} (or ``((name, (rx, ry, rz)), ...)``) rotation vectors in **degrees**,
        in the joint's local frame

    Returns
    -------
    ndarray, shape (J, 4): edited local rotations (a new array)
    """
    out = np.array(pose_quats, dtype=float)
    for name, rv in (deltas.items() if isinstance(deltas, dict) else deltas):
        j = _joint(skeleton, name, f"{field}.{name}")
        out[j] = quat_mul(out[j], rotvec_to_quat(np.radians(np.asarray(rv, dtype=float))))
    return out


def _frame(m: Motion, f: int, field: str = "frame") -> int:
    if f >= m.num_frames:
        raise ValueError(f"{field}: {f} is outside the motion's {m.num_frames} frames")
    return f


def _pose(sm, k: int, field: str = "pose") -> int:
    if k >= sm.num_poses:
        raise ValueError(f"{field}: {k} is outside the {sm.num_poses} poses")
    return k


def _needs(name: str) -> Callable:
    """The staggered function ``name`` (a clear error while another engineer's function has not landed)."""
    f = getattr(_staggered(), name, None)
    if f is None:
        raise ValueError(f"op needs staggered.{name}, which this version of stagger_nb does not have yet")
    return f


def _list(x):
    return None if x is None else list(x)
