"""Editor models: one evented ``traitlets.HasTraits`` per editor, the pure ``params <-> ops`` functions, and the
binding that keeps a model and a :class:`~stagger_nb.session.Session` in step.

The model is the single place an editor's state lives (STYLE.md lesson 9). Controls ``link`` to its traits and
views observe it; :class:`ModelBinding` turns a model change into ``session.set_ops`` (one undo step) and a session
change (undo/redo, load, code calling ``set_ops``) back into model traits. Nothing here imports ipywidgets.

Ownership. Each editor *owns* some op names (:data:`STAGGER_OPS`, :data:`WAND_OPS`, :data:`WARP_OPS`); every other
op of the session is foreign and is kept, in place, by :func:`merge_ops`. Inside an owned op, fields the editor
does not control (e.g. ``exaggerate.poses``) are kept as well. Only the owned ops whose parameters changed are
rewritten, so an op the editor cannot represent (two ``succession`` ops, a ``cull`` by a field it shows
differently) survives until the user moves the matching control.

Values coming from a session are never clamped: ``skip=100`` stays 100 (a slider's range grows to show it); a
joint name the skeleton does not have becomes a readable note in ``model.message`` and the op is kept unchanged.

Papers: Coleman et al. 2008 (staggered poses: cull §4.3, succession and random timing §5.2, exaggeration §5.3,
pose edits §5.1 Fig. 6), Dean et al. 2018 (magic wand: σ and repetitions §3.3), Hsu et al. 2007 (guided time
warping: duration, skip limit §4, keytimes §4.2, reference).
"""
from __future__ import annotations

import contextlib
import copy
import json
import math
from typing import Any, Callable

import traitlets as T

from .runners import MAX_WARP_RATIO

__all__ = ["StaggerModel", "WandModel", "WarpModel", "ModelBinding", "merge_ops",
           "stagger_params_to_ops", "stagger_ops_to_params", "wand_params_to_ops", "wand_ops_to_params",
           "warp_params_to_ops", "warp_ops_to_params", "STAGGER_OPS", "WAND_OPS", "WARP_OPS"]

STAGGER_OPS = ("cull", "edit_pose", "retime", "ik_pose", "exaggerate", "succession", "random_timing",
               "keep_contacts")
"""Ops the StaggerEditor writes, in the order it inserts them (staggered ops first, the constraint last)."""
WAND_OPS = ("propagate", "edit_frame")
WARP_OPS = ("guided_warp", "linear_warp")

# fields of each owned op the editor controls (others, e.g. exaggerate.poses, are kept as they are)
_CONTROLLED = {
    "cull": ("percent", "count", "keep"),
    "succession": ("root", "s", "l", "joints"),
    "random_timing": ("tau", "seed", "joints"),
    "exaggerate": ("w_r", "reference"),
    "edit_pose": ("pose", "deltas", "targets", "mode"),
    "retime": ("pose", "time"),
    "ik_pose": ("pose", "joint", "target"),
    "keep_contacts": (),
    "propagate": ("frame", "frames", "deltas", "sigma", "frame_range", "repetitions"),
    "edit_frame": ("frame", "deltas"),
    "guided_warp": ("duration", "free_length", "skip", "reference", "keytimes", "backward"),
    "linear_warp": ("duration", "keytimes"),
}


def _canon(x) -> str:
    return json.dumps(x, sort_keys=True, separators=(",", ":"), default=str)


# --------------------------------------------------------------------------------------------------
# shared validation helpers (TraitError messages name the trait, as ValueError does elsewhere)
# --------------------------------------------------------------------------------------------------
def _finite(name: str, v) -> float:
    v = float(v)
    if not math.isfinite(v):
        raise T.TraitError(f"{name}: expected a finite number, got {v!r}")
    return v


def _deltas3(name: str, d) -> dict:
    if not isinstance(d, dict):
        raise T.TraitError(f"{name}: expected {{joint: [rx, ry, rz] degrees}}, got {d!r}")
    out = {}
    for j, v in d.items():
        if not isinstance(j, str) or not isinstance(v, (list, tuple)) or len(v) != 3:
            raise T.TraitError(f"{name}.{j}: expected [rx, ry, rz] degrees, got {v!r}")
        out[j] = [_finite(f"{name}.{j}", x) for x in v]
    return out


class _Model(T.HasTraits):
    """Common traits: the playhead, the names the model knows, and the plain-text message."""

    frame = T.Int(0, help="the playhead: frame index (0-based) shown by the 3D view and every time plot")
    joint_names = T.List(T.Unicode(), help="joint names of the source skeleton (set by the binding)")
    message = T.Unicode("", help="plain-text note about the parameters ('' when none): a refused value, an "
                                 "op naming a joint this skeleton does not have")

    num_frames = T.Int(0, help="frames of the edited motion the playhead moves over (set by the editor when "
                               "it shows a new edit; 0 = unknown)")

    @T.validate("frame")
    def _v_frame(self, proposal):
        if proposal["value"] < 0 or 0 < self.num_frames <= proposal["value"]:
            top = f" and < {self.num_frames} (the edited motion's frames)" if self.num_frames else ""
            raise T.TraitError(f"frame: expected an index >= 0{top}, got {proposal['value']}")
        return proposal["value"]

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
            out[k] = _deltas3(f"{field}[{k}]", v)
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

    def params(self) -> dict:
        """The op parameters (traits tagged ``op=True``) as a plain dict (deep copy)."""
        return {k: copy.deepcopy(getattr(self, k)) for k in self.trait_names(op=True)}


