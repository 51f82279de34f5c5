"""The staggered-pose editor (Coleman et al. 2008): cull, succession, random timing, exaggeration, pose edits,
retime, insert/delete, foot contacts and IK posing over a :class:`~stagger_nb.session.models.StaggerModel`."""
from __future__ import annotations

import html
import math

import ipywidgets as widgets
import traitlets

from ..core.motion import Motion
from ..plotting import joint_curves_figure, pose_probability_figure
from ..session import Session
from ..session.models import STAGGER_OPS, StaggerModel, plain_message
from ..session.models.views import joint_curves_view, place_ik_target, probability_view, reach_ik_targets, stagger_state
from ..session.timeline import knot_table_of
from ._controls import _STYLE, _inert, _link, _slider
from ._editor import _Editor, _session_for
from ._layout import _LINES, _PLOT_HEIGHT, _VIEW_SIZE, _default_joint, _x_span
from .plots import PlotView
from .skeleton_view import SkeletonView
from .timeline import Timeline

__all__ = ["StaggerEditor"]


def _controls(m: Motion, names: list, model: StaggerModel) -> dict:
    """The StaggerEditor's controls by model trait name (each is linked to that trait; steps from the model)."""
    wide = {"style": _STYLE}
    st = model.step
    c = {}
    c["cull_by"] = widgets.ToggleButtons(options=[("by %", "percent"), ("by count", "count"), ("picked", "keep")],
                                         description="cull poses", style={**_STYLE, "button_width": "84px"},
                                         tooltips=["keep a percentage of the poses, by priority",
                                                   "keep a number of poses, by priority",
                                                   "keep the poses you pick (click the probability plot)"])
    c["percent"] = _slider(widgets.FloatSlider, "keep poses %", min=5.0, max=100.0, step=st("percent"),
                           readout_format=".0f")
    c["count"] = widgets.BoundedIntText(min=0, max=10**6, description="keep (0 = all)", **wide,
                                        layout=widgets.Layout(width="230px"))
    c["keep"] = widgets.SelectMultiple(options=[], rows=3, description="keep poses", **wide,
                                       layout=widgets.Layout(width="260px"))
    c["root"] = widgets.Dropdown(options=names, description="succession root", **wide)
    c["joints"] = widgets.SelectMultiple(options=names, rows=4, description="delayed joints", **wide,
                                         layout=widgets.Layout(width="280px"))
    c["s"] = _slider(widgets.FloatSlider, "s (s/bone)", min=-0.1, max=0.1, step=st("s"), readout_format=".3f")
    c["l"] = _slider(widgets.FloatSlider, "exponent l", min=0.25, max=4.0, step=st("l"))
    c["tau"] = _slider(widgets.FloatSlider, "random τ (s)", min=0.0, max=0.15, step=st("tau"), readout_format=".3f")
    c["seed"] = widgets.BoundedIntText(min=0, max=2**31 - 1, description="seed", **wide,
                                       layout=widgets.Layout(width="200px"))
    c["tau_joints"] = widgets.SelectMultiple(options=names, rows=4, description="τ joints", **wide,
                                             layout=widgets.Layout(width="280px"))
    c["w_r"] = _slider(widgets.FloatSlider, "exaggerate w_r", min=-1.0, max=2.0, step=st("w_r"))
    c["w_r_reference"] = widgets.Dropdown(options=[("previous", "previous"), ("next", "next"), ("mean", "mean")],
                                          description="against", **wide)
    c["pose"] = _slider(widgets.IntSlider, "pose k", min=0, max=1)
    c["joint"] = widgets.Dropdown(options=names, description="joint", **wide)
    # each button as wide as its label ("unstaggered" was cut to "unstagger…" at 100 px)
    c["edit_mode"] = widgets.ToggleButtons(options=["staggered", "unstaggered"], description="edit mode",
                                           style={**_STYLE, "button_width": "auto"},
                                           tooltips=["the edit follows each joint's own timing (Fig. 6a)",
                                                     "the edit lands at the pose time for every joint (Fig. 6b)"])
    for a in "xyz":
        c["r" + a] = _slider(widgets.FloatSlider, f"nudge {a} (°)", min=-90.0, max=90.0, step=st("r" + a))
    # a plain FloatText: a typed value outside the neighbours' times is refused by the model with a sentence
    # saying where it may lie (a bounded text box would clamp it silently)
    c["pose_time"] = widgets.FloatText(step=st("pose_time"), description="pose time (s)", **wide,
                                       layout=widgets.Layout(width="230px"))
    c["keep_contacts"] = widgets.Checkbox(description="keep foot contacts", indent=False)
    c["ik_joint"] = widgets.Dropdown(options=[("(none)", "")] + [(n, n) for n in model.ik_effectors],
                                     description="IK effector", **wide)
    for a in "xyz":
        c["ik_" + a] = _slider(widgets.FloatSlider, f"target {a}", min=-1.0, max=1.0, step=st("ik_" + a),
                               readout_format=".3f")
    c["propagate"] = widgets.Checkbox(description="propagate pose edits to similar poses", indent=False,
                                      tooltip="the magic wand (Dean et al. 2018 §3.3): each nudge and IK target "
                                              "changes every similar pose, weighted by the Green's falloff")
    c["region"] = widgets.Checkbox(description="timing edits in a region", indent=False,
                                   tooltip="s and τ scaled by the magic-wand falloff around the region frame "
                                           "(turning it on centres it on the selected pose)")
    c["region_frame"] = widgets.BoundedIntText(min=0, max=max(m.num_frames - 1, 0), description="region frame",
                                               **wide, layout=widgets.Layout(width="230px"))
    c["sigma"] = widgets.BoundedFloatText(min=0.0, max=1e6, step=0.05, description="wand σ (0 = auto)", **wide,
                                          layout=widgets.Layout(width="230px"))
    for k in ("cull_by", "percent", "count", "s", "l", "tau", "w_r", "keep_contacts", "propagate", "region",
              "region_frame", "sigma"):
        c[k].add_class(f"sn-{k.replace('_', '-')}")
    c["percent"].add_class("sn-cull")   # its former name (browser checks)
    for k in ("pose", "ik_joint", "ik_x", "ik_y", "ik_z"):
        c[k].add_class(f"sn-{k.replace('_', '-')}")
    return c


