"""Typed session operations: one small frozen dataclass per op, with ``from_json`` / ``to_json``.

An op is stored in a session file as a JSON object such as
``{"op": "succession", "root": "LeftShoulder", "s": 0.03, "l": 2.0}``. :meth:`Op.from_json` turns such an
object into the op's dataclass (every field checked; defaults filled in) or raises ``ValueError`` whose
message starts with the field's path, e.g. ``ops[2].s: expected a finite number, got '0.1'``;
:meth:`Op.to_json` gives the normalised object back (``from_json(to_json(op)) == op``). Constructing a
dataclass directly checks its fields the same way. The values are immutable (lists become tuples, joint
deltas a tuple of ``(name, (rx, ry, rz))`` pairs), so an op is hashable and its canonical JSON
(:attr:`Op.key`) is computed once.

Each op says which state it consumes (``needs``): ``"staggered"`` (a
:class:`~stagger_nb.staggered.StaggeredMotion`; a Motion is extracted first, Coleman et al. 2008 §4) or
``"motion"`` (a Motion; a staggered state is evaluated first, §3). The runners are in :mod:`.runners`.

Ops (fields; ``?`` optional, ``=`` default):

======================  ================================================================================
extract                 (none)
cull                    exactly one of ``percent`` (0, 100], ``count`` (int >= 2), ``keep`` (pose indices)
succession              root, s, l=1.0, joints?, limit=1.5 (null: raw), falloff? {frame, sigma?, frame_range?}
                        (§5.2, succession)
random_timing           tau >= 0, seed=0, joints?, limit=1.5 (null: raw), falloff?   (§5.2, random timing)
exaggerate              w_r, poses?, reference="previous" (|"next"|"mean"|pose), mode="staggered", joints?,
                        propagate=false, sigma?, frame_range?
edit_pose               pose, deltas {joint: [rx, ry, rz] deg} | targets {joint: [x, y, z, w]},
                        mode="staggered"|"unstaggered", propagate=false, sigma?, frame_range?   (§5.1, Fig. 6a/6b)
retime                  pose, time (s)                               (§5.2, Fig. 6c)
refine                  pose, joint, time (s): one joint's knot at the refined time t_k + r[k, j]   (§3, §5.2)
insert_pose             time (s)                                     (§5.1)
delete_pose             pose                                         (§5.1)
keep_contacts           (none): constraint layer with the source's contacts carried through the timing edits
ik_pose                 pose, joint, target [x, y, z] (world units, at the pose's time), propagate=false,
                        sigma?, frame_range?
guide_poses             reference="self", keytimes?, duration? (s; default the reference's) | free_length=true,
                        skip=8, upsample?        (pose times by the guided warp, Hsu et al. 2007 on §5.2)
edit_frame              frame, deltas
propagate               frame | frames, deltas (one object, or a list with one per frame), sigma?,
                        frame_range? [start, stop), repetitions="keep"|"discard"   (Dean et al. 2018)
guided_warp             duration (s) | free_length=true, skip=8, keytimes?, reference="self", backward=false,
                        upsample?                                    (Hsu et al. 2007)
linear_warp             duration (s), keytimes?
resample                frame_time (s)
======================  ================================================================================

``propagate: true`` on a pose edit (edit_pose, exaggerate, ik_pose) spreads its change to every pose with the
magic wand's falloff (Dean et al. 2018, §3.3) of the edited pose's source frame (``sigma``, ``frame_range`` its
width and half-open source-frame range); ``falloff`` on a timing edit (succession, random_timing) scales each
pose's offsets by the falloff around source frame ``frame``.

This module imports no technique package: ops are plain data.
"""
from __future__ import annotations

import dataclasses
import json
import math
import numbers
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Callable, ClassVar

from ..core.limits import MAX_TIMING_LIMIT, TIMING_LIMIT   # the one declaration of the timing limit

