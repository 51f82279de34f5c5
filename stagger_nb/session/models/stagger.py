"""The StaggerEditor's model and its pure ``params <-> ops`` functions (Coleman et al. 2008: cull §4.3, succession
and random timing §5.2, exaggeration §5.3, pose edits §5.1 Fig. 6, IK posing)."""
from __future__ import annotations

import copy

import numpy as np
import traitlets as T

from ...core.rotations import quat_conj, quat_mul, quat_to_rotvec, rotvec_to_quat
from ..ops import MAX_DEGREES, MAX_WORLD, Cull, Exaggerate, RandomTiming, Retime, Succession, limits
from ._base import _finite, _g, _Model, _within, snap

__all__ = ["StaggerModel", "STAGGER_OPS", "stagger_params_to_ops", "stagger_ops_to_params"]

STAGGER_OPS = ("cull", "edit_pose", "retime", "ik_pose", "exaggerate", "succession", "random_timing",
               "keep_contacts")
"""Ops the StaggerEditor writes, in the order it inserts them (staggered ops first, the constraint last)."""


class StaggerModel(_Model):
    """Parameters of the staggered-pose editor (Coleman et al. 2008).

    Op traits (tagged ``op=True``) map to ops with :func:`stagger_params_to_ops`; the others are view state
    (selected pose and joint, the nudge of that joint, the IK effector and target) kept consistent with them.
    """

    cull_by = T.Enum(["percent", "count", "keep"], "percent", help="how poses are culled (§4.3)").tag(op=True)
    percent = T.Float(100.0, help="keep this % of the candidate poses (cull by percent; 100 = all)").tag(
        op=True, step=5.0)
    count = T.Int(0, help="keep this many poses (cull by count; 0 = all)").tag(op=True)
    keep = T.List(T.Int(), help="indices of the candidate poses to keep (cull by picking; [] = all)").tag(op=True)
    root = T.Unicode("", help="succession root joint (§5.2)").tag(op=True)
    joints = T.List(T.Unicode(), help="joints the succession delays ([] = all)").tag(op=True)
    s = T.Float(0.0, help="succession delay per bone (seconds; 0 = off)").tag(op=True, step=0.005)
    l = T.Float(1.0, help="succession exponent l (> 0; inert when s = 0)").tag(op=True, step=0.05)
    tau = T.Float(0.0, help="random timing spread τ (seconds; 0 = off)").tag(op=True, step=0.005)
    tau_joints = T.List(T.Unicode(), help="joints τ applies to ([] = all)").tag(op=True)
    seed = T.Int(0, help="random seed of τ").tag(op=True)
    w_r = T.Float(0.0, help="exaggeration weight w_r (§5.3; 0 = off)").tag(op=True, step=0.05)
    w_r_reference = T.Union([T.Enum(["previous", "next", "mean"]), T.Int()], default_value="previous",
                            help="exaggerate against the previous / next / mean pose or a pose index").tag(op=True)
    pose_edits = T.Dict(help="{pose index: {joint: [rx, ry, rz] degrees}} geometric pose edits (§5.1)").tag(
        op=True, label="the nudge")
    edit_mode = T.Enum(["staggered", "unstaggered"], "staggered",
                       help="pose edits in staggered (Fig. 6a) or non-staggered (Fig. 6b) mode").tag(op=True)
    retimes = T.Dict(help="{pose index: new time (s)} (Fig. 6c)").tag(op=True, label="the pose time")
    ik_targets = T.List(T.Dict(), help="[{pose, joint, target: [x, y, z]}] IK pose edits").tag(
        op=True, label="the IK target")
    # off by default (issue 20 item 4): the contact layer does not yet meet the issue's figures on every clip
    keep_contacts = T.Bool(False, help="hold the source's foot contacts through the timing edits").tag(op=True)
    propagate = T.Bool(False, help="spread each pose edit (nudge, IK target) to every similar pose, weighted by the "
                                   "magic wand's falloff of the edited pose (Dean et al. 2018, §3.3)").tag(op=True)
    sigma = T.Float(0.0, help="falloff width σ of the propagation and of the region (pose-space units; 0 = the "
                              "clip's default)").tag(op=True)
    region = T.Bool(False, help="limit the timing edits (s, τ) to the magic-wand region around region_frame: each "
                                "pose's offsets scaled by the falloff at its time").tag(op=True)
    region_frame = T.Int(0, help="source frame the region is centred on (turning the region on puts it at the "
                                 "selected pose)").tag(op=True)

    # view state
    edit_bases = T.Dict(help="{pose index: {joint: [x, y, z, w]}} the true pose value (editing knot at t_k) each "
                             "nudge starts from, set by the binding: pose edits are then written as targets "
                             "base ⊕ nudge, so edit_mode chooses the knot that reaches them (§5.1, Fig. 6a/6b)")
    pose = T.Int(0, help="selected pose index (the nudge, retime and IK controls act on it)")
    joint = T.Unicode("", help="selected joint (curves, nudge)")
    rx = T.Float(0.0, help="nudge of the selected joint at the selected pose, x (degrees)").tag(
        step=1.0, label="nudge x")
    ry = T.Float(0.0, help="nudge, y (degrees)").tag(step=1.0, label="nudge y")
    rz = T.Float(0.0, help="nudge, z (degrees)").tag(step=1.0, label="nudge z")
    pose_times = T.List(T.Float(), help="times (s) of the current poses (set from the replay)")
    candidate_times = T.List(T.Float(), help="times (s) of the poses extracted before any cull, which "
                                             "cull.keep and cull.count choose from (set from the replay)")
    pose_time = T.Float(0.0, help="time (s) of the selected pose; a user change retimes it (Fig. 6c)").tag(
        step="frame_time", label="pose time")
    frame_time = T.Float(1.0, help="seconds per frame of the source (set by the binding)")
    source_duration = T.Float(0.0, help="duration of the source (seconds; set by the binding; 0 = unknown)")
    ik_joint = T.Unicode("", help="IK end effector ('' = none)")
    ik_effectors = T.List(T.Unicode(), help="end effectors IK can move (hands and feet; set by the binding)")
    ik_x = T.Float(0.0, help="IK target x (world units)").tag(step=0.005, label="IK target x")
    ik_y = T.Float(0.0, help="IK target y").tag(step=0.005, label="IK target y")
    ik_z = T.Float(0.0, help="IK target z").tag(step=0.005, label="IK target z")
    ik_range = T.List(T.List(T.Float()), [[-1.0, 1.0]] * 3,
                      help="[[lo, hi]] * 3: where the IK target sliders reach, x, y, z (world units): the effector's "
                           "place at the selected pose +- the pose's extent, widened to show any target held")
    quality = T.Dict(help="read-only summary of the edit's quality (sn.quality.compare), updated after each replay")
    pose_source_frames = T.List(T.Int(), help="source frame of each current pose, before any retiming (set by "
                                              "the binding)")
    region_weights = T.List(T.Float(), help="the region's falloff at each current pose, in [0, 1] (set by the "
                                            "binding; [] while the region is off): what the timeline shows")

    @T.validate("percent")
    def _v_percent(self, p):
        lo, hi, open_lo = limits(Cull, "percent")
        return self._number(p, lo, hi, open_lo, unit=" %")

    @T.validate("count")
    def _v_count(self, p):
        n, lo = p["value"], limits(Cull, "count")[0]
        K = len(self.candidate_times)
        if n != 0 and (n < lo or (not self._loading and K and n > K)):
            top = f" and {K} (the poses extracted)" if K else ""
            raise T.TraitError(f"count must be 0 (all poses) or between {lo}{top}, got {n}" if K else
                               f"count must be 0 (all poses) or at least {lo}, got {n}")
        return n

    @T.validate("seed")
    def _v_seed(self, p):
        lo, hi, _ = limits(RandomTiming, "seed")
        if not lo <= p["value"] <= hi:
            raise T.TraitError(f"seed must lie between {lo} and {hi}, got {p['value']}")
        return p["value"]

    @T.validate("keep")
    def _v_keep(self, p):
        K = len(self.candidate_times)
        bad = [k for k in p["value"] if k < 0 or (K and k >= K)]
        if bad and not self._loading:
            raise T.TraitError(f"keep: pose {bad[0]} is not one of the {K} poses extracted")
        return sorted(set(int(k) for k in p["value"]))

    @T.validate("l")
    def _v_l(self, p):
        lo, hi, open_lo = limits(Succession, "l")
        return self._number(p, lo, hi, open_lo)

    @T.validate("s")
    def _v_s(self, p):
        lo, hi, open_lo = limits(Succession, "s")
        return self._number(p, lo, hi, open_lo, unit=" s")

    @T.validate("tau")
    def _v_tau(self, p):
        lo, hi, open_lo = limits(RandomTiming, "tau")
        return self._number(p, lo, hi, open_lo, unit=" s")

    @T.validate("w_r")
    def _v_w_r(self, p):
        lo, hi, open_lo = limits(Exaggerate, "w_r")
        return self._number(p, lo, hi, open_lo)

    @T.validate("rx", "ry", "rz")
    def _v_nudge(self, p):
        return self._number(p, -MAX_DEGREES, MAX_DEGREES, unit="°")

    @T.validate("ik_x", "ik_y", "ik_z")
    def _v_ik(self, p):
        return self._number(p, -MAX_WORLD, MAX_WORLD)

    @T.validate("pose_time")
    def _v_pose_time(self, p):
        if self._loading or not 0 <= self.pose < len(self.pose_times):
            return _finite("pose time", p["value"])
        lo, hi = self.pose_time_range()
        v = _finite("pose time", p["value"])
        if not lo < v < hi and not (self.pose == 0 and v == lo) and not (
                self.pose == len(self.pose_times) - 1 and v == hi):
            raise T.TraitError(f"pose time must lie between {lo:.3f} s and {hi:.3f} s (the poses beside pose "
                               f"{self.pose}), got {_g(v)} s")
        return snap(v, self.step("pose_time"))

    def pose_time_range(self, k: int | None = None) -> tuple:
        """``(lo, hi)`` seconds pose ``k`` (default: the selected pose) may be retimed to: strictly between the
        poses beside it as they are now; the first pose from 0 s, the last up to the source's end."""
        k = self.pose if k is None else int(k)
        t = self.pose_times
        lo = t[k - 1] if k > 0 else limits(Retime, "time")[0]
        hi = t[k + 1] if k + 1 < len(t) else max(self.source_duration, t[k]) if self.source_duration else t[k]
        return float(lo), float(hi)

    @T.validate("sigma")
    def _v_sigma(self, p):
        v = _finite("sigma", p["value"])
        if v < 0:
            raise T.TraitError(f"sigma: expected a number >= 0 (0 = the clip's default), got {v}")
        return v

    @T.validate("region_frame")
    def _v_region_frame(self, p):
        if p["value"] < 0:
            raise T.TraitError(f"region_frame: expected a source frame index >= 0, got {p['value']}")
        return p["value"]

    @T.observe("region")
    def _region_at_pose(self, change):
        """Turning the region on (a user's move) centres it on the selected pose's source frame."""
        if change["new"] and not self._loading and 0 <= self.pose < len(self.pose_source_frames):
            self.region_frame = int(self.pose_source_frames[self.pose])

    @T.validate("w_r_reference")
    def _v_ref(self, p):
        v = p["value"]
        if isinstance(v, int) and v < 0:
            raise T.TraitError(f"w_r_reference: expected 'previous', 'next', 'mean' or a pose index >= 0, got {v}")
        if isinstance(v, int):
            self._index_below("w_r_reference", v, len(self.pose_times), "poses")
        return v

    # joint names and pose indices are checked against the skeleton and the current poses (when known), so a
    # bad value is refused here, before any op is written (nothing committed). A pose index the
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
        lo = limits(Retime, "time")[0]
        out = {(int(k) if int(k) in self.retimes else self._index_below("retimes", k, len(self.pose_times), "poses")):
               _within(f"retimes[{k}]", v, lo, unit=" s") for k, v in p["value"].items()}
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
            [_within(f"ik_targets[{i}].target", x, -MAX_WORLD, MAX_WORLD) for x in e["target"]]
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
        """The selected pose's time, shown rounded to the control's step."""
        if 0 <= self.pose < len(self.pose_times):
            with self.loading():
                self.pose_time = snap(float(self.retimes.get(self.pose, self.pose_times[self.pose])),
                                      self.step("pose_time"))

    @T.observe("pose_time")
    def _retime(self, change):
        if self._loading or not 0 <= self.pose < len(self.pose_times):
            return
        now = float(self.retimes.get(self.pose, self.pose_times[self.pose]))
        if abs(self.pose_time - snap(now, self.step("pose_time"))) > 1e-12:   # not the time as shown
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

    def ik_entry(self) -> dict | None:
        """The IK edit of the selected pose and effector (``{pose, joint, target}``), None when there is none."""
        for e in self.ik_targets:
            if e.get("pose") == self.pose and e.get("joint") == self.ik_joint:
                return e
        return None

    @T.observe("ik_joint", "ik_targets")
    def _on_ik_selection(self, change):
        self._show_ik()

    def _show_ik(self):
        e = self.ik_entry()
        if e is not None:
            with self.hold_trait_notifications():
                self.ik_x, self.ik_y, self.ik_z = (float(x) for x in e["target"])

    @T.observe("ik_x", "ik_y", "ik_z")
    def _move_ik_target(self, change):
        """A user move of the target sliders records (or updates) the IK edit of the selected pose/effector."""
        if self._loading or not self.ik_joint:
            return
        target = [self.ik_x, self.ik_y, self.ik_z]
        e = self.ik_entry()
        if e is not None and list(e["target"]) == target:
            return
        rest = [x for x in self.ik_targets if x is not e]
        self.ik_targets = rest + [{"pose": int(self.pose), "joint": self.ik_joint, "target": target}]

    def show_ik_target(self, position, extent: float | None = None) -> None:
        """Place the target sliders at ``position`` (the effector's current place) without recording an edit;
        with ``extent``, let :attr:`ik_range` reach ``position +- extent`` on each axis (it only grows)."""
        p = [float(x) for x in position]
        with self.loading(), self.hold_trait_notifications():
            if extent is not None:
                self.ik_range = [[min(lo, v - extent), max(hi, v + extent)] for (lo, hi), v in zip(self.ik_range, p)]
            self.ik_x, self.ik_y, self.ik_z = p

    def pose_frames(self) -> list:
        """The frame of each current pose (nearest to its time): where the 3D view marks the poses."""
        return [self.pose_frame(k) for k in range(len(self.pose_times))]

    def candidate_near(self, time: float) -> int | None:
        """Index of the extracted pose nearest to ``time`` seconds (None before the extraction is known)."""
        t = self.candidate_times
        return min(range(len(t)), key=lambda k: abs(t[k] - float(time))) if t else None


