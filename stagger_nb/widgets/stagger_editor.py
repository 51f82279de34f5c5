"""The staggered-pose editor (Coleman et al. 2008): cull, succession, random timing, exaggeration, pose edits,
retime, insert/delete, foot contacts and IK posing over a :class:`~stagger_nb.session.models.StaggerModel`."""
from __future__ import annotations

import html
import math

import ipywidgets as widgets

from ..core.motion import Motion
from ..plotting import joint_curves_figure, pose_probability_figure
from ..session import Session
from ..session.models import STAGGER_OPS, StaggerModel, plain_message
from ..session.models.views import joint_curves_view, place_ik_target, probability_view, reach_ik_targets, stagger_state
from ._controls import _inert, _link
from ._editor import _Editor, _session_for
from ._sizes import _LINES, _PLOT_HEIGHT, _VIEW_SIZE, _default_joint, _x_span
from ._stagger_controls import IK_TIP, KEEP_TIP, _controls, _hint, _tools
from ._stagger_sheet import _DopeSheet
from .plots import PlotView
from .skeleton_view import SkeletonView
from .timeline import Timeline

__all__ = ["StaggerEditor"]


class StaggerEditor(_DopeSheet, _Editor):
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