# --------------------------------------------------------------------------------------------------
# StaggerEditor
# --------------------------------------------------------------------------------------------------
class StaggerModel(_Model):
    """Parameters of the staggered-pose editor (Coleman et al. 2008).

    Op traits (tagged ``op=True``) map to ops with :func:`stagger_params_to_ops`; the others are view state
    (selected pose and joint, the nudge of that joint, the IK effector and target) kept consistent with them.
    """

    cull_by = T.Enum(["percent", "count", "keep"], "percent", help="how poses are culled (§4.3)").tag(op=True)
    percent = T.Float(100.0, help="keep this % of the candidate poses (cull by percent; 100 = all)").tag(op=True)
    count = T.Int(0, help="keep this many poses (cull by count; 0 = all)").tag(op=True)
    keep = T.List(T.Int(), help="indices of the candidate poses to keep (cull by picking; [] = all)").tag(op=True)
    root = T.Unicode("", help="succession root joint (§5.2)").tag(op=True)
    joints = T.List(T.Unicode(), help="joints the succession delays ([] = all)").tag(op=True)
    s = T.Float(0.0, help="succession delay per bone (seconds; 0 = off)").tag(op=True)
    l = T.Float(1.0, help="succession exponent l (> 0; inert when s = 0)").tag(op=True)
    tau = T.Float(0.0, help="random timing spread τ (seconds; 0 = off)").tag(op=True)
    tau_joints = T.List(T.Unicode(), help="joints τ applies to ([] = all)").tag(op=True)
    seed = T.Int(0, help="random seed of τ").tag(op=True)
    w_r = T.Float(0.0, help="exaggeration weight w_r (§5.3; 0 = off)").tag(op=True)
    w_r_reference = T.Union([T.Enum(["previous", "next", "mean"]), T.Int()], default_value="previous",
                            help="exaggerate against the previous / next / mean pose or a pose index").tag(op=True)
    pose_edits = T.Dict(help="{pose index: {joint: [rx, ry, rz] degrees}} geometric pose edits (§5.1)").tag(op=True)
    edit_mode = T.Enum(["staggered", "unstaggered"], "staggered",
                       help="pose edits in staggered (Fig. 6a) or non-staggered (Fig. 6b) mode").tag(op=True)
    retimes = T.Dict(help="{pose index: new time (s)} (Fig. 6c)").tag(op=True)
    ik_targets = T.List(T.Dict(), help="[{pose, joint, target: [x, y, z]}] IK pose edits").tag(op=True)
    keep_contacts = T.Bool(True, help="hold the source's foot contacts through the timing edits").tag(op=True)

    # view state
    edit_bases = T.Dict(help="{pose index: {joint: [x, y, z, w]}} the true pose value (editing knot at t_k) each "
                             "nudge starts from, set by the binding: pose edits are then written as targets "
                             "base ⊕ nudge, so edit_mode chooses the knot that reaches them (§5.1, Fig. 6a/6b)")
    pose = T.Int(0, help="selected pose index (the nudge, retime and IK controls act on it)")
    joint = T.Unicode("", help="selected joint (curves, nudge)")
    rx = T.Float(0.0, help="nudge of the selected joint at the selected pose, x (degrees)")
    ry = T.Float(0.0, help="nudge, y (degrees)")
    rz = T.Float(0.0, help="nudge, z (degrees)")
    pose_times = T.List(T.Float(), help="times (s) of the current poses (set by the binding)")
    pose_time = T.Float(0.0, help="time (s) of the selected pose; a user change retimes it (Fig. 6c)")
    frame_time = T.Float(1.0, help="seconds per frame of the source (set by the binding)")
    ik_joint = T.Unicode("", help="IK end effector ('' = none)")
    ik_x = T.Float(0.0, help="IK target x (world units)")
    ik_y = T.Float(0.0, help="IK target y")
    ik_z = T.Float(0.0, help="IK target z")

    @T.validate("percent")
    def _v_percent(self, p):
        v = _finite("percent", p["value"])
        if not 0.0 < v <= 100.0:
            raise T.TraitError(f"percent: expected a percentage in (0, 100], got {v}")
        return v

    @T.validate("count", "seed")
    def _v_nonneg_int(self, p):
        if p["value"] < 0:
            raise T.TraitError(f"{p['trait'].name}: expected an integer >= 0, got {p['value']}")
        return p["value"]

    @T.validate("l")
    def _v_l(self, p):
        v = _finite("l", p["value"])
        if v <= 0:
            raise T.TraitError(f"l: expected a number > 0, got {v}")
        return v

    @T.validate("tau")
    def _v_tau(self, p):
        v = _finite("tau", p["value"])
        if v < 0:
            raise T.TraitError(f"tau: expected a number >= 0 (seconds), got {v}")
        return v

    @T.validate("s", "w_r", "rx", "ry", "rz", "ik_x", "ik_y", "ik_z")
    def _v_finite(self, p):
        return _finite(p["trait"].name, p["value"])

    @T.validate("w_r_reference")
    def _v_ref(self, p):
        v = p["value"]
        if isinstance(v, int) and v < 0:
            raise T.TraitError(f"w_r_reference: expected 'previous', 'next', 'mean' or a pose index >= 0, got {v}")
        if isinstance(v, int):
            self._index_below("w_r_reference", v, len(self.pose_times), "poses")
        return v

    # joint names and pose indices are checked against the skeleton and the current poses (when known), so a
    # bad value is refused here, before any op is written (issue 11: nothing committed). A pose index the
    # model already holds (read from the session, where a later cull may leave fewer poses than the edits
    # saw) is not checked again.
    @T.validate("root", "joint", "ik_joint")
    def _v_joint_name(self, p):
        return p["value"] if p["value"] == "" else self._known_joint(p["trait"].name, p["value"])

    @T.validate("joints", "tau_joints")
    def _v_joint_names(self, p):
        return [self._known_joint(p["trait"].name, j) for j in p["value"]]

    @T.validate("pose_edits")
    def _v_pose_edits(self, p):
        return self._edits_at("pose_edits", p["value"], len(self.pose_times), "poses", self.pose_edits)

    @T.validate("retimes")
    def _v_retimes(self, p):
        out = {(int(k) if int(k) in self.retimes else self._index_below("retimes", k, len(self.pose_times), "poses")):
               _finite(f"retimes[{k}]", v) for k, v in p["value"].items()}
        bad = {k: v for k, v in out.items() if v < 0}
        if bad:
            raise T.TraitError(f"retimes: expected times >= 0 (seconds), got {bad}")
        return out

    @T.validate("pose")
    def _v_pose(self, p):
        return self._index_below("pose", p["value"], len(self.pose_times), "poses")

    @T.validate("ik_targets")
    def _v_ik_targets(self, p):
        for i, e in enumerate(p["value"]):
            if not isinstance(e, dict) or set(e) != {"pose", "joint", "target"} or len(e["target"]) != 3:
                raise T.TraitError(f"ik_targets[{i}]: expected {{pose, joint, target: [x, y, z]}}, got {e!r}")
            if e["pose"] not in [x["pose"] for x in self.ik_targets]:
                self._index_below(f"ik_targets[{i}].pose", e["pose"], len(self.pose_times), "poses")
            self._known_joint(f"ik_targets[{i}].joint", e["joint"])
            [_finite(f"ik_targets[{i}].target", x) for x in e["target"]]
        return p["value"]

    # -- consistency of the view state with the op traits (model-internal; no session involved) --------
    def pose_frame(self, k: int) -> int:
        """Frame of pose ``k`` (nearest to its time)."""
        return int(round(self.pose_times[k] / self.frame_time))

    @T.observe("pose")
    def _pose_moves_playhead(self, change):
        """Choosing a pose moves the playhead to it (not while the playhead itself selects the pose)."""
        if not getattr(self, "_seeking", False) and 0 <= self.pose < len(self.pose_times):
            self._seek(self.pose_frame(self.pose))

    @T.observe("frame")
    def _playhead_selects_pose(self, change):
        """The playhead selects the pose nearest to it (the nudge / retime / IK controls act on that one)."""
        if not self.pose_times:
            return
        t = self.frame * self.frame_time
        k = min(range(len(self.pose_times)), key=lambda i: abs(self.pose_times[i] - t))
        self._seeking = True
        try:
            self.pose = k
        finally:
            self._seeking = False

    @T.observe("pose", "pose_times", "retimes")
    def _show_pose_time(self, change):
        if 0 <= self.pose < len(self.pose_times):
            with self.loading():
                self.pose_time = float(self.retimes.get(self.pose, self.pose_times[self.pose]))

    @T.observe("pose_time")
    def _retime(self, change):
        if self._loading or not 0 <= self.pose < len(self.pose_times):
            return
        if abs(self.pose_time - self.retimes.get(self.pose, self.pose_times[self.pose])) > 1e-12:
            self.retimes = {**self.retimes, self.pose: float(self.pose_time)}

    def _selected_nudge(self):
        return self.pose_edits.get(self.pose, {}).get(self.joint, [0.0, 0.0, 0.0])

    @T.observe("pose", "joint", "pose_edits")
    def _show_nudge(self, change):
        v = self._selected_nudge()
        with self.hold_trait_notifications():
            self.rx, self.ry, self.rz = v
        self._show_ik()

    @T.observe("rx", "ry", "rz")
    def _nudge(self, change):
        v = [self.rx, self.ry, self.rz]
        if v == self._selected_nudge() or not self.joint:
            return
        edits = copy.deepcopy(self.pose_edits)
        d = edits.setdefault(self.pose, {})
        d[self.joint] = v
        if not any(v):
            del d[self.joint]
            if not d:
                del edits[self.pose]
        self.pose_edits = edits

    def _ik_entry(self):
        for e in self.ik_targets:
            if e.get("pose") == self.pose and e.get("joint") == self.ik_joint:
                return e
        return None

    @T.observe("ik_joint", "ik_targets")
    def _on_ik_selection(self, change):
        self._show_ik()

    def _show_ik(self):
        e = self._ik_entry()
        if e is not None:
            with self.hold_trait_notifications():
                self.ik_x, self.ik_y, self.ik_z = (float(x) for x in e["target"])

    @T.observe("ik_x", "ik_y", "ik_z")
    def _move_ik_target(self, change):
        """A user move of the target sliders records (or updates) the IK edit of the selected pose/effector."""
        if self._loading or not self.ik_joint:
            return
        target = [self.ik_x, self.ik_y, self.ik_z]
        e = self._ik_entry()
        if e is not None and list(e["target"]) == target:
            return
        rest = [x for x in self.ik_targets if x is not e]
        self.ik_targets = rest + [{"pose": int(self.pose), "joint": self.ik_joint, "target": target}]

    def show_ik_target(self, position) -> None:
        """Place the target sliders at ``position`` (the effector's current place) without recording an edit."""
        with self.loading(), self.hold_trait_notifications():
            self.ik_x, self.ik_y, self.ik_z = (float(x) for x in position)