__all__ = ["Op", "OPS", "op_from_json", "validate_op", "canonical", "check_extract_options", "EXTRACT_OPTIONS",
           "Extract", "Cull", "Succession", "RandomTiming", "Exaggerate", "EditPose", "Retime", "Refine", "InsertPose",
           "DeletePose", "KeepContacts", "IKPose", "GuidePoses", "EditFrame", "Propagate", "GuidedWarp",
           "LinearWarp", "Resample", "MAX_SKIP", "MAX_ITEMS", "MAX_SECONDS", "MAX_EXPONENT", "MAX_WEIGHT",
           "MAX_DEGREES", "MAX_WORLD", "TIMING_LIMIT", "limits"]

#: Every op class by its ``"op"`` name (filled by :class:`Op` subclasses as they are defined).
OPS: dict[str, type["Op"]] = {}

MAX_SKIP = 127  # guided warping's largest input step per output frame (timewarp.prepare_warp's limit)
#: Most items in any list of an op (joints, poses, frames, keytimes, deltas): a hostile session file must
#: not make the checks themselves run for minutes (a 100,000-frame take has fewer poses than this).
MAX_ITEMS = 100_000
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


# --------------------------------------------------------------------------------------------------
# field checks: each takes (value, field_name) and returns the normalised (immutable) value or raises
# ValueError("<field>: expected ..., got ...")
# --------------------------------------------------------------------------------------------------
def _fail(name: str, expected: str, value) -> None:
    shown = repr(value)
    if len(shown) > 80:
        shown = shown[:77] + "..."
    raise ValueError(f"{name}: expected {expected}, got {shown}")


def _limit(value, name) -> None:
    if len(value) > MAX_ITEMS:
        raise ValueError(f"{name}: {len(value)} items is over the limit of {MAX_ITEMS}")


def number(lo: float | None = None, hi: float | None = None, *, open_lo: bool = False) -> Callable:
    """A finite number (not a bool) in ``[lo, hi]`` (``(lo, hi]`` with ``open_lo``), as a float."""
    if lo is None and hi is None:
        expected = "a finite number"
    elif hi is None:
        expected = f"a number {'>' if open_lo else '>='} {lo:g}"
    elif lo is None:
        expected = f"a number <= {hi:g}"
    else:
        expected = f"a number in {'(' if open_lo else '['}{lo:g}, {hi:g}]"

    def check(value, name):
        if isinstance(value, bool) or not isinstance(value, numbers.Real):  # numpy floats and ints are Real
            _fail(name, expected if lo is not None or hi is not None else "a finite number", value)
        try:
            v = float(value)  # an int beyond the float range (e.g. 10**400 in a file) overflows here
        except OverflowError:
            v = math.inf
        if not math.isfinite(v) or (lo is not None and (v <= lo if open_lo else v < lo)) or (
                hi is not None and v > hi):
            _fail(name, expected, value)
        return v
    check.lo, check.hi, check.open_lo = lo, hi, open_lo   # read by limits()
    return check


def integer(lo: int | None = 0, hi: int | None = None) -> Callable:
    """An integer (an integral float such as ``2.0`` is accepted) in ``[lo, hi]``."""
    expected = ("an integer" if lo is None and hi is None else f"an integer >= {lo}" if hi is None
                else f"an integer in [{lo}, {hi}]")

    def check(value, name):
        if isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral) and not isinstance(
                value, bool):
            try:
                value = int(value) if float(value).is_integer() else value  # 2.0 -> 2
            except (OverflowError, ValueError):  # inf, nan
                pass
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or (lo is not None and value < lo) or (
                hi is not None and value > hi):
            _fail(name, expected, value)
        return int(value)  # numpy integers become ints (JSON-serialisable)
    check.lo, check.hi, check.open_lo = lo, hi, False
    return check


def text(value, name) -> str:
    if not isinstance(value, str) or not value:
        _fail(name, "a non-empty string", value)
    return value


