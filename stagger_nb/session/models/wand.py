"""The WandEditor's model and its pure ``params <-> ops`` functions (Dean et al. 2018: σ and repetitions, §3.3)."""
from __future__ import annotations

import copy
import math

import traitlets as T

from ..ops import MAX_DEGREES, Propagate, limits
from ._base import _frame_index, _Model, _with_rotation

__all__ = ["WandModel", "WAND_OPS", "wand_params_to_ops", "wand_ops_to_params"]

WAND_OPS = ("propagate", "edit_frame")
"""Ops the WandEditor writes."""


class WandModel(_Model):
    """Parameters of the magic-wand editor (Dean et al. 2018): one or more edited frames, each a set of joint
    rotations, propagated with the Green's-function falloff of width σ."""

    sigma = T.Float(1.0, help="falloff width σ of the pose-space kernel (§3.3; > 0)").tag(op=True)
    default_sigma = T.Float(0.0, help="the σ a propagate op without one uses (the clip's default σ, set by the "
                                      "editor; 0 = unknown): undoing back to such an op shows it")
    sigma_grid = T.List(T.Float(), help="the σ positions of the editor's slider: the default σ times "
                                        "10^(SIGMA_STEP * n), n = -SIGMA_STEPS..SIGMA_STEPS (x 0.25 .. x 4); set "
                                        "with default_sigma")
    edits = T.Dict(help="{edited frame: {joint: [rx, ry, rz] degrees}}").tag(op=True)
    propagate = T.Bool(True, help="propagate the edits (off: edit only the edited frames)").tag(op=True)
    frame_range = T.List(T.Int(), help="[start, stop) frames the propagation may change ([] = all)").tag(op=True)
    repetitions = T.Enum(["keep", "discard"], "keep",
                         help="propagate to repetitions of the edited pose (keep) or not (discard), §3.3").tag(op=True)

    frame_time = T.Float(0.0, help="seconds per frame of the source (0 = unknown)")
    input_frames = T.Int(0, help="frames of the motion the edited frames index (the wand ops' input; set by "
                                 "the binding; 0 = unknown)")
    edit_frame = T.Int(0, help="the selected edited frame; changing it moves that frame's edit there (an edit "
                               "already at the new frame is selected instead)")
    joint = T.Unicode("", help="joint the rotation controls act on")
    rx = T.Float(0.0, help="rotation of the joint at the edited frame, x (degrees)").tag(step=1.0, label="rotate x")
    ry = T.Float(0.0, help="rotation, y (degrees)").tag(step=1.0, label="rotate y")
    rz = T.Float(0.0, help="rotation, z (degrees)").tag(step=1.0, label="rotate z")
    compare = T.List(T.Enum(["isomap", "diffusion", "spline"]), help="comparison falloffs drawn beside Green's")

    @property
    def edited_frames(self) -> list:
        """The frames holding an edit, sorted."""
        return sorted(self.edits)

    def time_of(self, frame: int) -> float:
        """Seconds of source frame ``frame``."""
        return frame * self.frame_time

    def frame_at(self, seconds: float) -> int:
        """The source frame nearest ``seconds`` (a slider in seconds writes frames: the ops index frames)."""
        return int(round(float(seconds) / self.frame_time)) if self.frame_time > 0 else int(seconds)

    def range_seconds(self, frame_range) -> tuple:
        """``[start, stop)`` frames as seconds (``[]``: the whole clip, ``input_frames`` long)."""
        v = list(frame_range) or [0, self.input_frames]
        return (round(self.time_of(v[0]), 4), round(self.time_of(v[1]), 4))

    def range_frames(self, seconds) -> list:
        """A range in seconds as ``[start, stop)`` frames, at least one frame long."""
        a, b = self.frame_at(seconds[0]), self.frame_at(seconds[1])
        return [a, max(a + 1, b)]

    def frame_weights(self, num_frames: int) -> list:
        """The weight each of ``num_frames`` source frames gets with propagate off: 1 at the edited frames (the
        selected frame when none is edited yet), 0 elsewhere; (F,) floats."""
        w = [0.0] * int(num_frames)
        for f in self.edited_frames or [self.edit_frame]:
            if 0 <= f < len(w):
                w[f] = 1.0
        return w

    def edited_times(self) -> list:
        """Seconds of each edited frame (sorted)."""
        return [self.time_of(f) for f in self.edited_frames]

    SIGMA_STEP = 0.04   # log10 units between the slider's positions
    SIGMA_STEPS = 15    # positions each side of the default sigma

    @T.validate("sigma")
    def _v_sigma(self, p):
        lo, hi, open_lo = limits(Propagate, "sigma")
        return self._number(p, lo, hi, open_lo)

    @T.observe("default_sigma")
    def _grid(self, change):
        s0 = self.default_sigma
        self.sigma_grid = [] if s0 <= 0 else [s0 * 10.0 ** (self.SIGMA_STEP * n)
                                               for n in range(-self.SIGMA_STEPS, self.SIGMA_STEPS + 1)]

    def snap_sigma(self, value: float) -> float:
        """The position of :attr:`sigma_grid` nearest to ``value`` on a log scale (``value`` when there is no
        grid): where the slider lands, so a move hits a warmed eigenbasis."""
        if not self.sigma_grid or not value > 0:
            return float(value)
        return float(min(self.sigma_grid, key=lambda g: abs(math.log(g) - math.log(value))))

    def sigmas_nearest_first(self) -> list:
        """:attr:`sigma_grid` ordered by distance from the current σ (log scale): the order to warm them in."""
        return sorted(self.sigma_grid, key=lambda g: abs(math.log(g) - math.log(self.sigma)))

    @T.validate("edit_frame")
    def _v_edit_frame(self, p):
        return _frame_index("edit_frame", p["value"], self.input_frames, noun="a frame index")

    @T.validate("edits")
    def _v_edits(self, p):
        return self._edits_at("edits", p["value"], self.input_frames, "frames")

    @T.validate("joint")
    def _v_joint_name(self, p):
        return p["value"] if p["value"] == "" else self._known_joint("joint", p["value"])

    range_note = T.Unicode("", help="why frame_range is wider than the range last asked for ('' when it is the "
                                    "range asked for): it always holds every edited frame (set by the model)")

    @T.validate("frame_range")
    def _v_range(self, p):
        v = [int(x) for x in p["value"]]
        if v and (len(v) != 2 or not 0 <= v[0] < v[1] or 0 < self.input_frames < v[1]):
            top = f" <= {self.input_frames}" if self.input_frames else ""
            raise T.TraitError(f"frame_range: expected [] or [start, stop) with 0 <= start < stop{top}, got {v}")
        if self._loading:   # as the session holds it
            return v
        held = self._holding(v)
        self.range_note = "" if held == v else self._range_sentence(v, held)
        return held

    def _edited(self) -> list:
        """The frames holding a non-zero edit (what a propagation must start from)."""
        return sorted(f for f, d in self.edits.items() if any(any(x) for x in d.values()))

    def _holding(self, v: list) -> list:
        """The range ``v`` widened to hold every edited frame (the propagation starts from them: a range that
        leaves one out cannot apply)."""
        frames = self._edited()
        if not v or not frames:
            return v
        return [min(v[0], frames[0]), max(v[1], frames[-1] + 1)]

    def _range_sentence(self, asked: list, held: list) -> str:
        out = [f for f in self._edited() if not asked[0] <= f < asked[1]]
        which = ", ".join(f"{f} ({self.time_of(f):.2f} s)" for f in out[:3]) + (" …" if len(out) > 3 else "")
        return (f"the edit range must hold the edited frame{'s' if len(out) > 1 else ''} {which}: it runs from frame "
                f"{held[0]} ({self.time_of(held[0]):.2f} s) to {held[1]} ({self.time_of(held[1]):.2f} s) instead of "
                f"{asked[0]} to {asked[1]}; move or remove the edit to limit it further")

    @T.observe("edits")
    def _range_follows_edits(self, change):
        """An edit added or moved outside the edit range widens it (said in :attr:`range_note`)."""
        if self._loading or not self.frame_range:
            return
        held = self._holding(list(self.frame_range))
        if held != list(self.frame_range):
            asked = list(self.frame_range)
            self.frame_range = held
            self.range_note = self._range_sentence(asked, held)

    @T.validate("rx", "ry", "rz")
    def _v_rotation(self, p):
        return self._number(p, -MAX_DEGREES, MAX_DEGREES, unit="°")

    def _selected(self):
        return self.edits.get(self.edit_frame, {}).get(self.joint, [0.0, 0.0, 0.0])

    @T.observe("edit_frame")
    def _move_edit(self, change):
        """Changing the edited frame moves its edit there (onto a frame without one) and moves the playhead."""
        old, new = change["old"], change["new"]
        self._seek(new)
        if not self._loading and old in self.edits and new not in self.edits:
            edits = copy.deepcopy(self.edits)
            edits[new] = edits.pop(old)
            self.edits = edits
        self._show_rotation(None)

    @T.observe("joint", "edits")
    def _show_rotation(self, change):
        with self.hold_trait_notifications():
            self.rx, self.ry, self.rz = self._selected()

    @T.observe("rx", "ry", "rz")
    def _rotate(self, change):
        v = [self.rx, self.ry, self.rz]
        if v != self._selected() and self.joint:   # (the frame stays an edited frame when its last joint is zeroed)
            self.edits = _with_rotation(self.edits, self.edit_frame, self.joint, v, keep_empty=True)

    def add_edit(self, frame: int) -> None:
        """Select ``frame`` as a new (empty) edited frame, keeping the others."""
        edits = copy.deepcopy(self.edits)
        edits.setdefault(int(frame), {})
        with self.loading():
            self.edits = edits
            self.edit_frame = int(frame)

    def remove_edit(self, frame: int) -> None:
        edits = copy.deepcopy(self.edits)
        edits.pop(int(frame), None)
        self.edits = edits