def _names_note(names, field, value, known) -> str | None:
    if known and value not in known:
        return f"{field}: the session names joint {value!r}, which this skeleton does not have; the op is kept unchanged"
    return None


def _nudge_quat(v) -> list:
    """Quaternion (x, y, z, w) of the nudge ``v`` (rotation vector, degrees)."""
    r = [math.radians(float(x)) for x in v]
    a = math.sqrt(sum(x * x for x in r))
    s = math.sin(a / 2) / a if a > 1e-12 else 0.5
    return [r[0] * s, r[1] * s, r[2] * s, math.cos(a / 2)]


def _qmul(a, b) -> list:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return [aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz]


def _nudge_of(base, target) -> list:
    """The nudge (rotation vector, degrees) taking ``base`` to ``target`` (``base⁻¹ target``), rounded to
    1e-9 degrees so a nudge written as a target reads back as itself."""
    x, y, z, w = _qmul([-base[0], -base[1], -base[2], base[3]], target)
    if w < 0:
        x, y, z, w = -x, -y, -z, -w
    sv = math.sqrt(x * x + y * y + z * z)
    a = 2.0 * math.atan2(sv, w)
    k = math.degrees(a / sv) if sv > 1e-15 else 2.0 * math.degrees(1.0)
    return [round(c * k, 9) + 0.0 for c in (x, y, z)]


