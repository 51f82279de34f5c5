"""One editor per technique: controls linked to an evented model, a 3D view and plots that observe it.

State lives in one place, the editor's model (:mod:`stagger_nb.session.models`): controls are attached with
``link``, the :class:`~stagger_nb.session.models.ModelBinding` writes the model into the session's op list (keeping
every op the editor does not own, in place) and sets the model back from it on undo/redo/load. Views observe the
model (``model.frame`` is the one playhead: the 3D view, every plot and the selected pose / edited frame follow it)
and the session (a new op list redraws them in place). No math and no threads here: heavy heads are warmed by
``Session.warm`` when the session offers it.
"""
from __future__ import annotations

import html
import re

import ipywidgets as widgets
import numpy as np
import traitlets

from ..core.kinematics import forward_kinematics
from ..core.motion import Motion
from ..session import Session, joint_rotation_degrees, warp_table_key
from ..session.models import ModelBinding, StaggerModel, WandModel, WarpModel
from ..timewarp.guided import AUTO_APPROX_PAIRS
from ..plotting import EDIT_COLOUR, falloff_figure, joint_curves_figure, pose_probability_figure, warp_figure
from .plots import PlotView
from .skeleton_view import SkeletonView

__all__ = ["StaggerEditor", "WandEditor", "WarpEditor"]

_STYLE = {"description_width": "120px"}
_WIDE = widgets.Layout(width="340px")


def _session_for(motion, session: Session | None, source_path=None) -> Session:
    if session is not None:
        return session
    if isinstance(motion, Session):
        return motion
    if not isinstance(motion, Motion):
        raise ValueError(f"motion: expected a Motion or a Session, got {type(motion).__name__}")
    return Session(motion, source_path=source_path)


def _x_span(edited: Motion) -> tuple:
    """The x range (seconds) of every time plot of an editor: the edited motion's span, the frames the
    playhead walks; one range for all plots, so their playheads line up down the column."""
    return (0.0, max(float(edited.times[-1]), float(edited.frame_time)))


def _default_joint(names, *preferred) -> str:
    for p in preferred:
        for n in names:
            if n.lower() == p.lower():
                return n
    return names[min(len(names) - 1, 1)]


def _slider(cls, description, **kw):
    return cls(description=description, continuous_update=True, style=_STYLE, layout=widgets.Layout(width="340px"),
               **kw)


def _grow_range(model, name, control, log=False):
    """Let ``control``'s range grow to show whatever value the model holds (a session's skip = 100 is shown as
    100, never clamped and written back). Registered before the link, so it runs first."""
    def grow(change=None):
        v = getattr(model, name)
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            return
        x = float(np.log10(v)) if log else v
        if x > control.max:
            control.max = x
        if x < control.min:
            control.min = x
    grow()
    model.observe(grow, names=name)


def _link(model, name, control, log=False):
    if hasattr(control, "max") and hasattr(control, "min") and not isinstance(control, widgets.IntRangeSlider):
        _grow_range(model, name, control, log=log)
    return widgets.link((model, name), (control, "value"))


def _session_knows(op: dict) -> bool:
    """Whether this version of the session package accepts ``op`` (a tool whose op it lacks is disabled)."""
    from .. import session as _s
    check = getattr(_s, "validate_op", None)
    if check is None:
        return True
    try:
        check(op)
        return True
    except ValueError:
        return False


def _on_kernel_thread(fn, *args) -> None:
    """Run ``fn(*args)`` on the kernel's own thread (the IOLoop, where widget messages and user edits run) when
    called from the session's warm-up worker; directly outside a kernel (scripts, tests)."""
    try:
        from IPython import get_ipython
        loop = getattr(getattr(get_ipython(), "kernel", None), "io_loop", None)
    except ImportError:
        loop = None
    if loop is None:
        fn(*args)
    else:
        loop.add_callback(fn, *args)


def _share_layouts_and_styles(root: widgets.Widget, keep=()) -> int:
    """Let the widgets under ``root`` with equal ``layout`` (or equal ``style``) share one model, closing the
    duplicates (ipywidgets lets controls share a Layout or style instance). Each model is one more for JupyterLab
    to restore on a page reload, where a long restore shows "model not found" (``save_and_reload`` in
    tests/browser_harness.py): a StaggerEditor made ~54 Layout and ~30 style models of a handful of distinct
    settings. The 3D view and the plots (their own models), the widgets in ``keep`` (whose layout is changed
    later) and the module's ``_WIDE`` are left alone. Call it before the editor is displayed. Returns the number
    of models closed."""
    canon, stack, done, closed = {}, [root], set(), 0
    skip = {id(w) for w in keep}
    while stack:
        w = stack.pop()
        if id(w) in done or id(w) in skip or isinstance(w, (SkeletonView, PlotView)):
            continue
        done.add(id(w))
        stack.extend(getattr(w, "children", ()) or ())
        for name in ("layout", "style"):
            sub = getattr(w, name, None) if w.has_trait(name) else None
            if not isinstance(sub, widgets.Widget):
                continue
            key = (type(sub), tuple(sorted((k, repr(v)) for k, v in sub.get_state().items())))
            first = canon.setdefault(key, sub)
            if first is not sub:
                setattr(w, name, first)
                if sub is not _WIDE:
                    sub.close()
                    closed += 1
    return closed


