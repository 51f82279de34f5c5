"""The StaggerEditor's model (Coleman et al. 2008: cull §4.3, succession and random timing §5.2, exaggeration
§5.3, pose edits §5.1 Fig. 6, IK posing); its ``params <-> ops`` functions are in :mod:`.stagger_ops`."""
from __future__ import annotations

import math

import numpy as np
import traitlets as T

from ..ops import MAX_DEGREES, MAX_WORLD, Cull, Exaggerate, RandomTiming, Retime, Succession, limits
from ._base import _finite, _g, _int_within, _Model, _with_rotation, _within, snap
from .stagger_ops import STAGGER_OPS, stagger_ops_to_params, stagger_params_to_ops
from .stagger_readouts import _PoseReadouts

__all__ = ["StaggerModel", "STAGGER_OPS", "stagger_params_to_ops", "stagger_ops_to_params"]


class StaggerModel(_PoseReadouts, _Model):
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
    refines = T.List(T.Dict(), help="[{pose, joint, time}] one joint's knot of one pose at the refined time "
                                    "t_k + r[k, j] s (the dope sheet's drags; after the timing edits)").tag(
        op=True, label="the knot time")
    # off by default (issue 20 item 4): the contact layer does not yet meet the figures on every clip
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
    ik_step = T.Float(0.005, help="step of the IK target sliders (world units; a round number near 1/200 of the "
                                  "body's extent, set with the reach by reach_ik)")
    ik_range = T.List(T.List(T.Float()), [[-1.0, 1.0]] * 3,
                      help="[[lo, hi]] * 3: where the IK target sliders reach, x, y, z (world units): the effector's "
                           "place at the selected pose +- the pose's extent, widened to show any target held")
    quality = T.Dict(help="read-only summary of the edit's quality (sn.quality.compare), updated after each replay")
    pose_source_frames = T.List(T.Int(), help="source frame of each current pose, before any retiming (set by "
                                              "the binding)")
    region_weights = T.List(T.Float(), help="the region's falloff at each current pose, in [0, 1] (set by the "
                                            "binding; [] while the region is off): what the timeline shows")

    # the numbers bounded by an op field's limits (declared once, with the op): trait -> (op, field, unit)
    _OP_NUMBERS = {"percent": (Cull, "percent", " %"), "l": (Succession, "l", ""), "s": (Succession, "s", " s"),
                   "tau": (RandomTiming, "tau", " s"), "w_r": (Exaggerate, "w_r", "")}

    @T.validate(*_OP_NUMBERS)
    def _v_op_number(self, p):
        op, field, unit = self._OP_NUMBERS[p["trait"].name]
        lo, hi, open_lo = limits(op, field)
        return self._number(p, lo, hi, open_lo, unit=unit)

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
        return _int_within("seed", p["value"], lo, hi)

    @T.validate("keep")
    def _v_keep(self, p):
        K = len(self.candidate_times)
        bad = [k for k in p["value"] if k < 0 or (K and k >= K)]
        if bad and not self._loading:
            raise T.TraitError(f"keep: pose {bad[0]} is not one of the {K} poses extracted")
        return sorted(set(int(k) for k in p["value"]))

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

    @T.validate("refines")
    def _v_refines(self, p):
        held = {(x["pose"], x["joint"]) for x in self.refines}
        for i, e in enumerate(p["value"]):
            if not isinstance(e, dict) or set(e) != {"pose", "joint", "time"}:
                raise T.TraitError(f"refines[{i}]: expected {{pose, joint, time}}, got {e!r}")
            if (e["pose"], e["joint"]) not in held:
                self._index_below(f"refines[{i}].pose", e["pose"], len(self.pose_times), "poses")
                self._known_joint(f"refines[{i}].joint", e["joint"])
            if _finite(f"refines[{i}].time", e["time"]) < 0:
                raise T.TraitError(f"refines[{i}].time: expected seconds >= 0, got {e['time']}")
        return p["value"]

    def refine(self, pose: int, joint: str, time: float) -> None:
        """Put ``joint``'s knot of pose ``pose`` at ``time`` seconds, rounded as a pose time is
        (:meth:`snap_time`), replacing an earlier refine of that knot. A refine the replay cannot apply is refused
        (TraitError with the plain sentence; nothing recorded)."""
        rest = [e for e in self.refines if (e["pose"], e["joint"]) != (int(pose), joint)]
        self.refines = rest + [{"pose": int(pose), "joint": str(joint), "time": self.snap_time(time)}]

    # -- consistency of the view state with the op traits (model-internal; no session involved) --------
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
        if v != self._selected_nudge() and self.joint:
            self.pose_edits = _with_rotation(self.pose_edits, self.pose, self.joint, v)

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

    def step(self, name: str) -> float | None:
        """As :meth:`_Model.step`; the IK target's step is :attr:`ik_step` (it scales with the clip)."""
        return float(self.ik_step) if name in ("ik_x", "ik_y", "ik_z") else super().step(name)

    @T.observe("ik_x", "ik_y", "ik_z")
    def _move_ik_target(self, change):
        """A user move of the target sliders records (or updates) the IK edit of the selected pose/effector.
        The target already shown (the effector's place, or the edit's target), or it snapped to the sliders'
        grid (multiples of :attr:`ik_step`: what the page sends back for a value it was sent), is not a move:
        nothing is recorded."""
        if self._loading or not self.ik_joint:
            return
        target = [self.ik_x, self.ik_y, self.ik_z]
        e = self.ik_entry()
        shown = list(e["target"]) if e is not None else getattr(self, "_shown_ik", None)
        if shown is not None and all(_echo(a, b, self.ik_step) for a, b in zip(target, shown)):
            return
        rest = [x for x in self.ik_targets if x is not e]
        self.ik_targets = rest + [{"pose": int(self.pose), "joint": self.ik_joint, "target": target}]

    def show_ik_target(self, position, extent: float | None = None) -> None:
        """Place the target sliders at ``position`` (the effector's current place) without recording an edit;
        with ``extent``, let :attr:`ik_range` reach ``position +- extent`` on each axis (it only grows)."""
        p = [float(x) for x in position]
        self._shown_ik = p
        with self.loading(), self.hold_trait_notifications():
            if extent is not None:
                self.ik_range = [[min(lo, v - extent), max(hi, v + extent)] for (lo, hi), v in zip(self.ik_range, p)]
            self.ik_x, self.ik_y, self.ik_z = p

    def reach_ik(self, lo, hi, extent: float) -> None:
        """Let the IK target sliders reach a clip's box ``lo``..``hi`` (3 numbers each, world units) +- ``extent``
        on a grid of :attr:`ik_step` (a round 1, 2 or 5 x 10^k near ``extent / 200``): set once, before the sliders
        are shown. A reach that grows while they are shown makes the page re-snap the old value to the new grid
        and send it back (found in the browser: an IK edit at the world origin from choosing an effector)."""
        e = float(extent)
        if not np.isfinite(e) or e <= 0:
            raise ValueError(f"extent must be a positive number of world units, got {extent!r}")
        step = _round_step(e / 200.0)
        box = [[math.floor((float(a) - e) / step) * step, math.ceil((float(b) + e) / step) * step]
               for a, b in zip(lo, hi)]
        with self.hold_trait_notifications():
            self.ik_step = step
            self.ik_range = [[min(r0, a), max(r1, b)] for (r0, r1), (a, b) in zip(self.ik_range, box)]



def _round_step(x: float) -> float:
    """The round number 1, 2 or 5 x 10^k nearest above ``x`` (> 0)."""
    k = math.floor(math.log10(x))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10.0 ** k >= x * (1 - 1e-9):
            return m * 10.0 ** k
    return 10.0 ** (k + 1)


def _echo(value: float, shown: float, step: float) -> bool:
    """``value`` is ``shown`` as a slider on a grid of ``step`` gives it back: the same number, or the grid point
    nearest to it (then rounded as :func:`snap` rounds a control's value)."""
    on_grid = snap(round(shown / step) * step, step)
    return value == shown or abs(value - on_grid) <= 1e-9 * max(1.0, abs(on_grid))