def wand_params_to_ops(p: dict) -> list:
    """One ``propagate`` op over every edited frame with a non-zero edit (``frame``/``deltas`` for one,
    ``frames``/``deltas`` lists for several, Dean et al. 2018 §3.3), or one ``edit_frame`` op per edited frame
    when propagation is off."""
    edits = []
    for f in sorted(p["edits"]):
        deltas = {j: [float(x) for x in v] for j, v in p["edits"][f].items() if any(v)}
        if deltas:
            edits.append((int(f), deltas))
    if not edits:
        return []
    if not p["propagate"]:
        return [{"op": "edit_frame", "frame": f, "deltas": d} for f, d in edits]
    if len(edits) == 1:
        op = {"op": "propagate", "frame": edits[0][0], "deltas": edits[0][1]}
    else:
        op = {"op": "propagate", "frames": [f for f, _ in edits], "deltas": [d for _, d in edits]}
    op["sigma"] = float(p["sigma"])
    if p["frame_range"]:
        op["frame_range"] = [int(x) for x in p["frame_range"]]
    if p["repetitions"] != "keep":
        op["repetitions"] = p["repetitions"]
    return [op]


def _wand_edits(op: dict):
    if op.get("frames") is not None:
        return list(zip(op["frames"], op["deltas"]))
    return [(op["frame"], op["deltas"])]


