"""The staggered ops (Coleman et al. 2008): extraction, cull, succession and random timing, exaggeration, pose
edits, retime, refine, insert/delete pose, the contact layer, IK posing and ``guide_poses`` (the guided warp of
the pose times, Hsu et al. 2007 on §5.2); a pose edit may spread to the similar poses with the magic wand's
falloff (Dean et al. 2018, §3.3; issue 24).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from ...core.limits import MAX_TAU, MAX_TIMING_LIMIT, TIMING_LIMIT  # each declared once there
from .base import MAX_EXPONENT, MAX_SECONDS, MAX_SKIP, MAX_WEIGHT, MAX_WORLD, Op, _check_free_length, _spec, deltas
from .fields import (
    _deltas_json,
    _index,
    _joints,
    _mode,
    _nonneg,
    _positive,
    _reference_json,
    _region_json,
    boolean,
    falloff_region,
    frame_range,
    integer,
    keytimes,
    number,
    optional,
    pose_reference,
    quaternions,
    text,
    tuple_of,
    warp_reference,
)

if TYPE_CHECKING:
    from .motion import GuidedWarp

__all__ = ["Extract", "Cull", "Succession", "RandomTiming", "Exaggerate", "EditPose", "Retime", "Refine",
           "InsertPose", "DeletePose", "KeepContacts", "IKPose", "GuidePoses"]


def _propagate_spec():
    """The fields ``propagate`` (bool), ``sigma`` and ``frame_range`` of a pose edit that the magic wand
    spreads to every similar pose (Dean et al. 2018, §3.3, on the staggered poses; issue 24)."""
    return (_spec(boolean, False, omit_default=True), _spec(optional(_positive), None, omit_none=True),
            _spec(optional(frame_range), None, omit_none=True))


def _timing_spec():
    """The fields ``joints`` (default all), ``limit`` (the timing saturation's, None: off) and ``falloff`` (a
    region the offsets are scaled by, Dean et al. 2018, §3.3; issue 24) of a timing edit (§5.2)."""
    return (_spec(_joints, None), _spec(optional(number(1.0, MAX_TIMING_LIMIT, open_lo=True)), TIMING_LIMIT),
            _spec(optional(falloff_region), None, to_json=_region_json, omit_none=True))


def _check_propagate(op) -> None:
    if not op.propagate:
        for f in ("sigma", "frame_range"):
            if getattr(op, f) is not None:
                raise ValueError(f"{f}: the falloff's {f} is read only with propagate: true")
@dataclass(frozen=True)
class Extract(Op):
    """The staggered-pose extraction of the current motion (§4), with the session's extract options."""

    name: ClassVar[str] = "extract"
    needs: ClassVar[str] = "motion"


@dataclass(frozen=True)
class Cull(Op):
    """Keep fewer poses (§4.1, prioritized extraction): a ``percent`` of them, a ``count``, or exactly the
    pose indices in ``keep`` (the first and last pose always stay)."""

    name: ClassVar[str] = "cull"
    needs: ClassVar[str] = "staggered"
    percent: float | None = _spec(optional(number(0.0, 100.0, open_lo=True)), None, omit_none=True)
    count: int | None = _spec(optional(integer(2)), None, omit_none=True)
    keep: tuple | None = _spec(optional(tuple_of(_index, "a list of pose indices")), None, omit_none=True)

    def _validate(self):
        given = [k for k in ("percent", "count", "keep") if getattr(self, k) is not None]
        if len(given) != 1:
            raise ValueError(f"{given[1] if len(given) > 1 else 'percent'}: give exactly one of percent, count "
                             f"or keep (got {', '.join(given) or 'none'})")


@dataclass(frozen=True)
class Succession(Op):
    """Succession (§5.2): timing offsets growing with the hierarchy distance from ``root``."""

    name: ClassVar[str] = "succession"
    needs: ClassVar[str] = "staggered"
    root: str = _spec(text)
    s: float = _spec(number(-MAX_SECONDS, MAX_SECONDS))
    l: float = _spec(number(0.0, MAX_EXPONENT, open_lo=True), 1.0)
    joints: tuple | None
    limit: float | None
    falloff: tuple | None
    joints, limit, falloff = _timing_spec()


@dataclass(frozen=True)
class RandomTiming(Op):
    """Random timing offsets of width ``tau`` seconds (§5.2), reproducible by ``seed``."""

    name: ClassVar[str] = "random_timing"
    needs: ClassVar[str] = "staggered"
    tau: float = _spec(number(0.0, MAX_TAU))   # core.limits.MAX_TAU: staggered.random_timing's own bound
    seed: int = _spec(integer(0, 2 ** 63 - 1), 0)
    joints: tuple | None
    limit: float | None
    falloff: tuple | None
    joints, limit, falloff = _timing_spec()


@dataclass(frozen=True)
class Exaggerate(Op):
    """Relative exaggeration ``v + w_r (v - v_ref)`` of ``poses`` (default all) (§5.1)."""

    name: ClassVar[str] = "exaggerate"
    needs: ClassVar[str] = "staggered"
    w_r: float = _spec(number(-MAX_WEIGHT, MAX_WEIGHT))
    poses: tuple | None = _spec(optional(tuple_of(_index, "a list of pose indices")), None)
    reference: Any = _spec(pose_reference, "previous")
    mode: str = _spec(_mode, "staggered")
    joints: tuple | None = _spec(_joints, None)
    propagate: bool
    sigma: float | None
    frame_range: tuple | None
    propagate, sigma, frame_range = _propagate_spec()

    def _validate(self):
        _check_propagate(self)
        if self.propagate and self.poses is None:
            raise ValueError("poses: propagate spreads the exaggeration of the given poses to the similar ones; "
                             "give poses (without them every pose is exaggerated already)")
        if self.propagate and len(set(self.poses)) != len(self.poses):
            raise ValueError(f"poses: a pose is repeated in {list(self.poses)}")


