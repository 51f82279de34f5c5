"""What the three editors share: the message line, progress bar, undo/redo, the model <-> session binding, the
one playhead, the warm-up futures and ``close``.

State lives in one place, the editor's model (:mod:`stagger_nb.session.models`): controls are attached with
``link``, the :class:`~stagger_nb.session.models.ModelBinding` writes the model into the session's op list (keeping
every op the editor does not own, in place) and sets the model back from it on undo/redo/load. Views observe the
model (``model.frame`` is the one playhead: the 3D view, every plot and the selected pose / edited frame follow it)
and the session (a new op list redraws them in place). No math and no threads here: heavy heads are warmed by
``Session.warm``.
"""
from __future__ import annotations

import html
import weakref

import ipywidgets as widgets

from ..core.motion import Motion
from ..session import Session, joint_rotation_degrees
from ..session.models import ModelBinding, plain_message
from ._controls import _STYLE, _inert, _inline, _link, _slider  # noqa: F401  (the editors import them here)
from .plots import PlotView
from .skeleton_view import SkeletonView

__all__ = ["_Editor"]

_WIDE = widgets.Layout(width="340px")
#: The editors' 3D view: beside the tool column in a notebook's output area at 1280x800 (sidebar open)
_VIEW_SIZE = {"width": 400, "height": 236}
#: The height (px) of an editor's first plot, legend row included: it ends inside the first screen
_PLOT_HEIGHT = 272
#: the message line's text: lines 17 px apart (an HTML widget's lines are 28 px apart: a two-line note took 56 px
#: of the tool column)
_LINES = "font-size:13px;line-height:17px"


def _session_for(editor, motion, session: Session | None, source_path=None) -> Session:
    """The session an editor edits: ``session``, ``motion`` when it is one, else a new Session of ``motion``
    (which the editor then owns: closing the editor closes it)."""
    editor._owns_session = False
    if session is not None:
        return session
    if isinstance(motion, Session):
        return motion
    if not isinstance(motion, Motion):
        raise ValueError(f"motion: expected a Motion or a Session, got {type(motion).__name__}")
    editor._owns_session = True
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


def _weakly(method):
    """``method`` (bound) called through a weak reference: a listener a session keeps does not keep the editor
    alive (a dead editor's listener does nothing)."""
    ref = weakref.WeakMethod(method)

    def call(*args):
        m = ref()
        if m is not None:
            m(*args)
    return call


def _widgets_under(root: widgets.Widget, keep=()) -> list:
    """Every widget reachable from ``root`` through its traits and attributes (a 3D view's pythreejs scene,
    camera, picker, meshes, geometries and links; in lists, tuples and dicts too), ``root`` included, those in
    ``keep`` left out:
    what closing an editor closes, so none stays registered with ipywidgets (which would keep the editor
    alive through their observers)."""
    out, stack, seen = [], [root], {id(k) for k in keep}
    while stack:
        w = stack.pop()
        if id(w) in seen:
            continue
        seen.add(id(w))
        out.append(w)
        values = [w._trait_values.get(name) for name in w.trait_names()] + list(vars(w).values())
        for v in values:   # traits, and attributes (the links a view keeps for itself)
            for x in (v if isinstance(v, (list, tuple)) else v.values() if isinstance(v, dict) else (v,)):
                if isinstance(x, widgets.Widget):
                    stack.append(x)
                elif isinstance(x, tuple) and x and isinstance(x[0], widgets.Widget):   # a link's (widget, name)
                    stack.append(x[0])
    return out


def _stop_work(futures: list, session) -> None:
    """What closing (or collecting) an editor stops: its warm-ups, and the session's worker when the editor made
    the session itself."""
    for f in futures:
        f.cancel()
    if session is not None:
        session.close()


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