def stagger_params_to_ops(p: dict, bases: dict | None = None) -> list:
    """The StaggerEditor's ops for parameters ``p`` (a :meth:`StaggerModel.params` dict), in canonical order.

    ``bases`` (``StaggerModel.edit_bases``: ``{pose: {joint: [x, y, z, w]}}``) turns the nudges of those joints
    into ``targets`` (``base ⊕ nudge``, the value the user sees plus the nudge), so ``edit_mode`` chooses the
    knot that takes that value: the true pose at ``t_k`` (staggered, Fig. 6a) or the extreme value (Fig. 6b).
    Without a base a nudge is written as ``deltas`` (the same change to both knots: the modes then agree).

    Identity values write no op (percent = 100, s = 0, τ = 0, w_r = 0, an all-zero nudge); ``keep_contacts``
    writes ``{"op": "keep_contacts"}`` when on and any other staggered op is written. Optional fields are
    written only when they differ from the op's default (so the op list stays short and readable).
    """
    ops = []
    if p["cull_by"] == "percent" and p["percent"] < 100.0:
        ops.append({"op": "cull", "percent": float(p["percent"])})
    elif p["cull_by"] == "count" and p["count"] > 0:
        ops.append({"op": "cull", "count": int(p["count"])})
    elif p["cull_by"] == "keep" and p["keep"]:
        ops.append({"op": "cull", "keep": sorted(int(k) for k in p["keep"])})
    for k in sorted(p["pose_edits"]):
        nudges = {j: [float(x) for x in v] for j, v in p["pose_edits"][k].items() if any(v)}
        known = (bases or {}).get(k, {})
        targets = {j: _qmul(known[j], _nudge_quat(v)) for j, v in nudges.items() if j in known}
        deltas = {j: v for j, v in nudges.items() if j not in known}
        for field, value in (("targets", targets), ("deltas", deltas)):  # one op per kind (exactly one each)
            if value:
                op = {"op": "edit_pose", "pose": int(k), field: value}
                if p["edit_mode"] != "staggered":
                    op["mode"] = p["edit_mode"]
                ops.append(op)
    for k in sorted(p["retimes"]):
        ops.append({"op": "retime", "pose": int(k), "time": float(p["retimes"][k])})
    for e in p["ik_targets"]:
        ops.append({"op": "ik_pose", "pose": int(e["pose"]), "joint": e["joint"],
                    "target": [float(x) for x in e["target"]]})
    if p["w_r"] != 0.0:
        op = {"op": "exaggerate", "w_r": float(p["w_r"])}
        if p["w_r_reference"] != "previous":
            op["reference"] = p["w_r_reference"]
        ops.append(op)
    if p["s"] != 0.0:
        op = {"op": "succession", "root": p["root"], "s": float(p["s"]), "l": float(p["l"])}
        if p["joints"]:
            op["joints"] = list(p["joints"])
        ops.append(op)
    if p["tau"] > 0.0:
        op = {"op": "random_timing", "tau": float(p["tau"]), "seed": int(p["seed"])}
        if p["tau_joints"]:
            op["joints"] = list(p["tau_joints"])
        ops.append(op)
    if p["keep_contacts"] and ops:
        ops.append({"op": "keep_contacts"})
    return ops