@dataclass(frozen=True)
class EditPose(Op):
    """Geometric edit of pose ``pose`` (§5.1, Fig. 6a/6b), by exactly one of

    - ``deltas``: joint rotations (rotation vectors, degrees, local frames) applied to both knots of each
      joint — the same change whichever knot the user looks at, so ``mode`` does not change the result;
    - ``targets``: new local rotations ``{joint: [x, y, z, w]}`` of the knot the user edits: the true pose
      at ``t_k`` (``mode="staggered"``, Fig. 6a) or the non-staggered extreme values (``"unstaggered"``,
      Fig. 6b); the other knot follows by the same change. Here the two modes give different motions.
    """

    name: ClassVar[str] = "edit_pose"
    needs: ClassVar[str] = "staggered"
    pose: int = _spec(_index)
    deltas: tuple | None = _spec(optional(deltas), None, to_json=_deltas_json, omit_none=True)
    mode: str = _spec(_mode, "staggered")
    targets: tuple | None = _spec(optional(quaternions), None, to_json=_deltas_json, omit_none=True)
    propagate: bool
    sigma: float | None
    frame_range: tuple | None
    propagate, sigma, frame_range = _propagate_spec()

    def _validate(self):
        _check_propagate(self)
        if (self.deltas is None) == (self.targets is None):
            raise ValueError(f"{'deltas' if self.deltas is None else 'targets'}: give exactly one of deltas "
                             "or targets")


@dataclass(frozen=True)
class Retime(Op):
    """Move pose ``pose`` as a unit to ``time`` seconds (§5.2, Fig. 6c)."""

    name: ClassVar[str] = "retime"
    needs: ClassVar[str] = "staggered"
    pose: int = _spec(_index)
    time: float = _spec(_nonneg)


@dataclass(frozen=True)
class Refine(Op):
    """Put joint ``joint``'s knot of pose ``pose`` at the refined time ``time`` = t_k + r[k, j] seconds (§3, §5.2;
    ``staggered.refine``: refused where it would leave that joint's knots out of order)."""

    name: ClassVar[str] = "refine"
    needs: ClassVar[str] = "staggered"
    pose: int = _spec(_index)
    joint: str = _spec(text)
    time: float = _spec(_nonneg)


@dataclass(frozen=True)
class InsertPose(Op):
    """Insert a pose at ``time`` seconds without changing the motion (§5.1)."""

    name: ClassVar[str] = "insert_pose"
    needs: ClassVar[str] = "staggered"
    time: float = _spec(_nonneg)


@dataclass(frozen=True)
class DeletePose(Op):
    """Delete interior pose ``pose`` without changing the motion (§5.1)."""

    name: ClassVar[str] = "delete_pose"
    needs: ClassVar[str] = "staggered"
    pose: int = _spec(_index)


@dataclass(frozen=True)
class KeepContacts(Op):
    """The constraint layer on the edited motion: the source's foot contacts, carried through the staggered
    timing edits, are held (``staggered.keep_contacts``)."""

    name: ClassVar[str] = "keep_contacts"
    needs: ClassVar[str] = "any"


@dataclass(frozen=True)
class IKPose(Op):
    """Move end effector ``joint`` to ``target`` (world units) at pose ``pose``'s time, recorded as a
    staggered pose edit (``staggered.ik_pose``)."""

    name: ClassVar[str] = "ik_pose"
    needs: ClassVar[str] = "staggered"
    pose: int = _spec(_index)
    joint: str = _spec(text)
    target: tuple = _spec(tuple_of(number(-MAX_WORLD, MAX_WORLD), f"a list of 3 numbers (world units, each "
                                                                 f"within +-{MAX_WORLD:g})", 3))
    propagate: bool
    sigma: float | None
    frame_range: tuple | None
    propagate, sigma, frame_range = _propagate_spec()

    def _validate(self):
        _check_propagate(self)


@dataclass(frozen=True)
class GuidePoses(Op):
    """Staggered poses timed like a reference (Hsu et al. 2007 on Coleman et al. 2008): the guided time warp of
    the motion the poses were extracted from to ``reference`` maps every pose time ``t_k``; refinements, splines
    and displacement maps follow the poses (§5.2 retiming), so the staggering is kept and later timing edits
    still apply. ``duration`` (seconds) is the warp's length, by default the reference's (a retimed take of the
    same action); ``free_length`` lets the warp choose it; ``keytimes`` ``[[input_s, output_s], ...]``, ``skip``
    and ``upsample`` as in ``guided_warp``; ``reference`` as in ``guided_warp``."""

    name: ClassVar[str] = "guide_poses"
    needs: ClassVar[str] = "staggered"
    reference: Any = _spec(warp_reference, "self", to_json=_reference_json)
    keytimes: tuple | None = _spec(optional(keytimes), None)
    duration: float | None = _spec(optional(_positive), None, omit_none=True)
    free_length: bool = _spec(boolean, False, omit_default=True)
    skip: int = _spec(integer(1, MAX_SKIP), 8)
    upsample: int | None = _spec(optional(integer(1, 16)), None, omit_none=True)

    def _validate(self):
        _check_free_length(self)

    def warp_op(self, duration: float) -> GuidedWarp:
        """The ``guided_warp`` op this retiming reads its warp from (``duration``: this op's, or the default)."""
        from .motion import GuidedWarp  # late: the motion ops are registered after the staggered ones
        return GuidedWarp(duration=None if self.free_length else float(self.duration or duration),
                          free_length=self.free_length, skip=self.skip, keytimes=self.keytimes,
                          reference=self.reference, upsample=self.upsample)
