"""The staggered-pose editor (Coleman et al. 2008): cull, succession, random timing, exaggeration, pose edits,
retime, insert/delete, foot contacts and IK posing over a :class:`~stagger_nb.session.models.StaggerModel`."""
from __future__ import annotations

import html
import re

import ipywidgets as widgets
import numpy as np
import traitlets

from ..core.kinematics import forward_kinematics
from ..core.motion import Motion
from ..session import Session, joint_rotation_degrees
from ..session.models import STAGGER_OPS, StaggerModel
from ..staggered import end_effectors
from ..plotting import joint_curves_figure, pose_probability_figure
from ._editor import (_STYLE, _Editor, _default_joint, _inert, _link, _session_for, _slider,
                      _x_span)
from .plots import PlotView
from .skeleton_view import SkeletonView

__all__ = ["StaggerEditor"]


_TOE = re.compile(r"toe|heel", re.IGNORECASE)   # end effectors the IK menu leaves out (the foot above is there)


def _controls(m: Motion, names: list, effectors: list) -> dict:
    """The StaggerEditor's controls by model trait name (each is linked to that trait)."""
    wide = {"style": _STYLE}
    c = {}
    c["cull_by"] = widgets.ToggleButtons(options=[("by %", "percent"), ("by count", "count"), ("picked", "keep")],
                                         description="cull poses", style={**_STYLE, "button_width": "90px"},
                                         tooltips=["keep a percentage of the poses, by priority",
                                                   "keep a number of poses, by priority",
                                                   "keep the poses you pick (click the probability plot)"])
    c["percent"] = _slider(widgets.FloatSlider, "keep poses %", min=5.0, max=100.0, step=5.0, readout_format=".0f")
    c["count"] = widgets.BoundedIntText(min=0, max=10**6, description="keep (0 = all)", **wide,
                                        layout=widgets.Layout(width="230px"))
    c["keep"] = widgets.SelectMultiple(options=[], rows=4, description="keep poses", **wide,
                                       layout=widgets.Layout(width="260px"))
    c["root"] = widgets.Dropdown(options=names, description="succession root", **wide)
    c["joints"] = widgets.SelectMultiple(options=names, rows=4, description="delayed joints", **wide,
                                         layout=widgets.Layout(width="280px"))
    c["s"] = _slider(widgets.FloatSlider, "s (s/bone)", min=-0.1, max=0.1, step=0.005, readout_format=".3f")
    c["l"] = _slider(widgets.FloatSlider, "exponent l", min=0.25, max=4.0, step=0.05)
    c["tau"] = _slider(widgets.FloatSlider, "random τ (s)", min=0.0, max=0.15, step=0.005, readout_format=".3f")
    c["seed"] = widgets.BoundedIntText(min=0, max=2**31 - 1, description="seed", **wide,
                                       layout=widgets.Layout(width="200px"))
    c["tau_joints"] = widgets.SelectMultiple(options=names, rows=4, description="τ joints", **wide,
                                             layout=widgets.Layout(width="280px"))
    c["w_r"] = _slider(widgets.FloatSlider, "exaggerate w_r", min=-1.0, max=2.0, step=0.05)
    c["w_r_reference"] = widgets.Dropdown(options=[("previous", "previous"), ("next", "next"), ("mean", "mean")],
                                          description="against", **wide)
    c["pose"] = _slider(widgets.IntSlider, "pose k", min=0, max=1)
    c["joint"] = widgets.Dropdown(options=names, description="joint", **wide)
    c["edit_mode"] = widgets.ToggleButtons(options=["staggered", "unstaggered"], description="edit mode",
                                           style={**_STYLE, "button_width": "100px"},
                                           tooltips=["the edit follows each joint's own timing (Fig. 6a)",
                                                     "the edit lands at the pose time for every joint (Fig. 6b)"])
    for a in "xyz":
        c["r" + a] = _slider(widgets.FloatSlider, f"nudge {a} (°)", min=-90.0, max=90.0, step=1.0)
    c["pose_time"] = widgets.BoundedFloatText(min=0.0, max=m.duration, step=m.frame_time, description="pose time (s)",
                                              **wide, layout=widgets.Layout(width="230px"))
    c["keep_contacts"] = widgets.Checkbox(description="keep foot contacts", indent=False)
    c["ik_joint"] = widgets.Dropdown(options=[("(none)", "")] + [(n, n) for n in effectors],
                                     description="IK effector", **wide)
    for a in "xyz":
        c["ik_" + a] = _slider(widgets.FloatSlider, f"target {a}", min=-1.0, max=1.0, step=0.005,
                               readout_format=".3f")
    for k in ("cull_by", "percent", "count", "s", "l", "tau", "w_r", "keep_contacts"):
        c[k].add_class(f"sn-{k.replace('_', '-')}")
    c["percent"].add_class("sn-cull")   # its former name (browser checks)
    return c


