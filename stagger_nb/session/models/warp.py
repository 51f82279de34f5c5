"""The WarpEditor's model and its pure ``params <-> ops`` functions (Hsu et al. 2007: duration, skip limit §4,
keytimes §4.2, reference)."""
from __future__ import annotations

import copy
import math
from typing import Any

import traitlets as T

from ..ops import GuidedWarp, LinearWarp, limits
from ..runners import MAX_WARP_RATIO
from ._base import _canon, _finite, _int_within, _Model, snap

__all__ = ["WarpModel", "WARP_OPS", "warp_params_to_ops", "warp_ops_to_params"]

WARP_OPS = ("guided_warp", "linear_warp", "guide_poses")
"""Ops the WarpEditor writes (``guide_poses``: the guided warp applied to the staggered pose times, issue 24)."""


class WarpModel(_Model):
    """Parameters of the guided time-warping editor (Hsu et al. 2007)."""

    mode = T.Enum(["guided", "linear"], "guided", help="guided (DP, §4) or linear time warp").tag(op=True)
    duration = T.Float(1.0, help="output duration (seconds; > 0)").tag(op=True, step="frame_time")
    free_length = T.Bool(False, help="let the warp choose its length (unconstrained end)").tag(op=True)
    skip = T.Int(8, help="skip limit: input frames one output frame may advance (§4; 1 .. 127)").tag(op=True)
    reference = T.Unicode("self", help="'self', 'segment' or the name of a reference clip").tag(op=True)
    segment = T.List(T.Float(), [0.0, 1.0], help="[start, stop] seconds of the source used as reference when "
                                                  "reference = 'segment'").tag(op=True, step="frame_time")
    keytimes = T.List(T.List(T.Float()), help="[[input_s, output_s], ...] keytime constraints (§4.2)").tag(op=True)
    backward = T.Bool(False, help="allow the warp to run backward in time").tag(op=True)
    keytimes_text = T.Unicode("", help="the keytimes as typed, 'in:out, in:out' (seconds): setting it sets "
                                       "keytimes (a malformed entry is refused)").tag(label="keytimes")
    target = T.Enum(["motion", "poses"], "motion",
                    help="what the guided warp retimes: the edited motion (guided_warp) or the staggered pose times "
                         "(guide_poses: refinements and the staggered edits kept and editable; needs a session "
                         "with staggered edits, guided mode, forward)").tag(op=True)
    has_staggered = T.Bool(False, help="the session holds staggered edits (set by the binding): 'poses' applies")

    source_duration = T.Float(0.0, help="duration of the source (seconds; set by the binding)")
    frame_time = T.Float(0.0, help="seconds per frame of the source (set by the binding; 0 = unknown)")
    reference_options = T.List(T.Unicode(), ["self", "segment"], help="names the reference can take")

    @T.validate("duration")
    def _v_duration(self, p):
        lo, _, open_lo = limits(LinearWarp, "duration")
        hi = MAX_WARP_RATIO * self.source_duration if self.source_duration > 0 else None   # the runner's limit
        v = self._number(p, lo, hi, open_lo, unit=" s")
        if not self._loading:
            self._reachable(self.skip, v, "duration")
        return v

    def show_chosen_duration(self, seconds: float) -> None:
        """With free length on (guided), :attr:`duration` shows the duration the warp chose (``seconds``, the
        replay's output; Hsu et al. 2007, §3.3), not the stale target the op no longer holds; set as a load (no
        edit: the free-length op has no duration). Turning free length off goes back to the target it had."""
        if self.free_length and self.mode == "guided" and abs(float(seconds) - self.duration) > 1e-9:
            if getattr(self, "_free_target", None) is None:
                self._free_target = self.duration
            with self.loading():
                self.duration = float(seconds)

    @T.observe("free_length")
    def _back_to_target(self, change):
        """A user turning free length off gets back the target duration the readout showed before it."""
        target, self._free_target = getattr(self, "_free_target", None), None
        if not change["new"] and target is not None and not self._loading:
            try:
                self.duration = target
            except T.TraitError:   # no longer reachable (the skip changed meanwhile): the chosen duration stays
                pass

    @T.validate("skip")
    def _v_skip(self, p):
        lo, hi, _ = limits(GuidedWarp, "skip")
        v = _int_within("skip", p["value"], lo, hi, unit=" input frames per output frame")
        if not self._loading:
            self._reachable(v, self.duration, "skip")
        return v

    def shortest(self, skip: int) -> float:
        """The shortest duration (seconds) a guided warp with ``skip`` reaches: it plays at most ``skip`` input
        frames per output frame (Hsu et al. 2007, §3.1), so ``(n - 1) skip >= N - 1`` frames (0 = unknown)."""
        if not (self.frame_time > 0 and self.source_duration > 0):
            return 0.0
        frames = round(self.source_duration / self.frame_time)   # N - 1
        return math.ceil(frames / max(1, int(skip))) * self.frame_time

    @T.validate("mode")
    def _v_mode(self, p):
        if not self._loading:
            self._reachable(self.skip, self.duration, "mode", mode=p["value"])
        return p["value"]

    @T.validate("free_length")
    def _v_free_length(self, p):
        if not self._loading:
            self._reachable(self.skip, self.duration, "free_length", free_length=p["value"])
        return p["value"]

    def _reachable(self, skip: int, duration: float, what: str, mode: str | None = None,
                   free_length: bool | None = None) -> None:
        """Refuse, in one sentence saying what to do, a skip and duration no guided warp can meet (a compression
        faster than ``skip`` times real time); free length and linear warps have no such bound. ``mode`` and
        ``free_length`` are the values asked for (default: the current ones): switching to guided, or turning
        free length off, at a skip that cannot reach the duration is refused the same way."""
        mode = self.mode if mode is None else mode
        free_length = self.free_length if free_length is None else free_length
        if mode != "guided" or free_length:
            return
        need = self.shortest(skip)
        if need and duration < need - 1e-9:
            frames = round(self.source_duration / self.frame_time)
            least = math.ceil(frames / max(1, round(duration / self.frame_time)))
            if what in ("mode", "free_length"):
                how = "a guided warp" if what == "mode" else "a fixed length"
                raise T.TraitError(f"{how} at {duration:.2f} s needs a skip of {least} or more (skip {skip} plays at "
                                   f"most {skip}x real time: {need:.2f} s at the shortest); raise skip to {least} or "
                                   "more first, or lengthen the duration")
            if what == "skip":
                raise T.TraitError(f"skip {skip} cannot shorten the clip to {duration:.2f} s: it plays at most "
                                   f"{skip}x real time, {need:.2f} s at the shortest; raise skip to {least} or more, "
                                   "or lengthen the duration")
            raise T.TraitError(f"a duration of {duration:.2f} s needs a skip of {least} or more (skip {skip} plays at "
                               f"most {skip}x real time: {need:.2f} s at the shortest); raise skip or lengthen the "
                               "duration")

    @T.validate("segment")
    def _v_segment(self, p):
        v = [_finite("segment", x) if self._loading else snap(_finite("segment", x), self.step("segment"))
             for x in p["value"]]
        if len(v) != 2 or v[1] < v[0] or v[0] < 0 or 0 < self.source_duration < v[1]:
            top = f" <= {self.source_duration:g}" if self.source_duration > 0 else ""
            raise T.TraitError(f"segment: expected [start, stop] seconds with 0 <= start <= stop{top}, got {v}")
        return v

    @T.validate("keytimes")
    def _v_keytimes(self, p):
        out = []
        for i, pair in enumerate(p["value"]):
            if len(pair) != 2:
                raise T.TraitError(f"keytimes[{i}]: expected [input_s, output_s], got {pair}")
            out.append([_finite(f"keytimes[{i}]", x) for x in pair])
            if min(out[-1]) < 0 or 0 < self.source_duration < out[-1][0]:
                raise T.TraitError(f"keytimes[{i}]: expected input time in [0, {self.source_duration:g}] s and "
                                   f"output time >= 0, got {pair}")
            if i and not (out[-1][0] > out[-2][0] and out[-1][1] > out[-2][1]):
                raise T.TraitError(f"keytimes[{i}]: input and output times must both increase, got {out[-2]} "
                                   f"then {out[-1]}")
        return out

    @staticmethod
    def format_keytimes(kt) -> str:
        return ", ".join(f"{a:g}:{b:g}" for a, b in kt)

    @T.validate("keytimes_text")
    def _v_keytimes_text(self, p):
        self._parse_keytimes(p["value"])
        return p["value"]

    @staticmethod
    def _parse_keytimes(text: str) -> list:
        pairs = []
        for item in text.replace(";", ",").split(","):
            if not item.strip():
                continue
            a, sep, b = item.partition(":")
            try:
                if not sep:
                    raise ValueError
                pairs.append([float(a), float(b)])
            except ValueError:
                raise T.TraitError(f"keytimes: {item.strip()!r} is not 'input_time:output_time' (seconds)") from None
        return pairs

    @T.observe("keytimes_text")
    def _typed_keytimes(self, change):
        if self._loading:
            return
        try:
            self.keytimes = self._parse_keytimes(change["new"])
        except T.TraitError:   # refused (out of order, past the clip...): the text shows the keytimes again
            with self.loading():
                self.keytimes_text = self.format_keytimes(self.keytimes)
            raise

    @T.observe("keytimes")
    def _show_keytimes(self, change):
        text = self.format_keytimes(self.keytimes)
        if self._parse_keytimes(self.keytimes_text) != self.keytimes:
            with self.loading():
                self.keytimes_text = text

    def with_keytime(self, input_s: float, output_s: float) -> list:
        """The keytimes with ``[input_s, output_s]`` added, in output-time order (a click on the warp plot)."""
        return sorted(self.keytimes + [[float(input_s), float(output_s)]], key=lambda p: p[1])

    @T.validate("reference")
    def _v_reference(self, p):
        if p["value"] not in self.reference_options:
            raise T.TraitError(f"reference: expected one of {self.reference_options}, got {p['value']!r}")
        return p["value"]


