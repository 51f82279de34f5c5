"""The op base class: :class:`Op` (``from_json`` / ``to_json``, every field checked on construction, the
canonical :attr:`Op.key`), the registry :data:`OPS`, the bounds of the op fields and :func:`limits`, which reads
them back from an op's dataclass (the one definition editors and models use).
"""
from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, ClassVar

from ...core.limits import MAX_TAU, MAX_TIMING_LIMIT, TIMING_LIMIT  # each limit declared once there
from .fields import _fail, joint_map, number, tuple_of

__all__ = ["Op", "OPS", "op_from_json", "validate_op", "canonical", "limits", "deltas", "MAX_SKIP", "MAX_SECONDS",
           "MAX_EXPONENT", "MAX_WEIGHT", "MAX_DEGREES", "MAX_WORLD", "MAX_TAU", "TIMING_LIMIT", "MAX_TIMING_LIMIT"]

#: Every op class by its ``"op"`` name (filled by :class:`Op` subclasses as they are defined).
OPS: dict[str, type[Op]] = {}

MAX_SKIP = 127  # guided warping's largest input step per output frame (timewarp.prepare_warp's limit)
#: Bounds of the timing and weight parameters (a hostile file's 1e308 is refused naming the field instead of
#: overflowing inside the technique): a succession delay or random spread of more than a minute per bone, a
#: succession exponent above 10 (depth^l; depths are ~10), an exaggeration weight beyond +-100.
MAX_SECONDS = 60.0
MAX_EXPONENT = 10.0
MAX_WEIGHT = 100.0
#: Largest component of a joint rotation edit (rotation vector, degrees): one full turn about an axis; a
#: larger value means the same rotations again, and 1e308 would overflow to NaN inside the technique.
MAX_DEGREES = 360.0
#: Largest coordinate of an IK target (world units of the clip: 10 km in centimetres): a target further away
#: is no pose, and 1e308 would overflow inside the solver.
MAX_WORLD = 1e6