def boolean(value, name) -> bool:
    if not isinstance(value, bool):
        _fail(name, "true or false", value)
    return value


def choice(*options) -> Callable:
    def check(value, name):
        if not isinstance(value, str) or value not in options:
            _fail(name, " or ".join(repr(o) for o in options), value)
        return value
    return check


def optional(inner: Callable) -> Callable:
    def check(value, name):
        return None if value is None else inner(value, name)
    check.inner = inner
    return check


def tuple_of(inner: Callable, what: str, length: int | None = None) -> Callable:
    """A list of items checked by ``inner``, as a tuple (of exactly ``length`` items when given)."""
    def check(value, name):
        if not isinstance(value, (list, tuple)) or (length is not None and len(value) != length):
            _fail(name, what, value)
        _limit(value, name)
        return tuple(inner(v, f"{name}[{i}]") for i, v in enumerate(value))
    return check


_finite = number()
_nonneg = number(0.0)
_positive = number(0.0, open_lo=True)
_index = integer(0)
_joints = optional(tuple_of(text, "a list of joint names"))
_mode = choice("staggered", "unstaggered")


def joint_map(inner: Callable, what: str) -> Callable:
    """``{joint name: value}`` with each value checked by ``inner`` -> ``((name, value), ...)`` (the stored,
    hashable form, which is accepted again)."""
    def check(value, name):
        if isinstance(value, tuple) and all(isinstance(p, tuple) and len(p) == 2 for p in value):
            value = dict(value)  # the stored form
        if not isinstance(value, dict):
            _fail(name, f"an object {{joint name: {what}}}", value)
        _limit(value, name)
        return tuple((text(k, f"{name} key"), inner(v, f"{name}.{k}")) for k, v in value.items())
    return check


def _quaternion(value, name) -> tuple:
    q = tuple_of(_finite, "a quaternion [x, y, z, w]", 4)(value, name)
    if sum(c * c for c in q) < 1e-12:
        _fail(name, "a non-zero quaternion [x, y, z, w]", value)
    return q


#: ``{joint name: [rx, ry, rz]}`` rotation vectors in degrees, in each joint's local frame (each component
#: within +-MAX_DEGREES).
deltas = joint_map(tuple_of(number(-MAX_DEGREES, MAX_DEGREES), f"a list of 3 numbers (rotation vector, degrees, "
                            f"each within +-{MAX_DEGREES:g})", 3), "[rx, ry, rz] degrees")
#: ``{joint name: [x, y, z, w]}`` local rotations (non-zero quaternions).
quaternions = joint_map(_quaternion, "[x, y, z, w]")


def _deltas_json(d: tuple) -> dict:
    return {k: list(v) for k, v in d}


def keytimes(value, name) -> tuple:
    """``[[input_seconds, output_seconds], ...]`` -> tuple of pairs (order is checked by the technique)."""
    if not isinstance(value, (list, tuple)):
        _fail(name, "a list of [input_time, output_time] pairs (seconds)", value)
    _limit(value, name)
    return tuple(tuple_of(_nonneg, "[input_time, output_time] (seconds)", 2)(p, f"{name}[{i}]")
                 for i, p in enumerate(value))


def frame_range(value, name) -> tuple:
    a, b = tuple_of(_index, "[start_frame, stop_frame]", 2)(value, name)
    if b <= a:
        _fail(name, "start_frame < stop_frame (half-open range)", value)
    return (a, b)


def time_range(value, name) -> tuple:
    a, b = tuple_of(_finite, "[start, stop] (seconds)", 2)(value, name)
    if b < a:
        _fail(name, "start <= stop", value)
    return (a, b)