def warp_params_to_ops(p: dict, references: dict | None = None, source_duration: float = 0.0) -> list:
    """The warp op for ``p`` ([] for the identity: guided on itself at the source's duration, no keytimes).

    ``references`` maps a reference name to its op JSON (``{"path": ...}``); "self" and "segment" are built in.
    """
    identity = (p["mode"] == "guided" and p["reference"] == "self" and not p["keytimes"] and not p["free_length"]
                and not p["backward"] and abs(p["duration"] - source_duration) < 1e-9)
    if identity:
        return []
    kt = [[float(a), float(b)] for a, b in p["keytimes"]] or None
    if p["mode"] == "linear":
        op = {"op": "linear_warp", "duration": float(p["duration"])}
        if kt:
            op["keytimes"] = kt
        return [op]
    r = p["reference"]
    if r == "self":
        ref: Any = "self"
    elif r == "segment":
        ref = {"segment": [float(x) for x in p["segment"]]}
    else:
        ref = copy.deepcopy((references or {}).get(r, {"path": r}))
    name = "guide_poses" if p.get("target") == "poses" else "guided_warp"
    op = {"op": name, "duration": float(p["duration"]), "skip": int(p["skip"]), "reference": ref}
    if kt:
        op["keytimes"] = kt
    if p["free_length"]:   # the warp chooses its length: no duration, no keytimes (they need one)
        op["free_length"] = True
        del op["duration"]
        op.pop("keytimes", None)
    if p["backward"] and name == "guided_warp":   # (the pose times keep their order: no backward guide_poses)
        op["backward"] = True
    return [op]