def wand_ops_to_params(ops: list, base: dict, joint_names=(), default_sigma: float | None = None
                       ) -> tuple[dict, list]:
    """Inverse of :func:`wand_params_to_ops` on the session ``ops`` (see :func:`stagger_ops_to_params`).
    A ``propagate`` op without ``sigma`` (the clip's default) reads as ``default_sigma`` when given."""
    p = copy.deepcopy(base)
    notes = []
    known = set(joint_names)
    mine = [o for o in ops if o["op"] in WAND_OPS]
    edits: dict = {}
    for o in mine:
        for f, d in _wand_edits(o):
            edits.setdefault(int(f), {}).update({j: [float(x) for x in v] for j, v in d.items()})
            for j in d:
                if known and j not in known:
                    notes.append(f"{o['op']}.deltas: joint {j!r} is not in this skeleton; the op is kept unchanged")
    p["edits"] = edits
    if mine:
        last = mine[-1]
        p["propagate"] = last["op"] == "propagate"
        if last["op"] == "propagate":
            if last.get("sigma") is not None:
                p["sigma"] = float(last["sigma"])
            elif default_sigma:
                p["sigma"] = float(default_sigma)
            p["frame_range"] = list(last.get("frame_range") or [])
            p["repetitions"] = last.get("repetitions", "keep")
    return p, notes