def warp_reference(value, name):
    """``"self"``, ``{"segment": [start_s, stop_s]}`` of the source, or ``{"path": "clip.bvh"}`` (also an
    in-memory clip registered with ``Session.use_reference``). Stored as ``"self"``, ``("segment", a, b)``
    or ``("path", p)``."""
    if value == "self":
        return value
    if isinstance(value, tuple) and value and value[0] in ("segment", "path"):  # the stored form
        value = {"segment": list(value[1:])} if value[0] == "segment" else {"path": value[1]}
    if isinstance(value, dict) and len(value) == 1:
        if "segment" in value:
            return ("segment",) + time_range(value["segment"], f"{name}.segment")
        if "path" in value:
            return ("path", text(value["path"], f"{name}.path"))
    _fail(name, '"self", {"segment": [start, stop]} or {"path": "file.bvh"}', value)


def _reference_json(r):
    return r if r == "self" else {"segment": list(r[1:])} if r[0] == "segment" else {"path": r[1]}


def pose_reference(value, name):
    if value in ("previous", "next", "mean"):
        return value
    return integer(0)(value, name) if not isinstance(value, str) else _fail(
        name, '"previous", "next", "mean" or a pose index', value)


def falloff_region(value, name) -> tuple:
    """A magic-wand region ``{"frame": f, "sigma": σ (optional, > 0), "frame_range": [start, stop) (optional)}``
    (Dean et al. 2018, §3.3: the falloff around source frame ``f``) -> ``(("frame", f), ("sigma", σ | None),
    ("frame_range", (start, stop) | None))`` (the stored, hashable form, which is accepted again)."""
    if isinstance(value, tuple) and all(isinstance(p, tuple) and len(p) == 2 for p in value):
        value = dict(value)  # the stored form
    if not isinstance(value, dict):
        _fail(name, '{"frame": f, "sigma": s} (a source frame, an optional falloff width)', value)
    for k in value:
        if k not in ("frame", "sigma", "frame_range"):
            raise ValueError(f"{name}.{k}: unknown field of a falloff region; fields are frame, sigma, frame_range")
    if "frame" not in value:
        raise ValueError(f"{name}.frame: required field of a falloff region is missing")
    fr = value.get("frame_range")
    fr = None if fr is None else frame_range(fr, f"{name}.frame_range")
    f = _index(value["frame"], f"{name}.frame")
    if fr is not None and not fr[0] <= f < fr[1]:
        _fail(f"{name}.frame", f"a frame inside frame_range [{fr[0]}, {fr[1]})", value["frame"])
    return (("frame", f), ("sigma", optional(_positive)(value.get("sigma"), f"{name}.sigma")), ("frame_range", fr))


def _region_json(r: tuple) -> dict:
    d = dict(r)
    out = {"frame": d["frame"], "sigma": d["sigma"]}
    if d["frame_range"] is not None:
        out["frame_range"] = list(d["frame_range"])
    return out


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


# --------------------------------------------------------------------------------------------------
# the op base class
# --------------------------------------------------------------------------------------------------
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
    def from_json(cls, data: Any, where: str = "op") -> "Op":
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


# --------------------------------------------------------------------------------------------------
# staggered ops (Coleman et al. 2008)
# --------------------------------------------------------------------------------------------------
def _propagate_spec():
    """The fields ``propagate`` (bool), ``sigma`` and ``frame_range`` of a pose edit that the magic wand
    spreads to every similar pose (Dean et al. 2018, §3.3, on the staggered poses; issue 24)."""
    return (_spec(boolean, False, omit_default=True), _spec(optional(_positive), None, omit_none=True),
            _spec(optional(frame_range), None, omit_none=True))


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
    l: float = _spec(number(0.0, MAX_EXPONENT, open_lo=True), 1.0)  # noqa: E741 (the paper's name)
    joints: tuple | None = _spec(_joints, None)
    limit: float | None = _spec(optional(number(1.0, MAX_TIMING_LIMIT, open_lo=True)), TIMING_LIMIT)
    falloff: tuple | None = _spec(optional(falloff_region), None, to_json=_region_json, omit_none=True)


