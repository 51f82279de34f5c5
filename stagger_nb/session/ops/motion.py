"""The motion ops: direct frame edits, the magic wand's ``propagate`` (Dean et al. 2018), the time warps (guided,
Hsu et al. 2007; linear) and resampling.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from .base import MAX_SKIP, Op, _check_free_length, _spec, deltas
from .fields import (
    _deltas_json,
    _index,
    _positive,
    _reference_json,
    boolean,
    choice,
    frame_range,
    integer,
    keytimes,
    optional,
    tuple_of,
    warp_reference,
)

__all__ = ["EditFrame", "Propagate", "GuidedWarp", "LinearWarp", "Resample"]


@dataclass(frozen=True)
class EditFrame(Op):
    """Rotate joints at one frame by ``deltas`` (degrees, local frames)."""

    name: ClassVar[str] = "edit_frame"
    needs: ClassVar[str] = "motion"
    frame: int = _spec(_index)
    deltas: tuple = _spec(deltas, to_json=_deltas_json)


@dataclass(frozen=True)
class Propagate(Op):
    """The magic wand: edits of the pose at ``frame`` (or at each of ``frames``) propagated to similar
    poses with Green's-function falloff (§3.3, Eqs. 4-5); ``repetitions="discard"`` keeps the edit to
    the edited frame's own neighbourhood (§3.3)."""

    name: ClassVar[str] = "propagate"
    needs: ClassVar[str] = "motion"
    deltas: Any = _spec(None)  # checked in _validate: its form depends on frame / frames
    frame: int | None = _spec(optional(_index), None, omit_none=True)
    frames: tuple | None = _spec(optional(tuple_of(_index, "a list of frame indices")), None, omit_none=True)
    sigma: float | None = _spec(optional(_positive), None)
    frame_range: tuple | None = _spec(optional(frame_range), None)
    repetitions: str = _spec(choice("keep", "discard"), "keep")

    def _validate(self):
        if (self.frame is None) == (self.frames is None):
            raise ValueError("frame: give exactly one of frame or frames")
        if self.frames is None:
            d = deltas(self.deltas, "deltas")
        else:
            n = len(self.frames)
            d = tuple_of(deltas, f"a list of {n} objects {{joint: [rx, ry, rz]}} (one per frame of frames)",
                         n)(self.deltas, "deltas")
            if len(set(self.frames)) != n:
                raise ValueError(f"frames: a frame is repeated in {list(self.frames)}")
        object.__setattr__(self, "deltas", d)

    def to_json(self) -> dict:
        out = super().to_json()
        out["deltas"] = (_deltas_json(self.deltas) if self.frames is None
                         else [_deltas_json(d) for d in self.deltas])
        first = ("op", "frame", "frames", "deltas")  # in the order a person writes them
        return {k: out[k] for k in first if k in out} | {k: v for k, v in out.items() if k not in first}

    @property
    def edits(self) -> tuple:
        """``((frame, deltas), ...)`` one per edited frame."""
        if self.frames is None:
            return ((self.frame, self.deltas),)
        return tuple(zip(self.frames, self.deltas))


@dataclass(frozen=True)
class GuidedWarp(Op):
    """Guided time warp (Hsu et al. 2007): retime to ``duration`` seconds (or, with ``free_length``, the
    length the reference's timing asks for, §3.3 unconstrained) through ``keytimes``, matching
    ``reference``'s local timing; ``backward`` plays the input backwards; ``upsample`` (>= 1) lets a
    same-duration warp redistribute time (default: 2 when the duration equals the input's)."""

    name: ClassVar[str] = "guided_warp"
    needs: ClassVar[str] = "motion"
    duration: float | None = _spec(optional(_positive), None, omit_none=True)
    free_length: bool = _spec(boolean, False)
    skip: int = _spec(integer(1, MAX_SKIP), 8)
    keytimes: tuple | None = _spec(optional(keytimes), None)
    reference: Any = _spec(warp_reference, "self", to_json=_reference_json)
    backward: bool = _spec(boolean, False)
    upsample: int | None = _spec(optional(integer(1, 16)), None, omit_none=True)

    def _validate(self):
        _check_free_length(self)
        if not self.free_length and self.duration is None:
            raise ValueError("duration: required unless free_length is true")


@dataclass(frozen=True)
class LinearWarp(Op):
    """Piecewise-linear time warp to ``duration`` seconds through ``keytimes`` (the spline-style baseline)."""

    name: ClassVar[str] = "linear_warp"
    needs: ClassVar[str] = "motion"
    duration: float = _spec(_positive)
    keytimes: tuple | None = _spec(optional(keytimes), None)


@dataclass(frozen=True)
class Resample(Op):
    """Resample to a new frame time (seconds)."""

    name: ClassVar[str] = "resample"
    needs: ClassVar[str] = "motion"
    frame_time: float = _spec(_positive)