def stagger_ops_to_params(ops: list, base: dict, joint_names=(), bases: dict | None = None) -> tuple[dict, list]:
    """Parameters shown by a StaggerEditor for the session ``ops``: ``base`` (the model's current parameters)
    updated from the owned ops (the last of each singleton op wins). Returns ``(params, notes)``; ``notes`` are
    plain sentences (an op naming a joint this skeleton does not have: that field keeps its ``base`` value).
    ``edit_pose`` targets read back as nudges from ``bases`` (as in :func:`stagger_params_to_ops`)."""
    p = copy.deepcopy(base)
    notes: list = []
    known = set(joint_names)
    by = {o["op"]: o for o in ops if o["op"] in STAGGER_OPS}
    c = by.get("cull")
    p["percent"] = 100.0
    if c is None:
        p["count"], p["keep"] = 0, []
    elif c.get("percent") is not None:
        p["cull_by"], p["percent"] = "percent", float(c["percent"])
    elif c.get("count") is not None:
        p["cull_by"], p["count"] = "count", int(c["count"])
    elif c.get("keep") is not None:
        p["cull_by"], p["keep"] = "keep", [int(k) for k in c["keep"]]
    sc = by.get("succession")
    p["s"] = 0.0 if sc is None else float(sc["s"])
    if sc is not None:
        p["l"] = float(sc.get("l", 1.0))
        note = _names_note(joint_names, "succession.root", sc["root"], known)
        if note:
            notes.append(note)
        else:
            p["root"] = sc["root"]
        bad = [j for j in (sc.get("joints") or []) if known and j not in known]
        if bad:
            notes.append(f"succession.joints: {', '.join(map(repr, bad))} not in this skeleton; the op is kept unchanged")
        else:
            p["joints"] = list(sc.get("joints") or [])
    rt = by.get("random_timing")
    p["tau"] = 0.0 if rt is None else float(rt["tau"])
    if rt is not None:
        p["seed"] = int(rt.get("seed", 0))
        bad = [j for j in (rt.get("joints") or []) if known and j not in known]
        if bad:
            notes.append(f"random_timing.joints: {', '.join(map(repr, bad))} not in this skeleton; the op is kept "
                         f"unchanged")
        else:
            p["tau_joints"] = list(rt.get("joints") or [])
    ex = by.get("exaggerate")
    p["w_r"] = 0.0 if ex is None else float(ex["w_r"])
    if ex is not None:
        p["w_r_reference"] = ex.get("reference", "previous")
    edits: dict = {}
    mode = None
    for o in ops:
        if o["op"] == "edit_pose":
            k = int(o["pose"])
            mine = edits.setdefault(k, {})
            mine.update({j: [float(x) for x in v] for j, v in (o.get("deltas") or {}).items()})
            kb = (bases or {}).get(k, {})
            for j, q in (o.get("targets") or {}).items():
                if j in kb:
                    mine[j] = _nudge_of(kb[j], q)
                else:
                    notes.append(f"edit_pose.targets: no starting value of joint {j!r} at pose {k} is known; "
                                 "the op is kept unchanged")
            if not mine:
                del edits[k]
            mode = o.get("mode", "staggered")
            for field in ("deltas", "targets"):
                for j in o.get(field) or {}:
                    if known and j not in known:
                        notes.append(f"edit_pose.{field}: joint {j!r} is not in this skeleton; the op is kept "
                                     "unchanged")
    p["pose_edits"] = edits
    if mode is not None:
        p["edit_mode"] = mode
    p["retimes"] = {int(o["pose"]): float(o["time"]) for o in ops if o["op"] == "retime"}
    p["ik_targets"] = [{"pose": int(o["pose"]), "joint": o["joint"], "target": [float(x) for x in o["target"]]}
                       for o in ops if o["op"] == "ik_pose"]
    others = [o for o in ops if o["op"] in STAGGER_OPS and o["op"] != "keep_contacts"]
    if "keep_contacts" in by:
        p["keep_contacts"] = True
    elif others:
        p["keep_contacts"] = False
    return p, notes


# --------------------------------------------------------------------------------------------------
# WandEditor
# --------------------------------------------------------------------------------------------------
class WandModel(_Model):
    """Parameters of the magic-wand editor (Dean et al. 2018): one or more edited frames, each a set of joint
    rotations, propagated with the Green's-function falloff of width σ."""

    sigma = T.Float(1.0, help="falloff width σ of the pose-space kernel (§3.3; > 0)").tag(op=True)
    default_sigma = T.Float(0.0, help="the σ a propagate op without one uses (the clip's default σ, set by the "
                                      "editor; 0 = unknown): undoing back to such an op shows it")
    edits = T.Dict(help="{edited frame: {joint: [rx, ry, rz] degrees}}").tag(op=True)
    propagate = T.Bool(True, help="propagate the edits (off: edit only the edited frames)").tag(op=True)
    frame_range = T.List(T.Int(), help="[start, stop) frames the propagation may change ([] = all)").tag(op=True)
    repetitions = T.Enum(["keep", "discard"], "keep",
                         help="propagate to repetitions of the edited pose (keep) or not (discard), §3.3").tag(op=True)

    input_frames = T.Int(0, help="frames of the motion the edited frames index (the wand ops' input; set by "
                                 "the binding; 0 = unknown)")
    edit_frame = T.Int(0, help="the selected edited frame; changing it moves that frame's edit there (an edit "
                               "already at the new frame is selected instead)")
    joint = T.Unicode("", help="joint the rotation controls act on")
    rx = T.Float(0.0, help="rotation of the joint at the edited frame, x (degrees)")
    ry = T.Float(0.0, help="rotation, y (degrees)")
    rz = T.Float(0.0, help="rotation, z (degrees)")
    compare = T.List(T.Enum(["isomap", "diffusion", "spline"]), help="comparison falloffs drawn beside Green's")

    @property
    def edited_frames(self) -> list:
        """The frames holding an edit, sorted."""
        return sorted(self.edits)

    @T.validate("sigma")
    def _v_sigma(self, p):
        v = _finite("sigma", p["value"])
        if v <= 0:
            raise T.TraitError(f"sigma: expected a number > 0, got {v}")
        return v

    @T.validate("edit_frame")
    def _v_edit_frame(self, p):
        if p["value"] < 0 or 0 < self.input_frames <= p["value"]:
            top = f" and < {self.input_frames}" if self.input_frames else ""
            raise T.TraitError(f"edit_frame: expected a frame index >= 0{top}, got {p['value']}")
        return p["value"]

    @T.validate("edits")
    def _v_edits(self, p):
        return self._edits_at("edits", p["value"], self.input_frames, "frames")

    @T.validate("joint")
    def _v_joint_name(self, p):
        return p["value"] if p["value"] == "" else self._known_joint("joint", p["value"])

    @T.validate("frame_range")
    def _v_range(self, p):
        v = p["value"]
        if v and (len(v) != 2 or not 0 <= v[0] < v[1] or 0 < self.input_frames < v[1]):
            top = f" <= {self.input_frames}" if self.input_frames else ""
            raise T.TraitError(f"frame_range: expected [] or [start, stop) with 0 <= start < stop{top}, got {v}")
        return v

    @T.validate("rx", "ry", "rz")
    def _v_finite(self, p):
        return _finite(p["trait"].name, p["value"])

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
        if v == self._selected() or not self.joint:
            return
        edits = copy.deepcopy(self.edits)
        d = edits.setdefault(self.edit_frame, {})
        d[self.joint] = v
        if not any(v):
            del d[self.joint]
        self.edits = edits

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