def _names_note(names, field, value, known) -> str | None:
    if known and value not in known:
        return (f"{field}: the session names joint {value!r}, which this skeleton does not have; the op is kept "
                "unchanged")
    return None


def _target_of(base, nudge) -> list:
    """``base ⊕ nudge``: the quaternion (x, y, z, w) reached from ``base`` by the rotation vector ``nudge``
    (degrees), applied in the joint's local frame (``base * exp(nudge / 2)``)."""
    return [float(x) for x in quat_mul(base, rotvec_to_quat(np.radians(np.asarray(nudge, dtype=float))))]


def _nudge_of(base, target) -> list:
    """The nudge (rotation vector, degrees) taking ``base`` to ``target`` (``base⁻¹ target``), rounded to
    1e-9 degrees so a nudge written as a target reads back as itself."""
    r = np.degrees(quat_to_rotvec(quat_mul(quat_conj(np.asarray(base, dtype=float)), target)))
    return [round(float(c), 9) + 0.0 for c in r]


def stagger_params_to_ops(p: dict, bases: dict | None = None) -> list:
    """The StaggerEditor's ops for parameters ``p`` (a :meth:`StaggerModel.params` dict), in canonical order.

    ``bases`` (``StaggerModel.edit_bases``: ``{pose: {joint: [x, y, z, w]}}``) turns the nudges of those joints
    into ``targets`` (``base ⊕ nudge``, the value the user sees plus the nudge), so ``edit_mode`` chooses the
    knot that takes that value: the true pose at ``t_k`` (staggered, Fig. 6a) or the extreme value (Fig. 6b).
    Without a base a nudge is written as ``deltas`` (the same change to both knots: the modes then agree).

    ``propagate`` adds ``"propagate": true`` (and ``sigma`` when not 0) to the pose edits and IK targets, ``region``
    a ``"falloff": {"frame": region_frame, "sigma": ...}`` to the succession and the random timing (issue 24).

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
    spread = {}
    if p.get("propagate"):      # the pose edits spread to every similar pose (Dean et al. 2018, §3.3)
        spread = {"propagate": True, **({"sigma": float(p["sigma"])} if p.get("sigma") else {})}
    region = {}
    if p.get("region"):         # the timing edits inside the region only
        region = {"falloff": {"frame": int(p["region_frame"]), "sigma": float(p["sigma"]) if p.get("sigma") else None}}
    for k in sorted(p["pose_edits"]):
        nudges = {j: [float(x) for x in v] for j, v in p["pose_edits"][k].items() if any(v)}
        known = (bases or {}).get(k, {})
        targets = {j: _target_of(known[j], v) for j, v in nudges.items() if j in known}
        deltas = {j: v for j, v in nudges.items() if j not in known}
        for field, value in (("targets", targets), ("deltas", deltas)):  # one op per kind (exactly one each)
            if value:
                op = {"op": "edit_pose", "pose": int(k), field: value}
                if p["edit_mode"] != "staggered":
                    op["mode"] = p["edit_mode"]
                ops.append({**op, **spread})
    for k in sorted(p["retimes"]):
        ops.append({"op": "retime", "pose": int(k), "time": float(p["retimes"][k])})
    for e in p["ik_targets"]:
        ops.append({"op": "ik_pose", "pose": int(e["pose"]), "joint": e["joint"],
                    "target": [float(x) for x in e["target"]], **spread})
    if p["w_r"] != 0.0:
        op = {"op": "exaggerate", "w_r": float(p["w_r"])}
        if p["w_r_reference"] != "previous":
            op["reference"] = p["w_r_reference"]
        ops.append(op)
    if p["s"] != 0.0:
        op = {"op": "succession", "root": p["root"], "s": float(p["s"]), "l": float(p["l"])}
        if p["joints"]:
            op["joints"] = list(p["joints"])
        ops.append({**op, **region})
    if p["tau"] > 0.0:
        op = {"op": "random_timing", "tau": float(p["tau"]), "seed": int(p["seed"])}
        if p["tau_joints"]:
            op["joints"] = list(p["tau_joints"])
        ops.append({**op, **region})
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
    p["percent"], p["count"], p["keep"] = 100.0, 0, []   # the fields of the other cull modes: their identity
    if c is None:
        pass
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
            notes.append(f"succession.joints: {', '.join(map(repr, bad))} not in this skeleton; the op is kept "
                         "unchanged")
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
    edits = [o for o in ops if o["op"] in ("edit_pose", "ik_pose")]
    if edits:
        p["propagate"] = bool(edits[-1].get("propagate", False))
        if p["propagate"]:
            p["sigma"] = float(edits[-1].get("sigma") or 0.0)
    timed = [o for o in ops if o["op"] in ("succession", "random_timing")]
    if timed:
        r = timed[-1].get("falloff")
        p["region"] = r is not None
        if r is not None:
            p["region_frame"] = int(r["frame"])
            p["sigma"] = float(r.get("sigma") or 0.0)
    others = [o for o in ops if o["op"] in STAGGER_OPS and o["op"] != "keep_contacts"]
    if "keep_contacts" in by:
        p["keep_contacts"] = True
    elif others:
        p["keep_contacts"] = False
    return p, notes