#: what the picked-poses list does (its tooltip, and the hint beside it)
KEEP_TIP = ("with 'picked', the poses kept: select them here (ctrl- or shift-click for several) or click them on "
            "the pose-probability plot")
#: what the IK tab says while no effector is chosen (its target sliders are disabled until one is)
IK_TIP = "choose an IK effector (a hand or foot) first: the target sliders then move it at pose k"


def _hint(text: str, width: str | None = None) -> widgets.HTML:
    """A short grey sentence saying what the controls beside it do (its own line height: a widget's text lines
    are 28 px apart)."""
    return widgets.HTML(f'<div style="font-size:11px;line-height:14px;color:#4a5568">{html.escape(text)}</div>',
                        layout=widgets.Layout(width=width, margin="0 0 0 8px") if width else
                        widgets.Layout(margin="0 0 0 8px"))


def _tools(c: dict, insert: widgets.Button, delete: widgets.Button, note=None, ik_hint=None) -> tuple[list, dict]:
    """(the main sliders, always shown: cull %, s, τ, w_r; the tools, one tab each: their other settings). The
    propagation of pose edits (issue 24) sits with the pose edits it spreads, the region of the timing edits with
    the timing; the wand's σ serves both and shows in both tabs (one control, two views). The picked-poses list
    has its hint beside it (the tab no taller); ``ik_hint`` goes under the IK effector."""
    quick = [c["percent"], c["s"], c["tau"], c["w_r"]]
    keep_hint = _hint("pick poses: select them here (ctrl-click for several) or click them on the probability plot",
                      width="136px")
    keep_hint.add_class("sn-keep-hint")
    tools = {"cull": [widgets.HBox([c["cull_by"]]), widgets.HBox([c["count"]]),
                      widgets.HBox([c["keep"], keep_hint], layout=widgets.Layout(align_items="center"))],
             "timing": [widgets.HBox([c["root"], c["l"]]), widgets.HBox([c["joints"]]),
                        widgets.HBox([c["seed"], c["tau_joints"]]), widgets.HBox([c["region"], c["region_frame"]]),
                        widgets.HBox([c["sigma"]])],
             "pose": [widgets.HBox([c["pose"], c["joint"]]), widgets.HBox([c["w_r_reference"], c["edit_mode"]]),
                      widgets.HBox([c["rx"], c["ry"], c["rz"]]), widgets.HBox([c["pose_time"], insert, delete]),
                      *([widgets.HBox([note])] if note is not None else []),
                      widgets.HBox([c["propagate"], c["sigma"]])],
             "IK": [widgets.HBox([c["ik_joint"]]), *([widgets.HBox([ik_hint])] if ik_hint is not None else []),
                    widgets.HBox([c["ik_x"], c["ik_y"], c["ik_z"]])],
             "contacts": [widgets.HBox([c["keep_contacts"]]),
                          widgets.HTML('<span style="font-size:12px;color:#4a5568">the source\'s foot contacts, '
                                       "carried through the timing edits, are held by IK</span>")]}
    return quick, tools