def _rows(c: dict, insert: widgets.Button, delete: widgets.Button) -> list:
    """The control rows, one tool per row."""
    return [widgets.HBox([c["cull_by"], c["keep_contacts"]]),
            widgets.HBox([c["percent"], c["count"], c["keep"]]),
            widgets.HBox([c["root"], c["s"], c["l"], c["joints"]]),
            widgets.HBox([c["tau"], c["seed"], c["tau_joints"]]),
            widgets.HBox([c["w_r"], c["w_r_reference"]]),
            widgets.HBox([c["pose"], c["joint"]]),
            widgets.HBox([c["edit_mode"]]),
            widgets.HBox([c["rx"], c["ry"], c["rz"]]),
            widgets.HBox([c["pose_time"], insert, delete]),
            widgets.HBox([c["ik_joint"], c["ik_x"], c["ik_y"], c["ik_z"]])]


class StaggerEditor(_Editor):
    """Staggered-pose editor (Coleman et al. 2008): cull by %, count or picked poses (§4.3); succession root,
    joint subset, ``s``, ``l`` and random ``τ`` with joints and seed (§5.2); exaggeration ``w_r`` against the
    previous / next / mean / a chosen pose (§5.3); geometric pose edits in staggered or non-staggered mode, retime,
    insert and delete a pose (§5.1, Fig. 6); keep contacts (on by default); IK posing of a hand or foot.

    ``editor.model`` is a :class:`~stagger_nb.session.models.StaggerModel`; ``editor.session`` the Session.
    With ``precompute`` the extraction, every cull position and the replay of the current edit at each position
    are warmed after first paint (``Session.warm``).
    """

    _css = "sn-stagger-editor"
    _ALIASES = {"cull": "percent", "joint_set": "tau_joints", "nudge": ("rx", "ry", "rz")}

    def __init__(self, motion, session: Session | None = None, source_path=None, precompute: bool = True,
                 show_ghost: bool = False, **kwargs):
        super().__init__(**kwargs)
        session = _session_for(motion, session, source_path)
        m = session.source
        names = list(m.skeleton.names)
        model = StaggerModel(root=_default_joint(names, "Hips", "LeftShoulder", "LeftArm", "lShldr"),
                             joint=_default_joint(names, "LeftForeArm", "LeftElbow", "lForeArm"),
                             frame_time=m.frame_time)
        effectors = [names[j] for j in end_effectors(m.skeleton) if not _TOE.search(names[j])]   # Hand_L too
        c = self.controls = _controls(m, names, effectors)
        self.insert_button = widgets.Button(description="insert pose at playhead", layout=widgets.Layout(width="200px"))
        self.delete_button = widgets.Button(description="delete pose k", layout=widgets.Layout(width="140px"))
        self.insert_button.on_click(lambda _: self.insert_pose(self.model.frame * m.frame_time))
        self.delete_button.on_click(lambda _: self.delete_pose(self.model.pose))
        view = SkeletonView(m, ghost=m, show_ghost=show_ghost)
        self.curves = PlotView(frame_time=m.frame_time)
        self.probability = PlotView(frame_time=m.frame_time)
        self.probability.on_click(self._on_probability_click)
        self._defer = precompute   # first paint without the staggered plots; the warm-up's extraction draws them
        self._fk_cache = (None, None)
        self._setup(model, session, view, [self.curves, self.probability], _rows(c, self.insert_button,
                                                                                 self.delete_button))
        # the model first (the binding set it from the session's ops), then the controls attached to it
        for k, w in c.items():
            if k in ("keep", "w_r_reference"):
                continue
            self._links.append(traitlets.link((model, k), (w, "value"), transform=(tuple, list))
                               if isinstance(w, widgets.SelectMultiple) else _link(model, k, w))
        self._links.append(traitlets.link((model, "keep"), (c["keep"], "value"), transform=(tuple, list)))
        self._links.append(traitlets.link((model, "w_r_reference"), (c["w_r_reference"], "value")))
        model.observe(self._on_inert, names=["s", "tau", "w_r", "cull_by", "ik_joint"])
        model.observe(self._on_selection, names=["joint"])
        model.observe(self._on_pose, names=["pose", "ik_joint"])
        self._on_inert()
        self._on_pose()
        if precompute:
            self._warm_positions()

    def _warm_positions(self) -> None:
        """After first paint: the extraction (then the plots that need it), then every cull position's refit and
        the whole replay of the current edit at that position (a first visit of a position is then a hit)."""
        self._first_future = self._warm("extract", then=self._refresh)
        pcs = [float(p) for p in np.arange(95.0, 4.0, -5.0)]
        self._warm(("cull", pcs), ("replay", [self._own_prefix(self.binding.ops_for(cull_by="percent", percent=p))
                                              for p in pcs]))

    def _own_prefix(self, ops: list) -> list:
        """``ops`` up to this editor's last op: what the warm-up replays (ops of other techniques after it, e.g.
        a guided warp of the edited motion with its own kNN tables, are left to the visit)."""
        last = max((i for i, o in enumerate(ops) if o["op"] in self.binding.owned), default=-1)
        return ops[:last + 1]

    # -- actions ---------------------------------------------------------------------------------------
    def _insert_action(self, op: dict) -> None:
        """Add an action op (insert/delete pose) after the staggered edits of the list, before the timing ops."""
        ops = self.session.ops
        pos = 0
        for i, o in enumerate(ops):
            if o["op"] in ("extract", "cull", "edit_pose", "retime", "ik_pose", "insert_pose", "delete_pose"):
                pos = i + 1
        ops.insert(pos, op)
        try:
            self.session.set_ops(ops)
        except ValueError as e:
            self.error = str(e)
            self._show_message()

    def insert_pose(self, time: float) -> None:
        """Insert a staggered pose at ``time`` seconds (op ``insert_pose``)."""
        self._insert_action({"op": "insert_pose", "time": float(time)})

    def delete_pose(self, k: int) -> None:
        """Delete pose ``k`` (op ``delete_pose``)."""
        self._insert_action({"op": "delete_pose", "pose": int(k)})

    def _on_probability_click(self, x, y, frame) -> None:
        """With cull = "picked", a click on the probability plot toggles the nearest candidate pose (§4.3)."""
        if self.model.cull_by != "keep":
            return
        times = np.asarray(self.session.extraction().pose_times)
        k = int(np.argmin(np.abs(times - float(x))))
        keep = set(self.model.keep)
        keep.symmetric_difference_update({k})
        self.model.keep = sorted(keep)

    # -- view state ------------------------------------------------------------------------------------
    def _on_inert(self, change=None) -> None:
        m, c = self.model, self.controls
        _inert(c["l"], m.s == 0, "l shapes the succession delay: inert while s = 0")
        _inert(c["joints"], m.s == 0, "the delayed joints apply to the succession: inert while s = 0")
        _inert(c["root"], m.s == 0, "the root of the succession: inert while s = 0")
        _inert(c["seed"], m.tau == 0, "the seed draws the random timing: inert while τ = 0")
        _inert(c["tau_joints"], m.tau == 0, "joints of the random timing: inert while τ = 0")
        _inert(c["w_r_reference"], m.w_r == 0, "the pose the exaggeration is measured against: inert while w_r = 0")
        _inert(c["percent"], m.cull_by != "percent", "choose 'by %' to cull by percentage")
        _inert(c["count"], m.cull_by != "count", "choose 'by count' to keep a number of poses")
        _inert(c["keep"], m.cull_by != "keep", "choose 'picked' to keep the poses you select")
        for a in "xyz":
            _inert(c["ik_" + a], not m.ik_joint, "choose an IK effector first")

    def _on_selection(self, change=None) -> None:
        self._redraw(self._draw_curves)

    def _effector_positions(self, edited: Motion):
        if self._fk_cache[0] is not edited:
            self._fk_cache = (edited, forward_kinematics(edited)[0])
        return self._fk_cache[1]

    def _on_pose(self, change=None) -> None:
        """The IK target sliders start at the effector's place at the selected pose (no edit recorded)."""
        m = self.model
        if not m.ik_joint or not m.pose_times or m._ik_entry() is not None:
            return
        try:
            edited = self.session.edited()
        except Exception:  # noqa: BLE001 - the message line already shows it
            return
        pos = self._effector_positions(edited)
        f = min(m.pose_frame(min(m.pose, len(m.pose_times) - 1)), len(pos) - 1)
        p = pos[f, edited.skeleton.index(m.ik_joint)]
        ext = float(np.ptp(pos[f], axis=0).max()) or 1.0
        for a, v in zip("xyz", p):
            w = self.controls["ik_" + a]
            w.min, w.max = min(w.min, float(v) - ext), max(w.max, float(v) + ext)
        m.show_ik_target(p)

    def _timing_summary(self):
        """(summary sentence, warnings) of the current staggered state: ``Session.timing_warnings`` (computed
        once per state by the session, not per message redraw)."""
        if getattr(self, "_last_staggered", None) is None:
            return "", ()
        try:
            return self.session.timing_warnings()
        except ValueError:   # a replay error: the message line shows it
            return "", ()

    def _notes(self) -> list:
        summary, _ = self._timing_summary()
        return [n for n in super()._notes() if n != summary]

    def _warnings_html(self) -> str:
        """The timing warnings: one sentence (cause and fix), the details on demand."""
        summary, warnings = self._timing_summary()
        if not summary:
            return ""
        last = getattr(self, "_warnings_shown", None)   # the session returns the same tuple for the same state
        if last is not None and last[0] == summary and last[1] is warnings:
            return last[2]
        details = "".join(f"<li>{html.escape(getattr(w, 'message', str(w)))}</li>" for w in warnings[:200])
        text = (f'<details style="color:#b7791f"><summary>&#9888; {html.escape(summary)}</summary>'
                f'<ul style="max-height:12em;overflow:auto">{details}</ul></details>')
        self._warnings_shown = (summary, warnings, text)
        return text

    # -- views -----------------------------------------------------------------------------------------
    def _needs_staggered(self) -> bool:
        return any(o.name in STAGGER_OPS + ("insert_pose", "delete_pose", "extract") for o in self.session.typed_ops)

    def _update_views(self, edited: Motion) -> None:
        m = self.session.source
        if not self._needs_staggered() and not self._extraction_ready():
            self._last_staggered = None
            self._draw_curves(edited)
            if not self.probability.figure:
                self.probability.figure = pose_probability_figure(None, None, [], [], [], [],
                                                                  title="pose probability: extracting poses…",
                                                                  x_range=_x_span(edited))
            self._show_motion(edited)
            return   # first paint: the extraction is computed after it (warm), then this draws the rest
        sm = self.session.staggered()
        self._last_staggered = sm
        full = self.session.extraction()
        K = sm.num_poses
        with self.model.loading():
            self.model.pose_times = [float(t) for t in sm.pose_times]
        c = self.controls
        c["pose"].max = max(K - 1, c["pose"].max if self.model.pose >= K else 0)
        opts = [(f"{k}: {t:.2f} s", k) for k, t in enumerate(full.pose_times)]
        # new options reset a selection control's value (ipywidgets selects the first option), which the link
        # would write to the model and the session as a user's choice: put the model's value back, unrecorded
        if [o[1] for o in c["keep"].options] != [o[1] for o in opts]:
            keep = list(self.model.keep)
            with self.binding.paused():
                c["keep"].options = opts
                c["keep"].value = tuple(k for k in keep if k < len(opts))
                self.model.keep = keep
        ref = self.model.w_r_reference
        refs = [("previous", "previous"), ("next", "next"), ("mean", "mean")] + [(f"pose {k}", k) for k in range(K)]
        if isinstance(ref, int) and ref >= K:
            refs.append((f"pose {ref}", ref))
        if c["w_r_reference"].options != tuple(refs):
            with self.binding.paused():
                c["w_r_reference"].options = refs
                c["w_r_reference"].value = ref
        ft = m.frame_time
        kept = np.asarray(sm.pose_times)
        self._draw_probability(full, sm, kept, _x_span(edited))
        self._draw_curves(edited, sm)
        self._show_motion(edited, pose_frames=np.round(kept / ft).astype(int),
                          contacts=list(getattr(sm, "contacts", ()) or ()))

    def _extraction_ready(self) -> bool:
        """Whether the staggered plots can be drawn now without waiting for the extraction: always without a
        warm-up; with one, once its extraction is done (first paint shows the motion and curves before)."""
        if not self._defer:
            return True
        fut = getattr(self, "_first_future", None)
        return fut is not None and fut.done()

    def _draw_probability(self, full, sm, kept: np.ndarray, x_range) -> None:
        """The pose-probability plot: rebuilt only when the extraction or the kept poses changed (a timing or
        exaggeration slider leaves it as it is: no figure rebuilt, nothing sent)."""
        key = (full, kept.tobytes(), None if sm.pose_probability is None else np.asarray(sm.pose_probability).tobytes(),
               tuple(x_range))
        last = getattr(self, "_probability_key", None)
        if last is not None and last[0] is full and last[1:] == key[1:] and self.probability.figure:
            return
        m = self.session.source
        prob = full.metadata.get("probability")
        times = np.arange(m.num_frames) * m.frame_time
        self.probability.figure = pose_probability_figure(
            times if prob is not None else None, prob, np.asarray(full.pose_times), full.pose_probability, kept,
            np.interp(kept, times, prob) if prob is not None else sm.pose_probability, x_range=x_range)
        self._probability_key = key

    def _draw_curves(self, edited: Motion, sm=None) -> None:
        m = self.session.source
        name = self.model.joint
        j = m.skeleton.index(name)
        sm = sm if sm is not None else getattr(self, "_last_staggered", None)
        kept = None if sm is None else np.asarray(sm.pose_times)
        knots = None if sm is None else kept + np.asarray(sm.refinements)[:, j]
        self.curves.figure = joint_curves_figure(
            edited.times, joint_rotation_degrees(edited, j), self._source_degrees(j), m.times,
            pose_times=() if kept is None else kept, knot_times=() if knots is None else knots,
            title=f"{name}: rotation vector (°), edited vs original", x_range=_x_span(edited))
        self.view.highlight_joints([name])
