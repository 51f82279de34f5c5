"""Checks of the ops' fields and of the session's ``extract_options``: each takes ``(value, field_name)`` and
returns the normalised, immutable value (lists become tuples, joint maps tuples of ``(name, value)`` pairs) or
raises ``ValueError("<field>: expected ..., got ...")``. A numeric check carries its bounds (``check.lo``,
``check.hi``, ``check.open_lo``), which :func:`~stagger_nb.session.ops.limits` reads: the one definition of each
limit is the check an op's dataclass field declares.
"""
from __future__ import annotations

import math
import numbers
from collections.abc import Callable

__all__ = ["MAX_ITEMS", "number", "integer", "text", "boolean", "choice", "optional", "tuple_of", "joint_map",
           "quaternions", "keytimes", "frame_range", "time_range", "warp_reference", "pose_reference",
           "falloff_region", "EXTRACT_OPTIONS", "check_extract_options"]

#: Most items in any list of an op (joints, poses, frames, keytimes, deltas): a hostile session file must
#: not make the checks themselves run for minutes (a 100,000-frame take has fewer poses than this).
MAX_ITEMS = 100_000


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