def warp_ops_to_params(ops: list, base: dict, references: dict | None = None,
                       source_duration: float = 0.0) -> tuple[dict, list, dict]:
    """Inverse of :func:`warp_params_to_ops` from the last warp op (no warp op: the identity warp, guided on
    itself at ``source_duration``). Returns ``(params, notes, new_references)``: a path reference the editor did
    not know is offered under its file name (``new_references``)."""
    p = copy.deepcopy(base)
    notes: list = []
    new_refs: dict = {}
    mine = [o for o in ops if o["op"] in WARP_OPS]
    if not mine:
        p.update(mode="guided", reference="self", duration=float(source_duration) or p["duration"], keytimes=[],
                 free_length=False, backward=False)
        return p, notes, new_refs
    o = mine[-1]
    p["mode"] = "linear" if o["op"] == "linear_warp" else "guided"
    p["target"] = "poses" if o["op"] == "guide_poses" else "motion"
    if o.get("duration") is not None:
        p["duration"] = float(o["duration"])
    p["keytimes"] = [[float(a), float(b)] for a, b in (o.get("keytimes") or [])]
    if o["op"] in ("guided_warp", "guide_poses"):
        p["skip"] = int(o.get("skip", 8))
        p["free_length"] = bool(o.get("free_length", False))
        p["backward"] = bool(o.get("backward", False))
        ref = o.get("reference", "self")
        if ref == "self":
            p["reference"] = "self"
        elif isinstance(ref, dict) and "segment" in ref:
            p["reference"], p["segment"] = "segment", [float(x) for x in ref["segment"]]
        else:
            refs = references or {}
            name = next((n for n, j in refs.items() if _canon(j) == _canon(ref)), None)
            if name is None:
                path = ref.get("path", "") if isinstance(ref, dict) else str(ref)
                name = path[len("<memory:"):-1] if path.startswith("<memory:") and path.endswith(">") else \
                    path.replace("\\", "/").rsplit("/", 1)[-1] or "reference"
                while name in ("self", "segment") or (name in refs and _canon(refs[name]) != _canon(ref)):
                    name += "'"
                new_refs[name] = copy.deepcopy(ref)
            p["reference"] = name
    return p, notes, new_refs