def canonical(value) -> str:
    """Canonical JSON text of ``value`` (sorted keys, no spaces, no NaN): equal ops give equal text."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)


#: ``{joint name: [rx, ry, rz]}`` rotation vectors in degrees, in each joint's local frame (each component
#: within +-MAX_DEGREES).
deltas = joint_map(tuple_of(number(-MAX_DEGREES, MAX_DEGREES), f"a list of 3 numbers (rotation vector, degrees, "
                            f"each within +-{MAX_DEGREES:g})", 3), "[rx, ry, rz] degrees")


def _spec(check: Callable, default=dataclasses.MISSING, to_json: Callable | None = None, omit_none: bool = False,
          omit_default: bool = False):
    """A dataclass field checked by ``check``; ``to_json`` turns the stored value back into JSON;
    ``omit_none`` leaves the field out of :meth:`Op.to_json` while it is None (alternatives such as cull's
    ``count``/``keep``; other optional fields are written as ``null``); ``omit_default`` while it equals its
    default (a field added to an op later, e.g. ``edit_pose.propagate``: older ops keep their JSON, their key)."""
    return field(default=default, metadata={"check": check, "to_json": to_json, "omit_none": omit_none,
                                            "omit_default": omit_default})


def limits(op, field_name: str) -> tuple:
    """``(lo, hi, open_lo)`` of the numeric field ``field_name`` of the op class ``op`` (or its name): the
    bounds its check accepts, None where unbounded. The one definition editors and models read (e.g.
    ``limits("random_timing", "tau")`` -> ``(0.0, 60.0, False)``)."""
    cls = OPS[op] if isinstance(op, str) else op
    f = {x.name: x for x in dataclasses.fields(cls)}.get(field_name)
    check = None if f is None else f.metadata.get("check")
    check = getattr(check, "inner", check)
    if check is None or not hasattr(check, "lo"):
        raise ValueError(f"field_name: {cls.name}.{field_name} is not a numeric field")
    return check.lo, check.hi, check.open_lo


@dataclass(frozen=True)
class Op:
    """Base of the op dataclasses. Subclasses set ``name`` (the ``"op"`` value) and ``needs``
    (``"staggered"``, ``"motion"``, or ``"any"`` for an op taking either state as it is)."""

    name: ClassVar[str] = ""
    needs: ClassVar[str] = "motion"

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.__dict__.get("name"):
            if cls.needs not in ("staggered", "motion", "any"):
                raise ValueError(f"needs: expected 'staggered', 'motion' or 'any', got {cls.needs!r}")
            OPS[cls.name] = cls

    def __post_init__(self):
        for f in dataclasses.fields(self):
            check = f.metadata.get("check")
            if check is not None:
                object.__setattr__(self, f.name, check(getattr(self, f.name), f.name))
        self._validate()

    def _validate(self) -> None:
        """Checks across fields (override); raise ValueError naming the field."""

    @classmethod
    def from_json(cls, data: Any, where: str = "op") -> Op:
        """The op of the JSON object ``data`` (the subclass named by ``data["op"]`` when called on
        :class:`Op`). Raises ValueError whose message starts with ``where`` and the bad field."""
        if not isinstance(data, dict):
            _fail(where, 'an object like {"op": "succession", ...}', data)
        name = data.get("op")
        if not isinstance(name, str):
            _fail(f"{where}.op", "an op name", name)
        target = OPS.get(name)
        if target is None:
            raise ValueError(f"{where}.op: unknown op {name!r}; known ops are {', '.join(sorted(OPS))}")
        if cls is not Op and target is not cls:
            _fail(f"{where}.op", repr(cls.name), name)
        fields = {f.name: f for f in dataclasses.fields(target)}
        for key in data:
            if key != "op" and key not in fields:
                raise ValueError(f"{where}.{key}: unknown field of op {name!r}; fields are "
                                 f"{', '.join(fields) or '(none)'}")
        for key, f in fields.items():
            if key not in data and f.default is dataclasses.MISSING:
                raise ValueError(f"{where}.{key}: required field of op {name!r} is missing")
        try:
            return target(**{k: v for k, v in data.items() if k != "op"})
        except ValueError as e:
            raise ValueError(f"{where}.{e}") from None

    def to_json(self) -> dict:
        """The normalised JSON object (``{"op": name, ...}``, every field; an unset alternative left out)."""
        out = {"op": self.name}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if v is None and f.metadata.get("omit_none"):
                continue
            if f.metadata.get("omit_default") and v == f.default:
                continue
            conv = f.metadata.get("to_json")
            out[f.name] = conv(v) if conv is not None and v is not None else _plain(v)
        return out

    @cached_property
    def key(self) -> str:
        """Canonical JSON text of :meth:`to_json` (computed once; equal ops have equal keys)."""
        return canonical(self.to_json())


def _plain(v):
    """Tuples back to JSON lists (recursively)."""
    if isinstance(v, tuple):
        return [_plain(x) for x in v]
    return v


def op_from_json(data: Any, where: str = "op") -> Op:
    """``Op.from_json(data, where)``: the typed op of a JSON object."""
    return Op.from_json(data, where)


def validate_op(op: Any, where: str = "op") -> dict:
    """A normalised copy of the JSON op ``op`` (defaults filled in) or ValueError naming the bad field."""
    return (op if isinstance(op, Op) else Op.from_json(op, where)).to_json()


def _check_free_length(op) -> None:
    """A warp op's ``free_length`` excludes a ``duration`` and ``keytimes`` (the warp chooses its length)."""
    if op.free_length:
        if op.duration is not None:
            raise ValueError("duration: free_length chooses the duration itself; leave duration out")
        if op.keytimes:
            raise ValueError("keytimes: need a duration (free_length chooses the output length itself)")