# --------------------------------------------------------------------------------------------------
# WarpEditor
# --------------------------------------------------------------------------------------------------
class WarpModel(_Model):
    """Parameters of the guided time-warping editor (Hsu et al. 2007)."""

    mode = T.Enum(["guided", "linear"], "guided", help="guided (DP, §4) or linear time warp").tag(op=True)
    duration = T.Float(1.0, help="output duration (seconds; > 0)").tag(op=True)
    free_length = T.Bool(False, help="let the warp choose its length (unconstrained end)").tag(op=True)
    skip = T.Int(8, help="skip limit: input frames one output frame may advance (§4; >= 0)").tag(op=True)
    reference = T.Unicode("self", help="'self', 'segment' or the name of a reference clip").tag(op=True)
    segment = T.List(T.Float(), [0.0, 1.0], help="[start, stop] seconds of the source used as reference when "
                                                  "reference = 'segment'").tag(op=True)
    keytimes = T.List(T.List(T.Float()), help="[[input_s, output_s], ...] keytime constraints (§4.2)").tag(op=True)
    backward = T.Bool(False, help="allow the warp to run backward in time").tag(op=True)

    source_duration = T.Float(0.0, help="duration of the source (seconds; set by the binding)")
    reference_options = T.List(T.Unicode(), ["self", "segment"], help="names the reference can take")

    @T.validate("duration")
    def _v_duration(self, p):
        v = _finite("duration", p["value"])
        if v <= 0:
            raise T.TraitError(f"duration: expected seconds > 0, got {v}")
        if self.source_duration > 0 and v > MAX_WARP_RATIO * self.source_duration:   # the runner's limit,
            raise T.TraitError(f"duration: expected at most {MAX_WARP_RATIO} times the source's "   # said before
                               f"{self.source_duration:g} s, got {v:g}")                         # an op is written
        return v

    @T.validate("skip")
    def _v_skip(self, p):
        if p["value"] < 0:
            raise T.TraitError(f"skip: expected an integer >= 0, got {p['value']}")
        return p["value"]

    @T.validate("segment")
    def _v_segment(self, p):
        v = [_finite("segment", x) for x in p["value"]]
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
    op = {"op": "guided_warp", "duration": float(p["duration"]), "skip": int(p["skip"]), "reference": ref}
    if kt:
        op["keytimes"] = kt
    if p["free_length"]:   # the warp chooses its length: no duration, no keytimes (they need one)
        op["free_length"] = True
        del op["duration"]
        op.pop("keytimes", None)
    if p["backward"]:
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
    if o.get("duration") is not None:
        p["duration"] = float(o["duration"])
    p["keytimes"] = [[float(a), float(b)] for a, b in (o.get("keytimes") or [])]
    if o["op"] == "guided_warp":
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


# --------------------------------------------------------------------------------------------------
# merging an editor's ops into the session's list, keeping everything else in place
# --------------------------------------------------------------------------------------------------
def _edit_prefix(ops: list) -> str:
    """The ops before the StaggerEditor's first owned op past the cull (what its pose edits apply to), as
    canonical JSON."""
    i = next((n for n, o in enumerate(ops) if o["op"] in STAGGER_OPS and o["op"] != "cull"), len(ops))
    return _canon(list(ops[:i]))


def _key(op: dict):
    """Which instance of an owned op this is: one per name, per pose, per (pose, joint) or per frame."""
    name = op["op"]
    if name == "edit_pose":
        return (name, op["pose"], "targets" if "targets" in op else "deltas")
    if name == "retime":
        return (name, op["pose"])
    if name == "ik_pose":
        return (name, op["pose"], op["joint"])
    if name == "edit_frame":
        return (name, op["frame"])
    if name in WARP_OPS:
        return ("warp",)
    return (name,)