@dataclass(frozen=True)
class RandomTiming(Op):
    """Random timing offsets of width ``tau`` seconds (§5.2), reproducible by ``seed``."""

    name: ClassVar[str] = "random_timing"
    needs: ClassVar[str] = "staggered"
    tau: float = _spec(number(0.0, MAX_SECONDS))
    seed: int = _spec(integer(0, 2 ** 63 - 1), 0)
    joints: tuple | None = _spec(_joints, None)
    limit: float | None = _spec(optional(number(1.0, MAX_TIMING_LIMIT, open_lo=True)), TIMING_LIMIT)
    falloff: tuple | None = _spec(optional(falloff_region), None, to_json=_region_json, omit_none=True)


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


def _check_free_length(op) -> None:
    """A warp op's ``free_length`` excludes a ``duration`` and ``keytimes`` (the warp chooses its length)."""
    if op.free_length:
        if op.duration is not None:
            raise ValueError("duration: free_length chooses the duration itself; leave duration out")
        if op.keytimes:
            raise ValueError("keytimes: need a duration (free_length chooses the output length itself)")


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

    def warp_op(self, duration: float) -> "GuidedWarp":
        """The ``guided_warp`` op this retiming reads its warp from (``duration``: this op's, or the default)."""
        return GuidedWarp(duration=None if self.free_length else float(self.duration or duration),
                          free_length=self.free_length, skip=self.skip, keytimes=self.keytimes,
                          reference=self.reference, upsample=self.upsample)


# --------------------------------------------------------------------------------------------------
# motion ops: direct edits, the magic wand (Dean et al. 2018), time warps (Hsu et al. 2007)
# --------------------------------------------------------------------------------------------------
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


# --------------------------------------------------------------------------------------------------
# extraction options (the session's ``extract_options``: keyword arguments of ``staggered.extract``)
# --------------------------------------------------------------------------------------------------
def _contacts(value, name):
    def one(c, n):
        if not isinstance(c, (list, tuple)) or len(c) != 3:
            _fail(n, "[joint_name, start_frame, stop_frame]", c)
        return [text(c[0], f"{n}[0]"), _index(c[1], f"{n}[1]"), _index(c[2], f"{n}[2]")]
    if not isinstance(value, (list, tuple)):
        _fail(name, "a list of [joint_name, start_frame, stop_frame]", value)
    _limit(value, name)
    return [one(c, f"{name}[{i}]") for i, c in enumerate(value)]


#: Allowed ``extract_options`` with their checks. Ranges bound the work an option can ask for
#: (``iterations: 1e9`` or ``filter_width: 1e9`` would hang or allocate without end, issue 13).
EXTRACT_OPTIONS: dict[str, Callable] = {
    "iterations": integer(0, 10),                              # spline refits (paper: 2)
    "continuity": choice("C1", "C0"),
    "filter_width": number(0.0, 5.0, open_lo=True),            # seconds, tent half-width (paper: 0.15)
    "refinement_window": number(0.0, 5.0),                     # seconds (paper: 0.25)
    "smoothing_iterations": optional(integer(0, 10_000)),      # Laplacian passes
    "smoothing_lambda": number(0.0, 1.0, open_lo=True),
    "root_translation_weight": number(0.0, 1e6),
    "contacts": optional(_contacts),
    "contact_weight": number(0.0, 1e3),
    "contact_tolerance": optional(number(0.0, 1e6, open_lo=True)),
    "contact_min_duration": number(0.0, 60.0),
    "min_prominence": number(0.0, 1.0),
}


def check_extract_options(options, name: str = "extract_options") -> dict:
    """A checked copy of ``options`` (JSON values) or ValueError naming ``extract_options.<key>``."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        _fail(name, "an object", options)
    out = {}
    for k, v in options.items():
        check = EXTRACT_OPTIONS.get(k)
        if check is None:
            raise ValueError(f"{name}.{k}: unknown option; options are {', '.join(sorted(EXTRACT_OPTIONS))}")
        out[k] = check(v, f"{name}.{k}")
    return out