def _inert(control, inert: bool, why: str, tip: str = "") -> None:
    """Disable ``control`` with a tooltip saying why (or enable it with its normal tooltip)."""
    control.disabled = bool(inert)
    control.tooltip = why if inert else tip


class _Editor(widgets.VBox):
    """Common plumbing: message line, progress bar, undo/redo, model <-> session binding, the shared playhead."""

    _css = ""
    _ALIASES: dict = {}   # former attribute names of controls (deprecated): name -> key in self.controls

    def __getattr__(self, name):
        """Deprecated aliases: ``editor.s`` etc. are the controls ``editor.controls["s"]`` (set the model instead:
        ``editor.model.s = 0.03``)."""
        controls = self.__dict__.get("controls")
        if controls is not None and not name.startswith("_"):
            key = self._ALIASES.get(name, name)
            if isinstance(key, tuple):
                return [controls[k] for k in key]
            if key in controls:
                return controls[key]
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def _setup(self, model, session: Session, view: SkeletonView, plots: list, controls: list,
               references: dict | None = None):
        self.model = model
        self.session = session
        self.view = view
        self.plots = plots
        self.error = ""
        self.message = widgets.HTML("", layout=widgets.Layout(min_height="20px"))
        self.progress = widgets.IntProgress(value=0, min=0, max=1, description="computing",
                                            layout=widgets.Layout(visibility="hidden", width="300px"))
        self.undo_button = widgets.Button(description="undo", icon="undo", layout=widgets.Layout(width="90px"))
        self.redo_button = widgets.Button(description="redo", icon="repeat", layout=widgets.Layout(width="90px"))
        self.undo_button.on_click(lambda _: self.session.undo())
        self.redo_button.on_click(lambda _: self.session.redo())
        self.binding = ModelBinding(model, session, references=references)
        # the shared playhead: model.frame <-> the 3D view (its Play and slider follow the view)
        self.frame_slider = getattr(view, "frame_slider", None) or view.slider
        self.player = getattr(view, "player", None) or view.play
        self.frame_slider.add_class("sn-frame")
        self._links = [widgets.link((model, "frame"), (view, "frame"))]
        for p in plots:
            self._links.append(widgets.dlink((model, "frame"), (p, "frame")))
            p.observe(self._plot_seeks, names="frame")   # a click on a plot seeks
            if hasattr(view, "link_frame"):
                view.link_frame(p, "frame")   # during browser playback the playheads move without the kernel
        if model.has_trait("joint") and view.has_trait("selected_joint"):
            view.observe(self._on_picked, names="selected_joint")
        model.observe(self._show_message, names="message")
        session.observe(self._on_session)
        if hasattr(session, "observe_busy"):
            session.observe_busy(self._on_busy)
        for row in controls:   # a row that does not fit wraps (shrunk sliders lose their track at 1280 px)
            if isinstance(row, widgets.HBox):
                row.layout.flex_flow = "row wrap"
        top = widgets.HBox([self.undo_button, self.redo_button, self.progress])
        # the plots take the width left beside the 3D view, or go below it (wrap) when less than 420 px is left
        body = widgets.HBox([view, widgets.VBox(plots, layout=widgets.Layout(flex="1 1 420px", min_width="0",
                                                                           max_width="100%"))],
                            layout=widgets.Layout(width="100%", flex_flow="row wrap", align_items="flex-start"))
        self.children = [top, widgets.VBox(controls), self.message, body]
        self.shared_models_closed = _share_layouts_and_styles(self, keep=(self.progress,))
        self.add_class(self._css)
        self._update_buttons()
        self._refresh()

    def _plot_seeks(self, change) -> None:
        """A plot's frame moves the playhead, unless the browser set it through the Play's jsdlink (then the
        Play's own message moves it: acting here too wrote stale frames back to the Play and slider, which
        jumped back while keys were pressed, and left the kernel a frame off the browser)."""
        if not change["owner"].frame_from_browser:
            self.model.frame = change["new"]

    def _on_picked(self, change) -> None:
        """Clicking a joint in the 3D view selects it in the editor."""
        if change["new"] and change["new"] in self.model.joint_names:
            self.model.joint = change["new"]

    def _show_motion(self, edited: Motion, pose_frames=None, contacts=None) -> None:
        """Send the edited motion to the 3D view once per edit (not again for a view-only change); the pose
        frames and contacts only when they changed (each is a set of highlight tracks to rebuild)."""
        pf = None if pose_frames is None else tuple(int(f) for f in pose_frames)
        ct = None if contacts is None else tuple(tuple(c) for c in contacts)
        last = getattr(self, "_shown", (None, None))   # the highlights last sent (the motion: view.motion)
        pf_new = pf if pf is not None and pf != last[0] else None
        ct_new = ct if ct is not None and ct != last[1] else None
        if self.view.motion is edited and pf_new is None and ct_new is None:
            return
        self._shown = (pf if pf is not None else last[0], ct if ct is not None else last[1])
        if self.view.motion is edited:   # only the highlights changed
            if pf_new is not None:
                self.view.set_pose_frames(pf_new)
            if ct_new is not None:
                self.view.set_contacts(ct_new)
            return
        self.view.set_motion(edited, pose_frames=pf_new, contacts=ct_new)

    def _source_degrees(self, j: int) -> np.ndarray:
        """The source's rotation vector of joint ``j`` in degrees, (F, 3): computed once per joint (and source)."""
        src, cache = self.__dict__.get("_source_deg", (None, None))
        if src is not self.session.source:
            cache = {}
            self._source_deg = (self.session.source, cache)
        if j not in cache:
            cache[j] = joint_rotation_degrees(self.session.source, j)
        return cache[j]

    def seek(self, frame: int) -> None:
        """Move the playhead (what a click on a plot does)."""
        self.model.frame = max(0, int(frame))

    def figures(self) -> list:
        """The plots' current figures as plotly JSON dicts (for ``export_html``)."""
        return [p.figure for p in self.plots]

    # -- session -> views ---------------------------------------------------------------------------
    def _on_session(self, session) -> None:
        self._update_buttons()
        self._refresh()

    def _update_buttons(self):
        self.undo_button.disabled = not self.session.can_undo
        self.redo_button.disabled = not self.session.can_redo

    def _on_busy(self, kind: str, started: bool) -> None:
        labels = {"extract": "extracting poses", "graph": "pose graph", "basis": "eigenvectors",
                  "warp": "kNN tables", "cull": "culling poses"}
        if started:
            self.progress.description = labels.get(kind, kind)
            self.progress.value = 0
            self.progress.layout.visibility = "visible"
        else:
            self.progress.value = self.progress.max
            self.progress.layout.visibility = "hidden"

    def _on_progress(self, done, total, label) -> None:
        if total > 1:
            self.progress.max = total
            self.progress.value = done

    def _refresh(self) -> None:
        """Replay (memoised) and redraw the views; an error is shown, never raised into the front end, and
        cleared when its cause is gone."""
        try:
            edited = self.session.edited(progress=self._on_progress)
            self._update_views(edited)
            self.error = ""
        except Exception as e:  # noqa: BLE001 - the UI boundary: report, never raise into the frontend
            self.error = f"{type(e).__name__}: {e}"
        self._show_message()

    def _redraw(self, draw) -> None:
        """``draw(session.edited())`` for a view-only change (no new ops): an error is shown, as in
        :meth:`_refresh`, never raised into the front end."""
        try:
            draw(self.session.edited())
        except Exception as e:  # noqa: BLE001 - the UI boundary: report, never raise into the frontend
            self.error = f"{type(e).__name__}: {e}"
            self._show_message()

    def _notes(self) -> list:
        """Plain notes of the last replay (``Session.messages`` when the session has it)."""
        get = getattr(self.session, "messages", None)
        return list(get()) if callable(get) else []

    def _warnings_html(self) -> str:
        return ""

    def _show_message(self, change=None) -> None:
        parts = []
        for text, colour in ((self.error, "#c53030"), (self.model.message, "#c53030")):
            if text:
                parts.append(f'<div style="color:{colour}">&#9888; {html.escape(text)}</div>')
        for text in self._notes():
            parts.append(f'<div style="color:#b7791f">{html.escape(text)}</div>')
        w = self._warnings_html()
        if w:
            parts.append(w)
        self.message.value = "".join(parts)

    def _update_views(self, edited: Motion) -> None:
        raise NotImplementedError

    def _warm(self, *jobs, then=None):
        """Fill the session's caches after first paint (``Session.warm``: a cancellable future on the session's
        executor, never a thread of ours); ``then()`` runs when it is done (e.g. draw what needed it). The
        progress bar shows meanwhile. Returns the future (also ``editor.warm_future``), None without warm."""
        warm = getattr(self.session, "warm", None)
        if warm is None:
            return None
        self.progress.layout.visibility = "visible"
        fut = warm(*jobs, progress=self._on_progress)
        self.warm_future = fut
        self.__dict__.setdefault("_warm_futures", []).append(fut)   # every one: close() cancels them all

        def done(f):
            if f is self.warm_future:
                self.progress.layout.visibility = "hidden"
            if not f.cancelled() and f.exception() is None and then is not None:
                then()
        fut.add_done_callback(lambda f: _on_kernel_thread(done, f))
        return fut

    def _futures(self):
        """Every warm-up future this editor submitted (in order)."""
        return list(self.__dict__.get("_warm_futures", ()))

    def close(self):
        """Cancel this editor's warm-ups and close every widget it made (controls, the 3D view, the plots and
        the layout boxes), so none stays registered with ipywidgets after the editor is gone."""
        for fut in self._futures():
            fut.cancel()
        owned = [*getattr(self, "controls", {}).values(), getattr(self, "view", None), *getattr(self, "plots", [])]
        stack = list(self.children)
        while stack:
            w = stack.pop()
            stack.extend(getattr(w, "children", ()) or ())
            owned.append(w)
        for w in owned:
            if isinstance(w, widgets.Widget):
                w.close()
        super().close()


