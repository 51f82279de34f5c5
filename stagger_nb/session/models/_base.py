"""What the three editor models share: the playhead, the joint names, the message, validators.

Validators raise ``traitlets.TraitError`` with a message naming the trait (as ``ValueError`` does elsewhere).
"""
from __future__ import annotations

import contextlib
import copy
import json
import math

import traitlets as T

from ..ops import MAX_DEGREES

__all__ = ["_Model", "snap"]


def _canon(x) -> str:
    return json.dumps(x, sort_keys=True, separators=(",", ":"), default=str)


def _g(v: float) -> str:
    """A number as a person writes it (``0.35``, ``1e+308``, ``100``)."""
    return f"{v:.6g}"


def _finite(name: str, v) -> float:
    try:
        v = float(v)
    except (TypeError, ValueError, OverflowError):
        raise T.TraitError(f"{name} must be a number, got {v!r}") from None
    if not math.isfinite(v):
        raise T.TraitError(f"{name} must be a finite number, got {v!r}")
    return v


def _int_within(name: str, v: int, lo: int, hi: int, unit: str = "") -> int:
    """An integer ``v`` inside ``[lo, hi]``, else a TraitError, e.g. "seed must lie between 0 and 9, got -1"."""
    if not lo <= v <= hi:
        raise T.TraitError(f"{name} must lie between {lo} and {hi}{unit}, got {v}")
    return v


def _frame_index(field: str, v: int, n: int, noun: str = "an index", of: str = "") -> int:
    """An index ``v >= 0`` and, once there are ``n > 0`` items, ``< n``; else a TraitError naming ``field``."""
    if v < 0 or 0 < n <= v:
        top = f" and < {n}{of}" if n else ""
        raise T.TraitError(f"{field}: expected {noun} >= 0{top}, got {v}")
    return v


def _with_rotation(edits: dict, key, joint: str, v: list, keep_empty: bool = False) -> dict:
    """A copy of ``edits {key: {joint: [rx, ry, rz]}}`` with ``joint``'s rotation at ``key`` set to ``v``: dropped
    where ``v`` is all zeros, and ``key`` with it when nothing is left there (unless ``keep_empty``)."""
    edits = copy.deepcopy(edits)
    d = edits.setdefault(key, {})
    d[joint] = v
    if not any(v):
        del d[joint]
        if not d and not keep_empty:
            del edits[key]
    return edits


def _within(name: str, v, lo=None, hi=None, open_lo: bool = False, unit: str = "") -> float:
    """``v`` as a finite float inside the bounds (None: unbounded; ``open_lo``: ``lo`` itself excluded), else a
    TraitError saying in one sentence where it must lie, e.g. "tau must lie between 0 and 60 s, got -0.1"."""
    v = _finite(name, v)
    below = lo is not None and (v <= lo if open_lo else v < lo)
    if below or (hi is not None and v > hi):
        if lo is not None and hi is not None and not open_lo:
            where = f"lie between {_g(lo)}{unit} and {_g(hi)}{unit}"
        else:
            parts = ([f"more than {_g(lo)}{unit}" if open_lo else f"at least {_g(lo)}{unit}"] if lo is not None
                     else []) + ([f"at most {_g(hi)}{unit}"] if hi is not None else [])
            where = "be " + " and ".join(parts)
        raise T.TraitError(f"{name} must {where}, got {_g(v)}{unit}")
    return v


def _deltas3(name: str, d, limit: float) -> dict:
    """``{joint: [rx, ry, rz]}`` degrees, each component within ``+-limit``."""
    if not isinstance(d, dict):
        raise T.TraitError(f"{name}: expected {{joint: [rx, ry, rz] degrees}}, got {d!r}")
    out = {}
    for j, v in d.items():
        if not isinstance(j, str) or not isinstance(v, (list, tuple)) or len(v) != 3:
            raise T.TraitError(f"{name}.{j}: expected [rx, ry, rz] degrees, got {v!r}")
        out[j] = [_within(f"{name}.{j}", x, -limit, limit, unit="°") for x in v]
    return out


def snap(value: float, step: float | None) -> float:
    """``value`` rounded to one decimal finer than ``step`` (a control's step: 0.05 -> 3 decimals, 1/120 s -> 4),
    so a slider's ``min + n * step`` (0.3500000000000001) is shown and saved as 0.35 while a value typed between
    two steps keeps its meaning. ``step`` None or <= 0: unchanged."""
    if not step or step <= 0 or not math.isfinite(value):
        return value
    return round(value, max(0, math.ceil(-math.log10(step) - 1e-9)) + 1) + 0.0