def _rank(op: dict, owned: tuple) -> tuple:
    """Order of an owned op: by name (``owned``), then by instance (pose, frame...)."""
    return (owned.index(op["op"]),) + _key(op)[1:]


def merge_ops(current: list, old_owned: list, new_owned: list, owned: tuple,
              home: Callable[[list], int] | None = None) -> list:
    """The session's op list after an editor changes its ops from ``old_owned`` to ``new_owned``.

    Only instances (see ``_key``) whose op differs between ``old_owned`` and ``new_owned`` are touched; each is
    replaced in place (its last occurrence in ``current``; fields the editor does not control are kept),
    removed, or inserted next to the owned ops of neighbouring rank (``owned`` gives the order), or at
    ``home(ops)`` when the list holds none of them (default: the end). Every other op keeps its place.
    """
    old = {_key(o): o for o in old_owned}
    new = {_key(o): o for o in new_owned}
    out = copy.deepcopy(list(current))
    order = [k for k in list(old) + list(new)]
    seen = set()
    for k in order:
        if k in seen:
            continue
        seen.add(k)
        a, b = old.get(k), new.get(k)
        if a is not None and b is not None and _canon(a) == _canon(b):
            continue
        at = [i for i, o in enumerate(out) if o["op"] in owned and _key(o) == k]
        if b is None:
            if at:
                del out[at[-1]]
            continue
        if at:
            prev = out[at[-1]]
            keep = {f: v for f, v in prev.items() if f not in _CONTROLLED.get(prev["op"], ()) and f != "op"}
            out[at[-1]] = {**keep, **copy.deepcopy(b)}
            continue
        r = _rank(b, owned)
        mine = [(i, _rank(o, owned)) for i, o in enumerate(out) if o["op"] in owned]
        before = [i for i, ro in mine if ro <= r]
        after = [i for i, ro in mine if ro > r]
        if before:
            pos = before[-1] + 1
        elif after:
            pos = after[0]
        else:
            pos = len(out) if home is None else home(out)
        out.insert(pos, copy.deepcopy(b))
    return out


def _stagger_home(ops):
    return 0


def _wand_home(ops):
    for i, o in enumerate(ops):
        if o["op"] in ("guided_warp", "linear_warp", "resample"):
            return i
    return len(ops)


def _wand_input_frames(session) -> int:
    """Frames of the motion the WandEditor's ops see: the source's, unless an op that changes the length
    comes before them (then 0, unknown: the replay checks the frame)."""
    ops = session.ops
    first = next((i for i, o in enumerate(ops) if o["op"] in WAND_OPS), _wand_home(ops))
    return session.source.num_frames if _wand_home(ops[:first]) == first else 0