_EFFECTOR = re.compile(r"(hand|foot|wrist|ankle)$", re.IGNORECASE)


class StaggerEditor(_Editor):
    """Staggered-pose editor (Coleman et al. 2008): cull by %, count or picked poses (§4.3); succession root,
    joint subset, ``s``, ``l`` and random ``τ`` with joints and seed (§5.2); exaggeration ``w_r`` against the
    previous / next / mean / a chosen pose (§5.3); geometric pose edits in staggered or non-staggered mode, retime,
    insert and delete a pose (§5.1, Fig. 6); keep contacts (on by default); IK posing of a hand or foot.

    ``editor.model`` is a :class:`~stagger_nb.session.models.StaggerModel`; ``editor.session`` the Session.
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
        effectors = [n for n in names if _EFFECTOR.search(n)]
        c = {}
        c["cull_by"] = widgets.ToggleButtons(options=[("by %", "percent"), ("by count", "count"),
                                                      ("picked", "keep")], description="cull poses",
                                             style={**_STYLE, "button_width": "90px"},
                                             tooltips=["keep a percentage of the poses, by priority",
                                                       "keep a number of poses, by priority",
                                                       "keep the poses you pick (click the probability plot)"])
        c["percent"] = _slider(widgets.FloatSlider, "keep poses %", min=5.0, max=100.0, step=5.0, readout_format=".0f")
        c["count"] = widgets.BoundedIntText(min=0, max=10**6, description="keep (0 = all)", style=_STYLE,
                                            layout=widgets.Layout(width="230px"))
        c["keep"] = widgets.SelectMultiple(options=[], rows=4, description="keep poses", style=_STYLE,
                                           layout=widgets.Layout(width="260px"))
        c["root"] = widgets.Dropdown(options=names, description="succession root", style=_STYLE)
        c["joints"] = widgets.SelectMultiple(options=names, rows=4, description="delayed joints", style=_STYLE,
                                             layout=widgets.Layout(width="280px"))
        c["s"] = _slider(widgets.FloatSlider, "s (s/bone)", min=-0.1, max=0.1, step=0.005, readout_format=".3f")
        c["l"] = _slider(widgets.FloatSlider, "exponent l", min=0.25, max=4.0, step=0.05)
        c["tau"] = _slider(widgets.FloatSlider, "random τ (s)", min=0.0, max=0.15, step=0.005, readout_format=".3f")
        c["seed"] = widgets.BoundedIntText(min=0, max=2**31 - 1, description="seed", style=_STYLE,
                                           layout=widgets.Layout(width="200px"))
        c["tau_joints"] = widgets.SelectMultiple(options=names, rows=4, description="τ joints", style=_STYLE,
                                                 layout=widgets.Layout(width="280px"))
        c["w_r"] = _slider(widgets.FloatSlider, "exaggerate w_r", min=-1.0, max=2.0, step=0.05)
        c["w_r_reference"] = widgets.Dropdown(options=[("previous", "previous"), ("next", "next"), ("mean", "mean")],
                                              description="against", style=_STYLE)
        c["pose"] = _slider(widgets.IntSlider, "pose k", min=0, max=1)
        c["joint"] = widgets.Dropdown(options=names, description="joint", style=_STYLE)
        c["edit_mode"] = widgets.ToggleButtons(options=["staggered", "unstaggered"], description="edit mode",
                                               style={**_STYLE, "button_width": "100px"},
                                               tooltips=["the edit follows each joint's own timing (Fig. 6a)",
                                                         "the edit lands at the pose time for every joint (Fig. 6b)"])
        for a in "xyz":
            c["r" + a] = _slider(widgets.FloatSlider, f"nudge {a} (°)", min=-90.0, max=90.0, step=1.0)
        c["pose_time"] = widgets.BoundedFloatText(min=0.0, max=m.duration, step=m.frame_time,
                                                  description="pose time (s)", style=_STYLE,
                                                  layout=widgets.Layout(width="230px"))
        c["keep_contacts"] = widgets.Checkbox(description="keep foot contacts", indent=False)
        c["ik_joint"] = widgets.Dropdown(options=[("(none)", "")] + [(n, n) for n in effectors],
                                         description="IK effector", style=_STYLE)
        for a in "xyz":
            c["ik_" + a] = _slider(widgets.FloatSlider, f"target {a}", min=-1.0, max=1.0, step=0.005,
                                   readout_format=".3f")
        self.controls = c
        self.insert_button = widgets.Button(description="insert pose at playhead", layout=widgets.Layout(width="200px"))
        self.delete_button = widgets.Button(description="delete pose k", layout=widgets.Layout(width="140px"))
        self.insert_button.on_click(lambda _: self.insert_pose(self.model.frame * m.frame_time))
        self.delete_button.on_click(lambda _: self.delete_pose(self.model.pose))

        view = SkeletonView(m, ghost=m, show_ghost=show_ghost)
        self.curves = PlotView(frame_time=m.frame_time)
        self.probability = PlotView(frame_time=m.frame_time)
        self._precompute = precompute
        self._defer = precompute and callable(getattr(session, "warm", None))
        layout = [
            widgets.HBox([c["cull_by"], c["keep_contacts"]]),
            widgets.HBox([c["percent"], c["count"], c["keep"]]),
            widgets.HBox([c["root"], c["s"], c["l"], c["joints"]]),
            widgets.HBox([c["tau"], c["seed"], c["tau_joints"]]),
            widgets.HBox([c["w_r"], c["w_r_reference"]]),
            widgets.HBox([c["pose"], c["joint"]]),
            widgets.HBox([c["edit_mode"]]),
            widgets.HBox([c["rx"], c["ry"], c["rz"]]),
            widgets.HBox([c["pose_time"], self.insert_button, self.delete_button]),
            widgets.HBox([c["ik_joint"], c["ik_x"], c["ik_y"], c["ik_z"]]),
        ]
        # the model first (binding: the session's ops set it), then the controls attached to it
        self.model = model
        self.session = session
        self._fk_cache = (None, None)
        self._setup_links = lambda: [_link(model, k, w) if not isinstance(w, widgets.SelectMultiple) else
                                     traitlets.link((model, k), (w, "value"), transform=(tuple, list))
                                     for k, w in c.items() if k not in ("w_r_reference", "keep")]
        self.probability.on_click(self._on_probability_click)
        for k in ("cull_by", "percent", "count", "s", "l", "tau", "w_r", "keep_contacts"):
            c[k].add_class(f"sn-{k.replace('_', '-')}")
        c["percent"].add_class("sn-cull")   # its former name (browser checks)
        self._setup(model, session, view, [self.curves, self.probability], layout)
        self._links += self._setup_links()
        self._links.append(traitlets.link((model, "keep"), (c["keep"], "value"), transform=(tuple, list)))
        self._links.append(traitlets.link((model, "w_r_reference"), (c["w_r_reference"], "value")))
        self._missing = {name for name, op in [
            ("keep_contacts", {"op": "keep_contacts"}),
            ("ik", {"op": "ik_pose", "pose": 0, "joint": names[0], "target": [0.0, 0.0, 0.0]}),
            ("retime", {"op": "retime", "pose": 0, "time": 0.0}),
            ("insert", {"op": "insert_pose", "time": 0.0})] if not _session_knows(op)}
        if "keep_contacts" in self._missing and not any(o["op"] == "keep_contacts" for o in session.ops):
            model.keep_contacts = False
        model.observe(self._on_inert, names=["s", "tau", "w_r", "cull_by", "ik_joint"])
        model.observe(self._on_selection, names=["joint"])
        model.observe(self._on_pose, names=["pose", "ik_joint"])
        self._on_inert()
        self._on_pose()
        if precompute:   # after first paint: the extraction (then the plots that need it), then every cull position:
            # its refit, then the whole replay of the current edit at that position (a first visit is then a hit)
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
        why = "this version of the session has no {} op"
        if "keep_contacts" in self._missing:
            _inert(c["keep_contacts"], True, why.format("keep_contacts"))
        if "ik" in self._missing:
            for k in ("ik_joint", "ik_x", "ik_y", "ik_z"):
                _inert(c[k], True, why.format("ik_pose"))
        if "retime" in self._missing:
            _inert(c["pose_time"], True, why.format("retime"))
        if "insert" in self._missing:
            _inert(self.insert_button, True, why.format("insert_pose / delete_pose"))
            _inert(self.delete_button, True, why.format("insert_pose / delete_pose"))

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
        from ..session.models import STAGGER_OPS
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
        if [o[1] for o in c["keep"].options] != [o[1] for o in opts]:
            c["keep"].options = opts
            c["keep"].value = tuple(k for k in self.model.keep if k < len(opts))
        refs = [("previous", "previous"), ("next", "next"), ("mean", "mean")] + [(f"pose {k}", k) for k in range(K)]
        if isinstance(self.model.w_r_reference, int) and self.model.w_r_reference >= K:
            refs.append((f"pose {self.model.w_r_reference}", self.model.w_r_reference))
        if c["w_r_reference"].options != tuple(refs):
            c["w_r_reference"].options = refs
            c["w_r_reference"].value = self.model.w_r_reference
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


class WandEditor(_Editor):
    """Magic-wand editor (Dean et al. 2018): rotate joints at one or more edited frames and propagate the edit
    with the Green's-function falloff of width σ (§3.3); keep or discard repetitions; compare the falloff with
    ISOMAP, diffusion and spline falloffs (Fig. 3, 6).

    Parameters
    ----------
    motion : Motion or Session
    frame : int, optional
        Edited frame (default the middle).
    joint : str, optional
        Joint whose rotation the sliders edit.
    rotation : (3,) degrees, optional
        Initial rotation-vector edit of ``joint`` (written as an op when the session has no wand op).
    """

    _css = "sn-wand-editor"
    _ALIASES = {"rotation": ("rx", "ry", "rz")}
    _SIGMA_STEP = 0.04   # log10 units between slider positions
    _SIGMA_STEPS = 15    # positions each side of the default sigma (x 0.25 .. x 4)

    def __init__(self, motion, session: Session | None = None, frame: int | None = None, joint: str | None = None,
                 rotation=(0.0, 0.0, 0.0), source_path=None, precompute: bool = True, show_ghost: bool = False,
                 **kwargs):
        super().__init__(**kwargs)
        session = _session_for(motion, session, source_path)
        m = session.source
        F = m.num_frames
        names = list(m.skeleton.names)
        s0 = float(session.wand_graph().default_sigma)
        self._sigma_grid = s0 * 10.0 ** (self._SIGMA_STEP * np.arange(-self._SIGMA_STEPS, self._SIGMA_STEPS + 1))
        f0 = F // 2 if frame is None else int(frame)
        joint = joint or _default_joint(names, "LeftUpLeg", "LeftHip", "LeftFemur", "lThigh")
        model = WandModel(sigma=s0, joint=joint, frame=f0)
        with model.loading():
            model.edit_frame = f0
        c = {}
        c["sigma"] = widgets.FloatLogSlider(base=10, min=np.log10(self._sigma_grid[0]),
                                            max=np.log10(self._sigma_grid[-1]), step=self._SIGMA_STEP,
                                            description="σ", readout_format=".3g", continuous_update=True,
                                            style=_STYLE, layout=_WIDE)
        c["edit_frame"] = _slider(widgets.IntSlider, "edited frame", min=0, max=F - 1)
        c["propagate"] = widgets.Checkbox(description="propagate (off: edit the frames only)", indent=False)
        c["repetitions"] = widgets.ToggleButtons(options=["keep", "discard"], description="repetitions",
                                                 style=_STYLE, tooltips=["propagate to repeats of the edited pose",
                                                                         "edit only the neighbourhood (§3.3)"])
        c["joint"] = widgets.Dropdown(options=names, description="joint", style=_STYLE)
        for a in "xyz":
            c["r" + a] = _slider(widgets.FloatSlider, f"rotate {a} (°)", min=-90.0, max=90.0, step=1.0)
        c["compare"] = widgets.SelectMultiple(options=["isomap", "diffusion", "spline"], rows=3,
                                              description="compare with", style=_STYLE)
        self.controls = c
        self.limit_range = widgets.Checkbox(value=False, description="limit edit range", indent=False)
        self.range = _slider(widgets.IntRangeSlider, "range [start, stop)", min=0, max=F, value=(0, F))
        self.edited_frames = widgets.Dropdown(options=[], description="edited frames", style=_STYLE)
        self.add_button = widgets.Button(description="add edit at playhead", layout=widgets.Layout(width="180px"))
        self.remove_button = widgets.Button(description="remove this edit", layout=widgets.Layout(width="150px"))
        self.add_button.on_click(lambda _: self.model.add_edit(self.model.frame))
        self.remove_button.on_click(lambda _: self.model.remove_edit(self.model.edit_frame))

        view = SkeletonView(m, ghost=m, show_ghost=show_ghost)
        self.falloff_plot = PlotView(frame_time=m.frame_time)
        self.curves = PlotView(frame_time=m.frame_time)
        layout = [widgets.HBox([c["sigma"], c["propagate"], c["repetitions"]]),
                  widgets.HBox([c["edit_frame"], self.edited_frames, self.add_button, self.remove_button]),
                  widgets.HBox([self.limit_range, self.range]),
                  widgets.HBox([c["joint"], c["rx"], c["ry"], c["rz"]]),
                  widgets.HBox([c["compare"]])]
        c["sigma"].add_class("sn-sigma")
        c["edit_frame"].add_class("sn-edit-frame")
        self._setup(model, session, view, [self.falloff_plot, self.curves], layout)
        if not model.edits and any(rotation):   # an initial rotation becomes the first edit
            model.rx, model.ry, model.rz = (float(r) for r in rotation)
        _grow_range(model, "sigma", c["sigma"], log=True)   # slider positions snap to the warmed sigma grid
        self._links.append(traitlets.link((model, "sigma"), (c["sigma"], "value"),
                                          transform=(float, self._snapped_sigma)))
        for k in ("edit_frame", "propagate", "repetitions", "joint", "rx", "ry", "rz"):
            self._links.append(_link(model, k, c[k]))
        self._links.append(traitlets.link((model, "compare"), (c["compare"], "value"), transform=(tuple, list)))
        self._links.append(traitlets.link((model, "frame_range"), (self.range, "value"),
                                          transform=(lambda v: tuple(v) if v else (0, F), list)))
        self.limit_range.value = bool(model.frame_range)
        self.limit_range.observe(self._on_limit, names="value")
        self._range_link_paused = False
        model.observe(self._on_edits, names=["edits", "edit_frame"])
        model.observe(self._on_inert, names=["propagate", "frame_range"])
        model.observe(self._on_view_state, names=["compare", "joint"])
        self.edited_frames.observe(self._on_pick_edit, names="value")
        self._on_edits()
        self._on_inert()
        if precompute:
            order = np.argsort(np.abs(np.log(self._sigma_grid) - np.log(model.sigma)), kind="stable")
            self._warm(("wand_basis", [float(self._sigma_grid[i]) for i in order]))

    def _snapped_sigma(self, value: float) -> float:
        return float(self._sigma_grid[np.argmin(np.abs(np.log(self._sigma_grid) - np.log(value)))])

    def _on_limit(self, change) -> None:
        self.model.frame_range = list(self.range.value) if change["new"] else []

    def _on_pick_edit(self, change) -> None:
        if change["new"] is not None:
            self.model.edit_frame = int(change["new"])

    def _on_edits(self, change=None) -> None:
        opts = [(f"frame {f}", f) for f in self.model.edited_frames]
        if self.edited_frames.options != tuple(opts):
            self.edited_frames.options = opts
        self.edited_frames.value = self.model.edit_frame if self.model.edit_frame in self.model.edits else None

    def _on_inert(self, change=None) -> None:
        c, m = self.controls, self.model
        _inert(c["sigma"], not m.propagate, "σ sets the propagation's falloff: inert while propagate is off")
        _inert(c["repetitions"], not m.propagate, "repetitions apply to the propagation: inert while it is off")
        _inert(self.range, not m.frame_range, "tick 'limit edit range' to restrict the propagation")
        self.limit_range.value = bool(m.frame_range)

    def _on_view_state(self, change=None) -> None:
        self._redraw(self._update_views)

    def _update_views(self, edited: Motion) -> None:
        m = self.session.source
        mod = self.model
        f = int(mod.edit_frame)
        fr = mod.frame_range or None
        compare = list(mod.compare)
        # the falloff depends on the source and these only (not on the rotation): rebuilt when they change
        key = (f, float(mod.sigma), None if fr is None else tuple(fr), tuple(compare), tuple(mod.edited_frames),
               _x_span(edited))
        if f < m.num_frames and (key != getattr(self, "_falloff_key", None) or not self.falloff_plot.figure):
            curves = self.session.falloff_curves(f, mod.sigma, fr, compare=compare)
            self.falloff_plot.figure = falloff_figure(
                m.times, curves, edited_times=[g * m.frame_time for g in (mod.edited_frames or [f])],
                title=f"Green's falloff from frame {f} (σ = {mod.sigma:.3g})", x_range=_x_span(edited))
            self._falloff_key = key
        j = m.skeleton.index(mod.joint)
        self.curves.figure = joint_curves_figure(
            edited.times, joint_rotation_degrees(edited, j), self._source_degrees(j), m.times,
            pose_times=[g * m.frame_time for g in mod.edited_frames], pose_label="edited frames",
            pose_colour=EDIT_COLOUR,
            title=f"{mod.joint}: rotation vector (°), edited vs original", x_range=_x_span(edited))
        self._show_motion(edited, pose_frames=mod.edited_frames or [f])
        self.view.highlight_joints([mod.joint])


class WarpEditor(_Editor):
    """Guided time-warping editor (Hsu et al. 2007): target duration or free length, skip limit, keytimes,
    backward warps, a reference (the input itself, a segment of it, or other clips) and linear vs guided; the
    warp curve and its log-scale derivative (Fig. 5).

    Parameters
    ----------
    motion : Motion or Session
    reference : Motion, path, dict {name: Motion or path}, or None
        Extra reference clips offered besides "self" and "segment". A Motion is offered as "reference".
        In-memory clips are registered with ``Session.use_reference`` (a saved session keeps the name only).
    """

    _css = "sn-warp-editor"

    def __init__(self, motion, reference=None, session: Session | None = None, source_path=None,
                 show_ghost: bool = False, **kwargs):
        super().__init__(**kwargs)
        session = _session_for(motion, session, source_path)
        m = session.source
        given = {}
        if isinstance(reference, (Motion, str)):
            given["reference"] = reference
        elif isinstance(reference, dict):
            given.update(reference)
        elif reference is not None:
            raise ValueError(f"reference: expected a Motion, a path, a dict of them or None, "
                             f"got {type(reference).__name__}")
        refs = {}
        for name, r in given.items():
            if isinstance(r, Motion):
                refs[name] = session.use_reference(f"<memory:{name}>", r)
            else:
                refs[name] = {"path": str(r)}
        D = m.duration
        model = WarpModel(duration=D, segment=[0.0, round(D / 2, 6)])
        c = {}
        c["mode"] = widgets.ToggleButtons(options=["guided", "linear"], description="warp", style=_STYLE)
        c["duration"] = _slider(widgets.FloatSlider, "duration (s)", min=round(D / 8 + m.frame_time, 3),
                                max=round(2 * D, 3), step=m.frame_time, readout_format=".2f")
        c["free_length"] = widgets.Checkbox(description="free length", indent=False)
        c["skip"] = _slider(widgets.IntSlider, "skip s", min=1, max=16)
        c["backward"] = widgets.Checkbox(description="backward", indent=False)
        c["reference"] = widgets.Dropdown(options=["self", "segment"], description="reference", style=_STYLE)
        c["segment"] = _slider(widgets.FloatRangeSlider, "segment (s)", min=0.0, max=round(D, 3), step=m.frame_time,
                               readout_format=".2f")
        self.keytimes = widgets.Text(value="", placeholder="in:out, in:out  (seconds)", description="keytimes",
                                     style=_STYLE, layout=_WIDE)
        self.controls = c
        view = SkeletonView(m, ghost=m, show_ghost=show_ghost)
        self.warp_plot = PlotView(frame_time=m.frame_time)
        layout = [widgets.HBox([c["mode"], c["skip"], c["backward"]]),
                  widgets.HBox([c["duration"], c["free_length"], self.keytimes]),
                  widgets.HBox([c["reference"], c["segment"]])]
        self.click_keytime = widgets.Checkbox(value=False, indent=False,
                                              description="click the warp plot to add a keytime")
        self.clear_keytimes = widgets.Button(description="clear keytimes", layout=widgets.Layout(width="130px"))
        self.clear_keytimes.on_click(lambda _: setattr(self.model, "keytimes", []))
        self.warp_plot.on_click(self._on_warp_click)
        layout.append(widgets.HBox([self.click_keytime, self.clear_keytimes]))
        c["duration"].add_class("sn-duration")
        c["skip"].add_class("sn-skip")
        self._setup(model, session, view, [self.warp_plot], layout, references=refs)
        # a reference given to the constructor is the one used (when the session has no warp op yet)
        traitlets.link((model, "reference_options"), (c["reference"], "options"))
        for k in ("mode", "duration", "free_length", "skip", "backward", "reference"):
            self._links.append(_link(model, k, c[k]))
        self._links.append(traitlets.link((model, "segment"), (c["segment"], "value"), transform=(tuple, list)))
        self._links.append(traitlets.link((model, "keytimes"), (self.keytimes, "value"),
                                          transform=(self._format_keytimes, self._parse_keytimes)))
        model.observe(self._on_inert, names=["mode", "reference", "free_length"])
        self._on_inert()
        if given and not any(o["op"] in ("guided_warp", "linear_warp") for o in session.ops):
            model.reference = next(iter(given))   # a style warp on the given clip, at the same duration
        self._warmed_tables = None
        model.observe(lambda _: self._warm_skip_tables(),
                      names=["reference", "backward", "free_length", "duration", "segment", "mode"])
        self._warm_skip_tables()

    def _warm_skip_tables(self) -> None:
        """Warm (``Session.warm``) the kNN tables of the skip slider's largest value for the current reference,
        direction and upsampling: the session slices every smaller skip from them, so a skip move re-runs only
        the DP. With no warp yet, the tables of a compression (the first duration move's). Submitted again only
        when what chooses the tables changes; long clips (approximate kNN, not sliced) are not warmed."""
        if self.session.source.num_frames ** 2 > AUTO_APPROX_PAIRS:
            return
        ops = [o for o in self.binding.to_ops(self.model.params()) if o["op"] == "guided_warp"]
        if not ops and self.model.mode == "guided":
            ops = [o for o in self.binding.to_ops(dict(self.model.params(), reference="self", free_length=False,
                                                       duration=0.9 * self.session.source.duration))
                   if o["op"] == "guided_warp"]
        if not ops:
            return
        op = dict(ops[-1], skip=max(int(self.controls["skip"].max), int(ops[-1].get("skip", 8))))
        try:
            key = warp_table_key(self.session.source, op) + (op["skip"],)
            if key == self._warmed_tables:
                return
            self._warm(("warp_tables", [op]))
            self._warmed_tables = key
        except ValueError:
            pass   # an op the session cannot warm (e.g. a duration out of range): computed on demand, reported there

    def _on_warp_click(self, x, y, frame) -> None:
        """With "click to add a keytime" on, a click on the warp plot at (output time x, input time y) adds
        the keytime [y, x] (Hsu et al. 2007, §4.2)."""
        if self.click_keytime.value and y is not None and not self.model.free_length:
            kt = sorted(self.model.keytimes + [[float(y), float(x)]], key=lambda p: p[1])
            self.model.keytimes = kt

    @staticmethod
    def _format_keytimes(kt) -> str:
        return ", ".join(f"{a:g}:{b:g}" for a, b in kt)

    def _parse_keytimes(self, text: str):
        """``"in:out, in:out"`` seconds; a malformed entry is reported and the keytimes stay as they were."""
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
                self.error = f"keytimes: {item.strip()!r} is not 'input_time:output_time' (seconds)"
                self._show_message()
                return self.model.keytimes
        self.error = ""
        return pairs

    def _on_inert(self, change=None) -> None:
        c, m = self.controls, self.model
        _inert(c["segment"], m.reference != "segment", "the segment is used only when reference = segment")
        linear = m.mode == "linear"
        for k in ("skip", "reference", "backward", "free_length"):
            _inert(c[k], linear, f"{k} applies to guided warps only")
        _inert(c["duration"], m.free_length and not linear, "free length: the warp chooses its duration")
        _inert(self.keytimes, m.free_length and not linear, "keytimes need a fixed duration (free length is on)")

    def _update_views(self, edited: Motion) -> None:
        from .. import timewarp
        ft = edited.frame_time
        warp = None
        names = [op.name for op in self.session.typed_ops]   # not .ops: a JSON copy of every op per call
        for i in range(len(names) - 1, -1, -1):
            if names[i] in ("guided_warp", "linear_warp"):
                warp = self.session.warp_curve(i)
                break
        if warp is None:   # no warp op (e.g. undone): the identity
            warp = edited.times
        out_t = np.arange(len(warp)) * ft
        kt = self.model.keytimes or None
        self.warp_plot.figure = warp_figure(out_t, warp, timewarp.warp_speed(warp, ft), keytimes=kt,
                                            title=f"{self.model.mode} warp: {self.session.source.duration:.2f} s "
                                                  f"→ {out_t[-1]:.2f} s")
        self._show_motion(edited)