class _Model(T.HasTraits):
    """Common traits: the playhead, the names the model knows, and the plain-text message."""

    frame = T.Int(0, help="the playhead: frame index (0-based) shown by the 3D view and every time plot")
    joint_names = T.List(T.Unicode(), help="joint names of the source skeleton (set by the binding)")
    message = T.Unicode("", help="plain-text note about the parameters ('' when none): a refused value, an "
                                 "op naming a joint this skeleton does not have")

    hint = T.Unicode("", help="plain-text suggestion of what would improve the edit ('' when none), e.g. holding "
                              "the feet a timing edit slides; never a refusal (those are the message)")

    num_frames = T.Int(0, help="frames of the edited motion the playhead moves over (set by the editor when "
                               "it shows a new edit; 0 = unknown)")
    notes = T.Dict(help="{trait: plain sentence}: why the last value given to that trait through "
                        ":meth:`set_control` was refused (the control shows it beside itself); cleared when the "
                        "trait takes a value")

    @T.validate("frame")
    def _v_frame(self, proposal):
        return _frame_index("frame", proposal["value"], self.num_frames, of=" (the edited motion's frames)")

    def _known_joint(self, field: str, name) -> str:
        """``name`` if this skeleton has it (or the names are not known yet), else a TraitError naming ``field``."""
        if not isinstance(name, str):
            raise T.TraitError(f"{field}: expected a joint name, got {name!r}")
        if self.joint_names and name not in self.joint_names:
            raise T.TraitError(f"{field}: no joint named {name!r} in this skeleton")
        return name

    def _index_below(self, field: str, k, n: int, what: str) -> int:
        """``k`` as an int if ``0 <= k < n`` (``n`` = 0: not known yet), else a TraitError naming ``field``."""
        k = int(k)
        if k < 0 or 0 < n <= k:
            raise T.TraitError(f"{field}: {k} is outside the {n} {what}" if k >= 0 else
                               f"{field}: expected an index >= 0, got {k}")
        return k

    def _edits_at(self, field: str, value: dict, n: int, what: str, held=()) -> dict:
        """``{index: {joint: [rx, ry, rz]}}`` validated: each index below ``n`` (indices in ``held`` are not
        re-checked), each joint known, each rotation three finite degrees."""
        out = {}
        for k, v in value.items():
            k = int(k) if int(k) in held else self._index_below(field, k, n, what)
            out[k] = _deltas3(f"{field}[{k}]", v, MAX_DEGREES)
            for j in out[k]:
                self._known_joint(f"{field}[{k}]", j)
        return out

    def _seek(self, frame: int) -> None:
        """Move the playhead to ``frame`` as the model itself does (a pose's or an edited frame's time, which may
        lie past a shorter warped edit): clamped to the edited motion, never refused."""
        self.frame = min(int(frame), self.num_frames - 1) if self.num_frames else int(frame)

    @T.observe("num_frames")
    def _keep_frame_inside(self, change):
        if 0 < change["new"] <= self.frame:   # a shorter edit (a warp): the playhead moves to its last frame
            self.frame = change["new"] - 1

    _loading = False

    @contextlib.contextmanager
    def loading(self):
        """Set traits as a load (from the session), not as a user edit: observers that turn a user's move
        into an edit (moving an edited frame, recording an IK target) stand still."""
        old, self._loading = self._loading, True
        try:
            yield self
        finally:
            self._loading = old

    # -- controls ------------------------------------------------------------------------------------
    def step(self, name: str) -> float | None:
        """The step of the control of trait ``name`` (its ``step`` metadata; ``"frame_time"`` means the clip's
        seconds per frame): the one place a slider's step is defined, and what values are rounded to."""
        st = self.trait_metadata(name, "step")
        if st == "frame_time":
            return float(getattr(self, "frame_time", 0.0) or 0.0) or None
        return st

    def _number(self, proposal, lo=None, hi=None, open_lo: bool = False, unit: str = "") -> float:
        """A validator's number: finite, inside the bounds (a TraitError in one plain sentence naming the
        trait's label), rounded to its control's step (:func:`snap`) unless loaded from the session."""
        name = proposal["trait"].name
        v = _within(self.label(name), proposal["value"], lo, hi, open_lo, unit)
        return v if self._loading else snap(v, self.step(name))

    def label(self, name: str) -> str:
        """The words a message uses for trait ``name`` (its ``label`` metadata, else the name)."""
        return self.trait_metadata(name, "label") or name

    #: the trait :meth:`set_control` is setting (None otherwise): the binding merges a control's quick
    #: successive changes into one undo step (a drag), not those of code setting traits
    _control_change = None

    def set_control(self, name: str, value) -> str:
        """Set trait ``name`` to ``value`` as a control does: '' when it took the value; otherwise the model
        is left as it was, ``notes[name]`` holds the plain sentence saying why and it is returned. Quick
        successive changes from a control are one undo step (:class:`~.binding.ModelBinding`)."""
        old, self._control_change = self._control_change, name
        try:
            setattr(self, name, value)
        except T.TraitError as e:
            why = str(e)
            self.notes = {**self.notes, name: why}
            return why
        finally:
            self._control_change = old
        if name in self.notes:
            self.notes = {k: v for k, v in self.notes.items() if k != name}
        return ""

    def params(self) -> dict:
        """The op parameters (traits tagged ``op=True``) as a plain dict (deep copy)."""
        return {k: copy.deepcopy(getattr(self, k)) for k in self.trait_names(op=True)}