# --------------------------------------------------------------------------------------------------
# the binding: model <-> session
# --------------------------------------------------------------------------------------------------
class ModelBinding:
    """Keeps ``model`` and ``session`` in step, both ways.

    - A change of an op trait (``op=True``) writes the session's op list (:func:`merge_ops`, one undo step via
      ``session.set_ops``); a refused op list (ValueError) leaves the session as it was and puts the reason in
      ``model.message``.
    - A change of the session's op list (undo/redo, load, code) sets the model's op traits from it; the model
      then equals what the ops say (undo restores every parameter).

    Parameters
    ----------
    model : StaggerModel, WandModel or WarpModel
    session : Session
    references : dict, optional
        WarpModel only: ``{name: op reference JSON}`` of the extra reference clips.
    """

    def __init__(self, model: _Model, session, references: dict | None = None):
        self.model = model
        self.session = session
        self.references = dict(references or {})
        if isinstance(model, StaggerModel):
            self.owned, self._home = STAGGER_OPS, _stagger_home
        elif isinstance(model, WandModel):
            self.owned, self._home = WAND_OPS, _wand_home
        elif isinstance(model, WarpModel):
            self.owned, self._home = WARP_OPS, None
            model.source_duration = float(session.source.duration)
            model.reference_options = ["self", "segment"] + [n for n in self.references if n not in ("self", "segment")]
        else:
            raise ValueError(f"model: expected a StaggerModel, WandModel or WarpModel, got {type(model).__name__}")
        model.joint_names = list(session.source.skeleton.names)
        self._loading = False
        self._bases_prefix = None  # the op prefix model.edit_bases were recorded for
        self._notes: list = []
        self._error = ""
        self._last = model.params()
        self.pull()
        model.observe(self._on_model, names=model.trait_names(op=True))
        session.observe(self._on_session)

    # -- pure parts, per model ------------------------------------------------------------------------
    def to_ops(self, params: dict) -> list:
        if isinstance(self.model, StaggerModel):
            return stagger_params_to_ops(params, self.model.edit_bases)
        if isinstance(self.model, WandModel):
            return wand_params_to_ops(params)
        return warp_params_to_ops(params, self.references, self.model.source_duration)

    def from_ops(self, ops: list, base: dict) -> tuple[dict, list]:
        names = self.model.joint_names
        if isinstance(self.model, StaggerModel):
            return stagger_ops_to_params(ops, base, names, self.model.edit_bases)
        if isinstance(self.model, WandModel):
            return wand_ops_to_params(ops, base, names, self.model.default_sigma or None)
        p, notes, new_refs = warp_ops_to_params(ops, base, self.references, self.model.source_duration)
        if new_refs:
            self.references.update(new_refs)
            self.model.reference_options = list(self.model.reference_options) + [
                n for n in new_refs if n not in self.model.reference_options]
        return p, notes

    def ops_for(self, **changes) -> list:
        """The session's op list as it would be if the model's op traits took ``changes`` (e.g.
        ``percent=40.0``), the ops the editor does not own kept in place; neither the model nor the session
        changes (e.g. to warm a slider's next positions with ``Session.warm(("replay", lists))``)."""
        new = dict(self.model.params(), **changes)
        return merge_ops(self.session.ops, self.to_ops(self._last), self.to_ops(new), self.owned, self._home)

    @contextlib.contextmanager
    def paused(self):
        """Model changes made inside are not written to the session (e.g. a control resetting its value while
        its options are replaced: the caller puts the model's value back before leaving)."""
        old, self._loading = self._loading, True
        try:
            yield self
        finally:
            self._loading = old

    # -- directions -----------------------------------------------------------------------------------
    def _on_model(self, change) -> None:
        if not self._loading:
            self.push()

    def push(self) -> bool:
        """Model -> session. Returns True when the op list changed."""
        new = self.model.params()
        old_ops = self.to_ops(self._last)  # as written (with the bases they were written with)
        if isinstance(self.model, StaggerModel):
            # the bases belong to the state the edits apply to: a new cull (or anything before the edits)
            # drops them, and the nudges are written as deltas until that state is the session's
            cur = self.session.ops
            nxt = merge_ops(cur, old_ops, stagger_params_to_ops(new), self.owned, self._home)
            if _edit_prefix(nxt) != self._bases_prefix:
                self._clear_bases()
            if _edit_prefix(nxt) == _edit_prefix(cur):
                # bases for the nudges this change makes (every nudge when edit_mode changes: the toggle acts
                # on them all), only: an untouched edit keeps its form (deltas stay deltas, in place)
                old_edits, toggle = self._last["pose_edits"], new["edit_mode"] != self._last["edit_mode"]
                self._record_bases((k, j) for k, d in new["pose_edits"].items() for j in d
                                   if toggle or _canon(d[j]) != _canon(old_edits.get(k, {}).get(j)))
        ops = merge_ops(self.session.ops, old_ops, self.to_ops(new), self.owned, self._home)
        try:
            changed = self.session.set_ops(ops)
        except ValueError as e:
            self._error = str(e)
            self._show()
            return False
        self._error = ""
        self._last = new
        if not changed:
            self._show()
        return changed

    def _on_session(self, session) -> None:
        self.pull()

    def pull(self) -> None:
        """Session -> model (op traits set from the session's op list)."""
        if isinstance(self.model, StaggerModel):
            if _edit_prefix(self.session.ops) != self._bases_prefix:
                self._clear_bases()
            self._record_bases((int(o["pose"]), j) for o in self.session.ops if o["op"] == "edit_pose"
                               for j in o.get("targets") or {})
        if isinstance(self.model, WandModel):
            with self.model.loading():
                self.model.input_frames = _wand_input_frames(self.session)
        params, notes = self.from_ops(self.session.ops, self.model.params())
        self._loading = True
        try:
            with self.model.loading(), self.model.hold_trait_notifications():
                for k, v in params.items():
                    if _canon(getattr(self.model, k)) != _canon(v):
                        setattr(self.model, k, v)
            m = self.model
            if isinstance(m, WandModel) and m.edits and m.edit_frame not in m.edits:
                with m.loading():
                    m.edit_frame = m.edited_frames[-1]
        except T.TraitError as e:   # a value the model refuses: say so, keep the op
            notes.append(f"{e}; the op is kept unchanged")
        finally:
            self._loading = False
        self._last = self.model.params()
        self._notes = notes
        self._error = ""
        self._show()

    def _clear_bases(self) -> None:
        if self.model.edit_bases:
            with self.model.loading():
                self.model.edit_bases = {}
        self._bases_prefix = None

    def _record_bases(self, pairs) -> None:
        """StaggerModel: record in ``model.edit_bases`` the value of each new ``(pose, joint)`` in the staggered
        state the pose edits apply to (its editing knot, the true pose at ``t_k``: what the view shows), once;
        nothing when that state is not a staggered representation (the nudge is then written as deltas)."""
        m = self.model
        pairs = {(int(k), j) for k, j in pairs if j not in m.edit_bases.get(int(k), {})}
        if not pairs:
            return
        try:
            sm = self._edit_state()
        except ValueError:  # a replay error: shown by the editor; the nudges stay deltas
            sm = None
        knots = getattr(sm, "editing_knots", None)
        if knots is None:
            return
        names = list(sm.skeleton.names)
        bases = copy.deepcopy(m.edit_bases)
        for k, j in pairs:
            if 0 <= k < len(knots) and j in names:
                bases.setdefault(k, {})[j] = [float(x) for x in knots[k][names.index(j)]]
        with m.loading():
            m.edit_bases = bases
        self._bases_prefix = _edit_prefix(self.session.ops)

    def _edit_state(self):
        """The state the StaggerEditor's pose edits apply to: after :func:`_edit_prefix` of the session's ops
        (the source's extraction when it is empty)."""
        n = len(json.loads(_edit_prefix(self.session.ops)))
        return self.session.extraction() if n == 0 else self.session.states()[n - 1]

    def _show(self) -> None:
        self.model.message = "; ".join([self._error] + self._notes if self._error else self._notes)