def _on_kernel_loop_later(delay: float, fn):
    """``fn()`` on the kernel's IOLoop ``delay`` seconds from now (a handle with ``cancel()``); at once (and
    None) outside a kernel (scripts, tests)."""
    try:
        from IPython import get_ipython
        loop = getattr(getattr(get_ipython(), "kernel", None), "io_loop", None)
    except ImportError:
        loop = None
    if loop is None:
        fn()
        return None
    h = loop.call_later(delay, fn)

    class _Handle:
        def cancel(self):
            loop.remove_timeout(h)
    return _Handle()


def _share_layouts_and_styles(root: widgets.Widget, keep=()) -> int:
    """Let the widgets under ``root`` with equal ``layout`` (or equal ``style``) share one model, closing the
    duplicates (ipywidgets lets controls share a Layout or style instance): fewer models for JupyterLab to send
    and restore on a page reload. The 3D view and the plots (their own models), the widgets in ``keep`` (whose
    layout is changed later) and the module's ``_WIDE`` are left alone. Call it before the editor is displayed.
    Returns the number of models closed."""
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


class _Editor(widgets.VBox):
    """Common plumbing: message line, progress bar, undo/redo, model <-> session binding, the shared playhead."""

    _css = ""
    _ALIASES: dict = {}   # former attribute names of controls (deprecated): name -> key in self.controls
    _NOTES_BESIDE: tuple = ()   # traits whose refusal note the editor shows beside the control, not in the message line

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

    def _setup(self, model, session: Session, view: SkeletonView, plots: list, tools,
               references: dict | None = None, quick=(), views=()):
        """Bind ``model`` to ``session`` and lay the editor out as a workspace (at 1280x800 with JupyterLab's
        sidebar open the 3D view, the first plot and the main sliders are on one screen):

        - a top bar: undo, redo, the progress bar, the model's quality line (when it has one);
        - the 3D view beside the tool column: the ``quick`` controls (the main sliders, always shown), then the
          tools (``{label: [rows]}``) one at a time in tabs, then the message line;
        - the plots (and ``views``, e.g. the dope sheet) below, each taking the whole width.

        ``tools`` may be a callable ``tools(model)`` giving ``(quick, tools)`` once the binding has set the model
        from the session (controls whose options depend on it are made then).
        """
        self.model = model
        self.session = session
        self.view = view
        self.plots = plots
        self.error = ""
        self.message = widgets.HTML("", layout=widgets.Layout(min_height="0"))
        self.message.add_class("sn-message")
        # the label whole ("extracting poses", "culling poses"): its own width, the bar takes the rest; out of
        # the layout while idle, so the quality line has the top bar's width
        self.progress = widgets.IntProgress(value=0, min=0, max=1, description="computing",
                                            style={"description_width": "initial"},
                                            layout=widgets.Layout(display="none", width="280px", flex="0 0 auto"))
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
        self._js_links: list = []   # jsdlink widgets: closed with the editor
        for p in plots:
            self._links.append(widgets.dlink((model, "frame"), (p, "frame")))
            p.observe(self._plot_seeks, names="frame")   # a click on a plot seeks
            if hasattr(view, "link_frame"):   # during browser playback the playheads move without the kernel
                self._js_links.append(view.link_frame(p, "frame"))
        if callable(tools):
            quick, tools = tools(model)
        if model.has_trait("joint") and view.has_trait("selected_joint"):
            view.observe(self._on_picked, names="selected_joint")
        model.observe(self._show_message, names=["message", "notes"])
        self._session_listener, self._busy_listener = _weakly(self._on_session), _weakly(self._on_busy)
        session.observe(self._session_listener)
        session.observe_busy(self._busy_listener)
        self._warm_futures: list = []
        owned = session if getattr(self, "_owns_session", False) else None
        self._finalizer = weakref.finalize(self, _stop_work, self._warm_futures, owned)
        # the quality line: the model's plain summary of the edit (shown as it is, when the model has one), in
        # the top bar beside the buttons: two short lines at most, as tall as the buttons (the view never moves
        # down), each part whole (:meth:`_show_quality`)
        self.quality = widgets.HTML("", layout=widgets.Layout(margin="0 0 0 8px", flex="1 1 0%", min_width="0",
                                                              overflow="hidden"))
        self.quality.add_class("sn-quality")
        if model.has_trait("quality"):
            model.observe(self._show_quality, names="quality")
            self._show_quality()
        # the column's whole width: no side margin (a widget's default 2 px beside a width of 100 % made the
        # column scroll sideways by 4 px)
        self.tools = widgets.Tab(children=[widgets.VBox(list(rows)) for rows in tools.values()],
                                 titles=list(tools), layout=widgets.Layout(width="100%", margin="2px 0"))
        self.tools.add_class("sn-tools")
        for rows in tools.values():   # a row that does not fit wraps (shrunk sliders lose their track)
            for row in rows:
                if isinstance(row, widgets.HBox):
                    row.layout.flex_flow = "row wrap"
        top = widgets.HBox([self.undo_button, self.redo_button, self.progress, self.quality],
                           layout=widgets.Layout(align_items="center", flex_flow="row nowrap", width="100%"))
        top.add_class("sn-top-bar")
        side = widgets.VBox([widgets.VBox(list(quick)), self.tools, self.message],
                            layout=widgets.Layout(flex="1 1 350px", min_width="0", max_width="100%"))
        side.add_class("sn-tool-column")
        main = widgets.HBox([view, side], layout=widgets.Layout(width="100%", flex_flow="row wrap",
                                                                align_items="flex-start"))
        below = widgets.VBox(list(plots) + list(views), layout=widgets.Layout(width="100%", min_width="0"))
        self.children = [top, main, below]
        self.shared_models_closed = _share_layouts_and_styles(self, keep=(self.progress,))
        self.add_class(self._css)
        self._update_buttons()
        self._refresh()

    #: the quality line's box: two lines of 12 px text in the height of the top bar's buttons (28 px)
    _QUALITY_LINES, _QUALITY_LINE_PX = 2, 14

    def _show_quality(self, change=None) -> None:
        """The quality line: the model's summary, each part green or red (``ok`` False: out of bounds). Parts
        wrap between words, never inside one: each part is a box of its own (``sn-quality-part``) that moves to
        the next line whole, two lines at most (a part that would start a third is left to the tooltip, which
        holds the whole summary)."""
        q = getattr(self.model, "quality", "") or ""
        if not isinstance(q, dict):
            q = {"text": str(q), "ok": True}
        items = q.get("items") or ([{"text": q["text"], "ok": q.get("ok", True)}] if q.get("text") else [])
        parts = [f'<span class="sn-quality-part" style="display:inline-block;max-width:100%;margin-right:6px">'
                 f'{"&middot; " if k else ""}<span style="color:{"#2f855a" if i.get("ok", True) else "#c53030"}">'
                 f'{html.escape(i["text"])}</span></span>' for k, i in enumerate(items)]
        tip = " · ".join(i["text"] for i in items)
        self.quality.tooltip = tip or None
        n, px = self._QUALITY_LINES, self._QUALITY_LINE_PX
        self.quality.value = (f'<div title="{html.escape(tip)}" style="font-size:12px;line-height:{px}px;'
                              f'max-height:{n * px}px;overflow:hidden;white-space:normal;overflow-wrap:normal;'
                              f'word-break:normal">{"".join(parts)}</div>' if parts else "")

    def _show_progress(self, shown: bool) -> None:
        """The progress bar in the top bar while work runs, out of the layout otherwise."""
        self.progress.layout.display = None if shown else "none"

    def _quality_later(self, delay: float = 0.5) -> None:
        """Ask the binding for the edit's quality line ``delay`` s after the last edit (on the kernel's loop,
        once a drag rests: its ~55 ms CPU on a 2,751-frame clip is not added to each slider move, nor to key
        presses a few tenths of a second apart); at once outside a kernel."""
        handle = self.__dict__.pop("_quality_handle", None)
        if handle is not None:
            handle.cancel()
        me = weakref.ref(self)

        def run():
            ed = me()
            if ed is not None and ed._finalizer.alive:
                ed.__dict__.pop("_quality_handle", None)
                ed.binding.show_quality()
        self._quality_handle = _on_kernel_loop_later(delay, run)

    def _plot_seeks(self, change) -> None:
        """A plot's frame moves the playhead, unless the browser set it through the Play's jsdlink: the Play's
        own message then moves it, and the Play, the slider and the kernel agree on one frame."""
        if not change["owner"].frame_from_browser:
            self.model.frame = change["new"]

    def _on_picked(self, change) -> None:
        """Clicking a joint in the 3D view selects it in the editor."""
        if change["new"] and change["new"] in self.model.joint_names:
            self.model.joint = change["new"]

    #: seconds an edit rests before the work a user does not see at once runs (the whole clip's points for the
    #: 3D view, the dope sheet): a drag sends the plot and the 3D view's shown frame for every value the kernel
    #: takes, and the rest once, when it pauses
    _REST_S = 0.05

    def _later(self, key: str, fn, delay: float | None = None) -> None:
        """``fn()`` on the kernel's loop once edits have rested ``delay`` s (default ``_REST_S``), replacing the
        one pending under ``key``; at once outside a kernel (scripts, tests)."""
        pending = self.__dict__.setdefault("_pending", {})
        handle = pending.pop(key, None)
        if handle is not None:
            handle.cancel()
        me = weakref.ref(self)

        def run():
            ed = me()
            if ed is not None and ed._finalizer.alive:
                ed._pending.pop(key, None)
                try:
                    fn()
                except Exception as e:   # never raised into the kernel's loop: shown as a replay error is
                    ed.error = plain_message(e)
                    ed._show_message()
        h = _on_kernel_loop_later(self._REST_S if delay is None else delay, run)
        if h is not None:
            pending[key] = h

    def _show_motion(self, edited: Motion, pose_frames=None, contacts=None) -> None:
        """Send the edited motion to the 3D view once per edit (not again for a view-only change); the pose
        frames and contacts only when they changed (each is a set of highlight tracks to rebuild). In a kernel
        the shown frame goes at once (``SkeletonView.preview``: a few hundred bytes) and the whole clip once the
        edit rests (:meth:`_later`: a drag does not send megabytes per value)."""
        pf = None if pose_frames is None else tuple(int(f) for f in pose_frames)
        ct = None if contacts is None else tuple(tuple(c) for c in contacts)
        last = getattr(self, "_shown", (None, None))   # the highlights last sent (the motion: view.motion)
        pf_new = pf if pf is not None and pf != last[0] else None
        ct_new = ct if ct is not None and ct != last[1] else None
        self.model.num_frames = edited.num_frames   # the playhead's range (a longer frame is refused)
        pending = self.__dict__.get("_pending", {}).pop("motion", None) if self.view.motion is edited else None
        if pending is not None:   # back to what is shown before an edit on its way was sent: not sent
            pending.cancel()
        if self.view.motion is edited and pf_new is None and ct_new is None:
            return
        self._shown = (pf if pf is not None else last[0], ct if ct is not None else last[1])
        if self.view.motion is edited:   # only the highlights changed
            if pf_new is not None:
                self.view.set_pose_frames(pf_new)
            if ct_new is not None:
                self.view.set_contacts(ct_new)
            return
        if hasattr(self.view, "preview") and not self.view.playing:
            self.view.preview(edited)
        pfs, cts = self._shown
        self._later("motion", lambda: self.view.set_motion(edited, pose_frames=pfs, contacts=cts))

    def _source_degrees(self, j: int):
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
            self._show_progress(True)
        else:
            self.progress.value = self.progress.max
            self._show_progress(False)

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
        except Exception as e:
            self.error = plain_message(e)
        self._show_message()

    def _redraw(self, draw) -> None:
        """``draw(session.edited())`` for a view-only change (no new ops): an error is shown, as in
        :meth:`_refresh`, never raised into the front end."""
        try:
            draw(self.session.edited())
        except Exception as e:
            self.error = plain_message(e)
            self._show_message()

    def _notes(self) -> list:
        """Plain notes of the last replay (``Session.messages`` when the session has it)."""
        get = getattr(self.session, "messages", None)
        return list(get()) if callable(get) else []

    def _warnings_html(self) -> str:
        return ""

    def _show_message(self, change=None) -> None:
        """The message line: a replay error, the model's message, each refused control's note (why its last
        value was refused), the runners' notes and the timing warnings."""
        parts = []
        beside = {self.model.notes.get(k, "") for k in self._NOTES_BESIDE}   # said once, beside their control
        shown = set(beside)
        for text in (self.error, self.model.message, *self.model.notes.values()):
            if text and text not in shown:
                shown.add(text)
                parts.append(f'<div class="sn-refused" style="color:#c53030;{_LINES}">&#9888; '
                             f'{html.escape(text)}</div>')
        for text in self._notes():
            parts.append(f'<div style="color:#b7791f;{_LINES}">{html.escape(text)}</div>')
        w = self._warnings_html()
        if w:
            parts.append(w)
        self.message.value = "".join(parts)

    def _update_views(self, edited: Motion) -> None:
        raise NotImplementedError

    def _warm(self, *jobs, then=None):
        """Fill the session's caches after first paint (``Session.warm``: a cancellable future on the session's
        executor, never a thread of ours); ``then()`` runs when it is done (e.g. draw what needed it). The
        progress bar shows meanwhile. Returns the future (also ``editor.warm_future``)."""
        self._show_progress(True)
        fut = self.session.warm(*jobs, progress=_weakly(self._on_progress))
        self.warm_future = fut
        self._warm_futures.append(fut)   # every one: close() cancels them all
        me = weakref.ref(self)
        if then is not None and hasattr(then, "__self__"):
            then = _weakly(then)   # the future (kept by the finalizer) must not keep the editor alive

        def done(f):
            ed = me()
            if ed is None or ed._finalizer.alive is False:   # closed meanwhile: nothing to draw
                return
            if f is ed.warm_future:
                ed._show_progress(False)
            if not f.cancelled() and f.exception() is None and then is not None:
                then()
        fut.add_done_callback(lambda f: _on_kernel_thread(done, f))
        return fut

    @property
    def warm_futures(self) -> list:
        """Every warm-up future this editor submitted, in order (the first of a StaggerEditor is its
        extraction, which draws the staggered plots when done)."""
        return list(self._warm_futures)

    def _futures(self):   # former name
        return self.warm_futures

    @property
    def warming(self) -> bool:
        """Whether a warm-up this editor started is still pending or running."""
        return any(not f.done() for f in self._warm_futures)

    def close(self):
        """Stop this editor's work (its warm-ups are cancelled; a session the editor made itself ends its
        worker thread), stop following the session, and close every widget it made (controls, the 3D view,
        the plots and the layout boxes), so none stays registered with ipywidgets after the editor is gone."""
        if "binding" in self.__dict__:   # set up (a second close, e.g. from Widget.__del__, does nothing more)
            self._finalizer()
            self.binding.close()
            self.session.unobserve(self._session_listener)
            self.session.unobserve_busy(self._busy_listener)
        view = getattr(self, "view", None)
        owned = [*getattr(self, "controls", {}).values(), *getattr(self, "plots", []), *getattr(self, "_js_links", []),
                 *(_widgets_under(view, keep=(_WIDE,)) if isinstance(view, widgets.Widget) else ())]
        stack = list(self.children)
        while stack:
            w = stack.pop()
            stack.extend(getattr(w, "children", ()) or ())
            owned.append(w)
        for w in owned:
            if isinstance(w, widgets.Widget):
                w.close()
        super().close()