class StaggerEditor(_Editor):
    """Staggered-pose editor (Coleman et al. 2008): cull by %, count or picked poses (§4.3); succession root,
    joint subset, ``s``, ``l`` and random ``τ`` with joints and seed (§5.2); exaggeration ``w_r`` against the
    previous / next / mean / a chosen pose (§5.3); geometric pose edits in staggered or non-staggered mode, retime,
    insert and delete a pose (§5.1, Fig. 6); keep contacts (off by default: the layer misses issue 20's goals at
    moderate edits); IK posing of a hand or foot.

    ``editor.model`` is a :class:`~stagger_nb.session.models.StaggerModel`; ``editor.session`` the Session.
    With ``precompute`` the extraction, every cull position and the replay of the current edit at each position
    are warmed after first paint (``Session.warm``).
    """

    _css = "sn-stagger-editor"
    _ALIASES = {"cull": "percent", "joint_set": "tau_joints", "nudge": ("rx", "ry", "rz")}
    _NOTES_BESIDE = ("pose_time",)   # a refused pose time is said under its field (once: not in the message line)

    def __init__(self, motion, session: Session | None = None, source_path=None, precompute: bool = True,
                 show_ghost: bool = False, **kwargs):
        super().__init__(**kwargs)
        session = _session_for(self, motion, session, source_path)
        m = session.source
        names = list(m.skeleton.names)
        model = StaggerModel(root=_default_joint(names, "Hips", "LeftShoulder", "LeftArm", "lShldr"),
                             joint=_default_joint(names, "LeftForeArm", "LeftElbow", "lForeArm"),
                             frame_time=m.frame_time)
        self.insert_button = widgets.Button(description="insert pose at playhead", layout=widgets.Layout(width="200px"))
        self.delete_button = widgets.Button(description="delete pose k", layout=widgets.Layout(width="140px"))
        self.insert_button.on_click(lambda _: self.insert_at_playhead())
        self.delete_button.on_click(lambda _: self.delete_pose(self.model.pose))
        view = SkeletonView(m, ghost=m, show_ghost=show_ghost, **_VIEW_SIZE)
        self.curves = PlotView(frame_time=m.frame_time)
        self.probability = PlotView(frame_time=m.frame_time)
        self.probability.on_click(self._on_probability_click)
        self.timeline = Timeline()
        self._knots = None   # the KnotTable the dope sheet shows
        self._defer = precompute   # first paint without the staggered plots; the warm-up's extraction draws them
        self.controls = {}
        self._setup(model, session, view, [self.curves, self.probability], self._make_controls,
                    views=[self.timeline])
        self._bind_timeline()
        c = self.controls
        # the model first (the binding set it from the session's ops), then the controls attached to it
        for k, w in c.items():
            if k not in ("keep", "w_r_reference"):
                self._links.append(_link(model, k, w, transform=(tuple, list) if isinstance(
                    w, widgets.SelectMultiple) else (None, None)))
        self._links.append(_link(model, "keep", c["keep"], transform=(tuple, list)))
        self._links.append(_link(model, "w_r_reference", c["w_r_reference"]))
        # the IK target sliders reach where the model says: the clip's box, set before they are shown
        reach_ik_targets(model, session)
        for a in "xyz":
            self._ik_reach(a)
            model.observe(lambda ch, a=a: self._ik_reach(a), names=["ik_range", "ik_step"])
        model.observe(self._on_inert, names=["s", "tau", "w_r", "cull_by", "ik_joint", "region", "propagate"])
        model.observe(self._on_selection, names=["joint"])
        model.observe(self._show_region, names=["region_weights"])
        model.observe(self._on_pose, names=["pose", "ik_joint"])
        model.observe(self._on_playhead, names=["frame", "pose_times"])
        self._on_inert()
        self._on_playhead()
        self._on_pose()
        if precompute:
            self._warm_positions()

    @property
    def knot_table(self):
        """The :class:`~stagger_nb.session.timeline.KnotTable` the dope sheet shows, or None before the first
        staggered draw."""
        return self._knots

    def _make_controls(self, model: StaggerModel) -> tuple[list, dict]:
        """The controls (``self.controls``), the main sliders and the tools, once the binding has set the model
        up."""
        self.controls = _controls(self.session.source, list(self.session.source.skeleton.names), model)
        # a refused pose time says why beside the field it was typed in (and in the message line)
        self.pose_time_note = widgets.HTML("", layout=widgets.Layout(margin="0 0 0 124px", min_height="0"))
        self.pose_time_note.add_class("sn-pose-time-note")
        model.observe(self._show_pose_time_note, names="notes")
        self.ik_hint = _hint(IK_TIP)
        self.ik_hint.add_class("sn-ik-hint")
        return _tools(self.controls, self.insert_button, self.delete_button, self.pose_time_note, self.ik_hint)

    def _show_pose_time_note(self, change=None) -> None:
        text = self.model.notes.get("pose_time", "")
        self.pose_time_note.value = (f'<div style="color:#c53030;font-size:12px;line-height:15px">&#9888; '
                                     f'{html.escape(text)}</div>' if text else "")

    # -- the dope sheet --------------------------------------------------------------------------------
    def _bind_timeline(self) -> None:
        """The dope sheet follows the selected pose and joint, the playhead and the timing region; its drags and
        clicks go to the model (a refused drag says why under the sheet)."""
        t, m = self.timeline, self.model
        self._links += [traitlets.dlink((m, "pose"), (t, "selected_pose")),
                        traitlets.dlink((m, "joint"), (t, "selected_joint")),
                        traitlets.dlink((m, "frame"), (t, "frame"))]
        self._js_links.append(self.view.link_frame(t, "frame"))   # browser playback moves its playhead too
        t.observe(self._timeline_seeks, names="frame")
        m.observe(self._open_joint_group, names="joint")
        t.on_refine(self._on_refine)
        t.on_retime(self._on_retime)
        t.on_select(self._on_timeline_select)
        self._show_region()

    def _timeline_seeks(self, change) -> None:
        if not self.timeline.frame_from_browser:
            self.model.frame = change["new"]

    def _open_joint_group(self, change=None) -> None:
        """Every limb group closed but the selected joint's (the sheet stays a few rows tall); after the first
        time, the user's choice with the selected joint's group opened."""
        if self._knots is None:
            return
        mine = self._knots.groups_of(self.model.joint)
        if getattr(self, "_groups_set", False):
            self.timeline.collapsed = [g for g in self.timeline.collapsed if g not in mine]
        else:
            self.timeline.collapsed = [label for label, _ in self._knots.groups if label not in mine]
            self._groups_set = True

    def _on_refine(self, pose: int, joint: str, time: float) -> None:
        """A knot dropped at ``time``: the model's refine op when the knot stays between its neighbours, else the
        plain sentence under the sheet (nothing recorded)."""
        if self._knots is None:
            return
        try:
            op = self._knots.refine_op(pose, joint, self.model.snap_time(time))
            self.model.joint = joint
            self.model.refine(op["pose"], op["joint"], op["time"])
        except (ValueError, traitlets.TraitError) as e:
            self.timeline.message = plain_message(e)

    def _on_retime(self, pose: int, time: float) -> None:
        """A pose's tab dropped at ``time``: the pose retimed (the model's retime op), else a sentence."""
        if self._knots is None:
            return
        try:
            t = self._knots.retime_time(pose, self.model.snap_time(time))
            self.model.pose = pose
            self.model.pose_time = t
        except (ValueError, traitlets.TraitError) as e:
            self.timeline.message = plain_message(e)

    def _on_timeline_select(self, pose: int, joint: str) -> None:
        try:
            if 0 <= pose < len(self.model.pose_times):
                self.model.pose = pose
            if joint:
                self.model.joint = joint
        except traitlets.TraitError as e:
            self.timeline.message = plain_message(e)

    def _draw_timeline(self, edited: Motion, sm) -> None:
        """The dope sheet of ``sm``: sent again only when the knots (or the axis) changed (an exaggeration or a
        pose edit leaves them: nothing is sent)."""
        last = self._knots
        self._knots = knots = knot_table_of(sm, edited.duration)
        self.timeline.x_range = [float(x) for x in _x_span(edited)]
        if not knots.same_as(last):
            self.timeline.set_table(knots)
        else:
            self.timeline.message = ""
        self._open_joint_group()

    def _ik_reach(self, axis: str) -> None:
        lo, hi = self.model.ik_range["xyz".index(axis)]
        w = self.controls["ik_" + axis]
        with w.hold_sync():   # one message: the page re-snaps once, to the final range and step
            w.min, w.max = min(w.min, lo), max(w.max, hi)
            w.step = self.model.ik_step
            w.readout_format = f".{max(0, math.ceil(-math.log10(w.step) - 1e-9)) + 1}f"   # as the model rounds

    def _warm_positions(self) -> None:
        """After first paint: the extraction (then the plots that need it), then every cull position's refit and
        the whole replay of the current edit at that position (a first visit of a position is then a hit)."""
        self._first_future = self._warm("extract", then=self._refresh)
        pcs = [float(p) for p in range(95, 4, -5)]
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
            self.binding.commit(ops)   # replayed first: an insert or delete that cannot apply is not recorded
        except ValueError as e:
            self.error = plain_message(e)
            self._show_message()

    def insert_at_playhead(self) -> None:
        """Insert a staggered pose at the playhead (the button), as :meth:`insert_pose`."""
        self.insert_pose(self.model.frame * self.model.frame_time, _why=self.model.insert_refusal())

    def insert_pose(self, time: float, _why: str | None = None) -> None:
        """Insert a staggered pose at ``time`` seconds (op ``insert_pose``); a time on a pose or outside the
        poses is refused with the model's sentence (``StaggerModel.insert_refusal``; nothing recorded)."""
        why = self.model.insert_refusal(float(time)) if _why is None else _why
        if why:
            self.error = why
            self._show_message()
            return
        self._insert_action({"op": "insert_pose", "time": float(time)})

    def delete_pose(self, k: int) -> None:
        """Delete pose ``k`` (op ``delete_pose``)."""
        self._insert_action({"op": "delete_pose", "pose": int(k)})

    def _on_probability_click(self, x, y, frame) -> None:
        """With cull = "picked", a click on the probability plot toggles the nearest candidate pose (§4.3)."""
        k = self.model.candidate_near(x)
        if self.model.cull_by == "keep" and k is not None:
            self.model.set_control("keep", sorted(set(self.model.keep) ^ {k}))

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
        _inert(c["keep"], m.cull_by != "keep", "choose 'picked' to keep the poses you select", KEEP_TIP)
        for a in "xyz":
            _inert(c["ik_" + a], not m.ik_joint, IK_TIP, f"where {m.ik_joint} goes at pose k, {a} (world units)")
        self.ik_hint.layout.display = None if not m.ik_joint else "none"   # said while the sliders are disabled
        _inert(c["region_frame"], not m.region, "the region's centre: inert while the region is off")
        _inert(c["sigma"], not (m.region or m.propagate), "the falloff width: inert while neither the region nor "
                                                          "propagation is on")

    def _on_playhead(self, change=None) -> None:
        """"insert pose at playhead" is disabled, saying why, while the playhead cannot take a new pose (on a
        pose, or outside them)."""
        why = self.model.insert_refusal()
        _inert(self.insert_button, bool(why), why, "insert a pose at the playhead (§5.1)")

    def _show_region(self, change=None) -> None:
        """The timing edits' region (``model.region_weights``, a weight per pose) on the dope sheet, when the editor
        has one (``editor.timeline``); the pose-probability plot draws it too."""
        timeline = self.__dict__.get("timeline")
        if timeline is not None and hasattr(timeline, "region"):
            timeline.region = [float(w) for w in self.model.region_weights]

    def _on_selection(self, change=None) -> None:
        self._redraw(self._draw_curves)

    def _on_pose(self, change=None) -> None:
        """The IK target sliders start at the effector's place at the selected pose (no edit recorded)."""
        try:
            place_ik_target(self.model, self.session)
        except ValueError:   # a replay error: the message line already shows it
            pass

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
        text = (f'<details style="color:#b7791f;{_LINES}"><summary>&#9888; {html.escape(summary)}</summary>'
                f'<ul style="max-height:12em;overflow:auto">{details}</ul></details>')
        self._warnings_shown = (summary, warnings, text)
        return text

    # -- views -----------------------------------------------------------------------------------------
    def _needs_staggered(self) -> bool:
        return any(o.name in STAGGER_OPS + ("insert_pose", "delete_pose", "extract") for o in self.session.typed_ops)

    def _update_views(self, edited: Motion) -> None:
        if not self._needs_staggered() and not self._extraction_ready():
            self._last_staggered = None
            self._draw_curves(edited)
            if not self.probability.figure:
                self.probability.figure = pose_probability_figure(None, None, [], [], [], [],
                                                                  title="pose probability: extracting poses…",
                                                                  x_range=_x_span(edited))
            self._show_motion(edited)
            return   # first paint: the extraction is computed after it (warm), then this draws the rest
        sm, full = stagger_state(self.model, self.session)
        self._last_staggered = sm
        K = sm.num_poses
        self.binding.show_staggered(sm)   # pose times, their source frames, the region's weights
        # what a slider move shows first: the plot, then the 3D view's shown frame; the rest after
        self._draw_curves(edited, sm)
        self._show_motion(edited, pose_frames=self.model.pose_frames(),
                          contacts=list(getattr(sm, "contacts", ()) or ()))
        c = self.controls
        c["pose"].max = max(K - 1, c["pose"].max if self.model.pose >= K else 0)
        opts = [(f"{k}: {t:.2f} s", k) for k, t in enumerate(self.model.candidate_times)]
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
        self._draw_probability(full, sm, _x_span(edited))
        self._later("timeline", lambda: self._draw_timeline(edited, sm))   # the dope sheet, once the edit rests
        self._quality_later()   # the quality line, once the edit rests

    def _extraction_ready(self) -> bool:
        """Whether the staggered plots can be drawn now without waiting for the extraction: always without a
        warm-up; with one, once its extraction is done (first paint shows the motion and curves before)."""
        if not self._defer:
            return True
        fut = getattr(self, "_first_future", None)
        return fut is not None and fut.done()

    def _draw_probability(self, full, sm, x_range) -> None:
        """The pose-probability plot: rebuilt only when the extraction or the kept poses changed (a timing or
        exaggeration slider leaves it as it is: no figure rebuilt, nothing sent)."""
        region = list(self.model.region_weights)
        region = region if len(region) == len(self.model.pose_times) else None
        key = (full, tuple(self.model.pose_times), tuple(x_range), None if region is None else tuple(region))
        last = getattr(self, "_probability_key", None)
        if last is not None and last[0] is full and last[1:] == key[1:] and self.probability.figure:
            return
        v = probability_view(self.session, sm, full)
        self.probability.figure = pose_probability_figure(
            v["times"], v["probability"], v["candidate_times"], v["candidate_values"], v["kept_times"],
            v["kept_values"], x_range=x_range, region=region)
        self._probability_key = key

    def _draw_curves(self, edited: Motion, sm=None) -> None:
        name = self.model.joint
        sm = sm if sm is not None else getattr(self, "_last_staggered", None)
        v = joint_curves_view(self.session, edited, name, sm,
                              self._source_degrees(self.session.source.skeleton.index(name)))
        self.curves.figure = joint_curves_figure(
            v["times"], v["degrees"], v["source_degrees"], v["source_times"], pose_times=v["pose_times"],
            knot_times=v["knot_times"], title=f"{html.escape(name)}: rotation vector (°), edited vs original",
            x_range=_x_span(edited), height=_PLOT_HEIGHT)
        self.view.highlight_joints([name])
