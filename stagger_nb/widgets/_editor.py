"""What the three editors share: the model <-> session binding, the workspace set-up, the refresh after each
change, the warm-up futures and ``close`` (here); the top bar and message line (:mod:`._editor_status`) and the one
playhead with what an edit sends once it rests (:mod:`._editor_playhead`) are mixins of :class:`_Editor`.

State lives in one place, the editor's model (:mod:`stagger_nb.session.models`): controls are attached with
``link``, the :class:`~stagger_nb.session.models.ModelBinding` writes the model into the session's op list (keeping
every op the editor does not own, in place) and sets the model back from it on undo/redo/load. Views observe the
model (``model.frame`` is the one playhead: the 3D view, every plot and the selected pose / edited frame follow it)
and the session (a new op list redraws them in place). No math and no threads here: heavy heads are warmed by
``Session.warm``.
"""
from __future__ import annotations

import weakref

import ipywidgets as widgets

from ..core.motion import Motion
from ..session import Session, joint_rotation_degrees
from ..session.models import ModelBinding, plain_message
from ._editor_playhead import _Playhead
from ._editor_status import _StatusLine
from ._lifecycle import _on_kernel_thread, _stop_work, _weakly, _widgets_under
from ._sizes import _WIDE, _share_layouts_and_styles
from .skeleton_view import SkeletonView

__all__ = ["_Editor"]


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


class _Editor(_StatusLine, _Playhead, widgets.VBox):
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
        model.observe(self._show_message, names=["message", "notes", "hint"])
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

    def _source_degrees(self, j: int):
        """The source's rotation vector of joint ``j`` in degrees, (F, 3): computed once per joint (and source)."""
        src, cache = self.__dict__.get("_source_deg", (None, None))
        if src is not self.session.source:
            cache = {}
            self._source_deg = (self.session.source, cache)
        if j not in cache:
            cache[j] = joint_rotation_degrees(self.session.source, j)
        return cache[j]

    def figures(self) -> list:
        """The plots' current figures as plotly JSON dicts (for ``export_html``)."""
        return [p.figure for p in self.plots]

    # -- session -> views ---------------------------------------------------------------------------
    def _on_session(self, session) -> None:
        self._update_buttons()
        self._refresh()

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
