"""Plot views: :class:`PlotView`, one plotly figure drawn by plotly.js in the browser, fed from Python.

Why a small view of our own rather than plotly's ``FigureWidget``: a FigureWidget keeps its browser state
(``_widget_data``) apart from the Python figure and updates views with one-shot messages, so a view created
later (a figure inside a box, a page reload) starts from stale or empty data unless private senders are
called (``_send_addTraces_msg``…), and it ships its 4.8 MB bundle with every instance. Here the whole figure
is one synced trait: every view, whenever it is created, draws the model's current ``figure`` with
``Plotly.react``; a change of ``figure`` redraws every view. Numpy arrays travel as plotly.js typed-array
specs (``{"dtype": "f4", "bdata": base64}``), not as JSON number lists. plotly.js itself (the installed
plotly package's bundle, never a CDN) is sent by the kernel once per page, as one binary message, to the
first view that asks; it is never part of the widget state, so restoring the widgets after a page
reload moves kilobytes, not megabytes (JupyterLab gives that restore 4 s before a slower fallback).

- ``view.figure = fig_dict``: plotly JSON ``{"data": [...], "layout": {...}}`` (builders in
  :mod:`stagger_nb.plotting`); replaced whole, redrawn in place (zoom and legend clicks are kept through
  ``layout.uirevision``).
- ``view.frame``: the playhead, a vertical red line at ``x = frame * frame_time`` or at
  ``playhead_x[frame]`` when ``playhead_x`` (one x per frame) is given; moved browser-side without a
  redraw. The frame trait is not echoed back to the browser (ipywidgets ``echo_update=False``): a
  ``jsdlink`` from a Play widget can drive it during playback without any kernel message out.
- a click sets ``view.frame`` to the nearest frame of the clicked x (seek; off with
  ``seek_on_click=False``) and calls the ``on_click(x, y, frame)`` callbacks.

The classes ``JointCurvesPlot``, ``ProbabilityPlot``, ``FalloffPlot`` and ``WarpPlot`` are PlotViews with
the former ``update(...)`` methods (deprecated: build with :mod:`stagger_nb.plotting` and assign
``view.figure``).
"""
from __future__ import annotations

import base64
from collections.abc import Callable

import anywidget
import ipywidgets as widgets
import numpy as np
import traitlets as t

from ..plotting import falloff_figure, joint_curves_figure, pose_probability_figure, warp_figure
from ._store_view import _FrameFromBrowser, store_view_esm

__all__ = ["PlotView", "PlotState", "plotly_js_bytes", "figure_to_json", "JointCurvesPlot", "ProbabilityPlot",
           "FalloffPlot",
           "WarpPlot"]

_JS = store_view_esm("plot_view.js")
_CSS = """
.sn-plot-view { width: 100%; max-width: 100%; min-width: 0; box-sizing: border-box; }
.sn-plot-view .sn-plot { width: 100%; max-width: 100%; }
"""
_TYPED = {"f": ("f4", np.float32), "i": ("i4", np.int32), "u": ("u4", np.uint32), "b": ("u1", np.uint8)}


def _typed_array(a: np.ndarray):
    """A 1-D numeric array as a plotly.js typed-array spec; other arrays as nested lists."""
    kind = a.dtype.kind
    if a.ndim != 1 or kind not in _TYPED:
        return a.tolist()
    if kind in "iu" and a.size and (a.max() > np.iinfo(np.int32).max or a.min() < np.iinfo(np.int32).min):
        return {"dtype": "f8", "bdata": base64.b64encode(np.ascontiguousarray(a, "<f8")).decode("ascii")}
    code, dt = _TYPED[kind]
    return {"dtype": code, "bdata": base64.b64encode(np.ascontiguousarray(a, dtype=np.dtype(dt).newbyteorder("<"))
                                                     ).decode("ascii")}


_PLAIN = (str, int, float, bool, type(None))


def figure_to_json(value, widget=None):
    """The JSON the browser gets for a figure dict: numpy arrays as typed-array specs (float32 for floats:
    ~7 significant digits, enough to draw), numpy scalars as numbers, tuples as lists.

    Plain leaves (str, int, float, bool, None) are kept without a call each (a StaggerEditor's joint-curve
    figure: 0.19 -> 0.10 ms per move)."""
    if isinstance(value, dict):
        return {k if type(k) is str else str(k): v if type(v) in _PLAIN else figure_to_json(v)
                for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [v if type(v) in _PLAIN else figure_to_json(v) for v in value]
    if isinstance(value, np.ndarray):
        return _typed_array(value)
    if isinstance(value, np.generic):
        return value.item()
    return value


_PLOTLY_JS: list = []   # the installed plotly.js bundle, UTF-8, read on first request


def plotly_js_bytes() -> bytes:
    """The installed plotly package's plotly.js bundle (what the views run), UTF-8 encoded."""
    if not _PLOTLY_JS:
        from plotly.offline import get_plotlyjs
        _PLOTLY_JS.append(get_plotlyjs().encode("utf-8"))
    return _PLOTLY_JS[0]


class _Checked(t.HasTraits):
    """The checks of a figure and a frame time (shared by the view and its state)."""

    @t.validate("frame_time")
    def _check_frame_time(self, proposal):
        if not proposal["value"] > 0:
            raise t.TraitError(f"frame_time: must be > 0 seconds, got {proposal['value']}")
        return proposal["value"]

    @t.validate("figure")
    def _check_figure(self, proposal):
        fig = proposal["value"]
        if set(fig) - {"data", "layout", "frames"} or not isinstance(fig.get("data", []), (list, tuple)):
            raise t.TraitError("figure: expected a plotly dict {'data': [...], 'layout': {...}}, got keys "
                               f"{sorted(fig)}")
        return fig


class PlotState(_Checked, widgets.Widget):
    """The synced state of one :class:`PlotView`: a data-only ipywidgets model (``WidgetModel`` of
    ``@jupyter-widgets/base``, no view of its own), which the browser view reads and observes.

    Why apart from the anywidget model: anywidget 0.11 gives each model 2 s to load its module; a model
    that misses it (a busy page: two CPU hogs, a reload restoring a thousand models in one task) still
    renders its initial state, but drops every later message from the kernel (``_handle_comm_msg`` waits
    on the failed load), so its plot would keep stale data or never get plotly.js. A base ``WidgetModel``
    has no such step: kernel updates and the plotly.js answer always arrive.
    """

    figure = t.Dict().tag(sync=True, to_json=figure_to_json)
    frame = t.Int(0, min=0).tag(sync=True, echo_update=False)
    frame_time = t.Float(1 / 30).tag(sync=True)
    playhead_x = t.List(t.Float()).tag(sync=True)
    playhead_xref = t.Unicode("x").tag(sync=True)
    show_playhead = t.Bool(True).tag(sync=True)
    seek_on_click = t.Bool(True).tag(sync=True)


_MIRRORED = ("figure", "frame_time", "playhead_x", "playhead_xref", "show_playhead", "seek_on_click")


class PlotView(_FrameFromBrowser, _Checked, anywidget.AnyWidget):
    """A view of one plotly figure on plotly.js, fed from Python.

    Traits
    ------
    figure : dict, plotly JSON ``{"data": [...], "layout": {...}}``; numpy arrays allowed
    frame : int >= 0, the playhead frame (set by a click when ``seek_on_click``)
    frame_time : float > 0, seconds per frame: the playhead is drawn at ``x = frame * frame_time``
    playhead_x : list of float, optional x of each frame (for a plot whose x axis is not the frame's time,
        e.g. a warp's input time); clicks seek to the frame with the nearest x
    playhead_xref : str, the x axis the playhead is drawn on (``"x"``; ``"x2"`` for a lower subplot)
    show_playhead, seek_on_click : bool

    ``view.store`` (:class:`PlotState`) carries these to the browser (``frame`` also travels on the view
    itself, so a browser-side ``jsdlink`` to ``(view, "frame")`` moves the playhead without the kernel).
    """

    _esm = _JS
    _css = _CSS
    store = t.Instance(PlotState).tag(sync=True, **widgets.widget_serialization)
    figure = t.Dict()
    frame = t.Int(0, min=0).tag(sync=True, echo_update=False)
    frame_time = t.Float(1 / 30)
    playhead_x = t.List(t.Float())
    playhead_xref = t.Unicode("x")
    show_playhead = t.Bool(True)
    seek_on_click = t.Bool(True)

    def __init__(self, figure: dict | None = None, **kwargs):
        if figure is not None:
            kwargs["figure"] = figure
        own = {k: kwargs[k] for k in _MIRRORED + ("frame",) if k in kwargs}
        # the state model first (validated; its comm opens with the whole state), then the view that
        # refers to it: a browser creating the view finds the state already there
        super().__init__(store=PlotState(**own), **kwargs)
        store = self.store
        self._store_links = [t.dlink((self, k), (store, k)) for k in _MIRRORED]
        self._follow_store(store)   # a click in the browser seeks
        self._click_callbacks: list[Callable] = []
        store.on_msg(self._on_custom_msg)

    def close(self):
        """Close the view's model and its store."""
        links, self._store_links = getattr(self, "_store_links", None), None
        if links is not None:   # the first close (ipywidgets closes again on garbage collection)
            for link in links:
                link.unlink()
            self.store.unobserve(self._frame_from_store, names="frame")
            self.store.close()
        super().close()

    def on_click(self, callback: Callable[[float, float | None, int], None], remove: bool = False) -> None:
        """Call ``callback(x, y, frame)`` when the plot is clicked in a browser (x, y in data units of the
        clicked point; frame as for the seek)."""
        if remove:
            self._click_callbacks.remove(callback)
        else:
            self._click_callbacks.append(callback)

    def _on_custom_msg(self, _widget, content, _buffers) -> None:
        if not isinstance(content, dict):
            return
        if content.get("event") == "click":
            self.click(float(content["x"]), content.get("y"), seek=False)
        elif content.get("event") == "need_plotly":   # the first view of a page asks, once
            self.store.send({"event": "plotly.js"}, buffers=[plotly_js_bytes()])

    def frame_of_x(self, x: float) -> int:
        """The frame a click at data x seeks to (what the browser computes)."""
        if self.playhead_x:
            return int(np.argmin(np.abs(np.asarray(self.playhead_x) - x)))
        return max(0, int(round(x / self.frame_time)))

    def click(self, x: float, y: float | None = None, seek: bool = True) -> int:
        """What a click at data x does (the browser calls it; tests and code may too): seek (``frame``)
        when ``seek`` and ``seek_on_click``, then the ``on_click`` callbacks. Returns the frame."""
        frame = self.frame_of_x(x)
        if seek and self.seek_on_click:
            self.frame = frame
        for cb in list(self._click_callbacks):
            cb(x, y, frame)
        return frame

    # --- deprecated names of the FigureWidget views (kept while the editors switch) -----------------
    def on_frame_click(self, callback: Callable[[int], None]) -> None:
        """Deprecated: ``on_click`` with only the frame."""
        self.on_click(lambda x, y, frame: callback(frame))

    def click_time(self, seconds: float) -> None:
        """Deprecated: ``click(seconds)``."""
        self.click(seconds)

    def sync_state(self) -> None:
        """Deprecated no-op: every view draws the current figure."""


class JointCurvesPlot(PlotView):
    """Deprecated: ``PlotView(plotting.joint_curves_figure(...))``."""

    def __init__(self, frame_time: float, height: int = 280, **kwargs):
        self._height = height
        super().__init__(joint_curves_figure(np.zeros(0), np.zeros((0, 3)), height=height),
                         frame_time=frame_time, **kwargs)

    def update(self, times, edited_deg, original_deg=None, pose_times=None, knot_times=None, title=None) -> None:
        """See :func:`stagger_nb.plotting.joint_curves_figure`; the original is sampled every frame_time."""
        ot = None if original_deg is None else np.arange(len(original_deg)) * self.frame_time
        self.figure = joint_curves_figure(times, edited_deg, original_deg, ot,
                                          pose_times=() if pose_times is None else pose_times,
                                          knot_times=() if knot_times is None else knot_times,
                                          title=title, height=self._height)


class ProbabilityPlot(PlotView):
    """Deprecated: ``PlotView(plotting.pose_probability_figure(...))``."""

    def __init__(self, frame_time: float, height: int = 240, **kwargs):
        self._height = height
        super().__init__(pose_probability_figure(None, None, (), (), (), (), height=height),
                         frame_time=frame_time, **kwargs)

    def update(self, times, signal, candidate_times, candidate_values, kept_times, kept_values) -> None:
        """See :func:`stagger_nb.plotting.pose_probability_figure`."""
        self.figure = pose_probability_figure(None if signal is None else times, signal, candidate_times,
                                              candidate_values, kept_times, kept_values, height=self._height)


class FalloffPlot(PlotView):
    """Deprecated: ``PlotView(plotting.falloff_figure(...))``."""

    def __init__(self, frame_time: float, height: int = 260, sweep: int = 0, **kwargs):
        self._height = height
        super().__init__(falloff_figure(np.zeros(0), {}, height=height), frame_time=frame_time, **kwargs)

    def update(self, times, curves: dict, frame: int | None = None, sweep=None, title=None) -> None:
        """See :func:`stagger_nb.plotting.falloff_figure`; ``frame`` is the edited frame (index)."""
        self.figure = falloff_figure(times, curves, edited_times=() if frame is None else [frame * self.frame_time],
                                     sweep=sweep, title=title, height=self._height)


class WarpPlot(PlotView):
    """Deprecated: ``PlotView(plotting.warp_figure(...))``."""

    def __init__(self, frame_time: float, height: int = 420, **kwargs):
        self._height = height
        super().__init__(warp_figure(np.zeros(0), np.zeros(0), np.zeros(0), height=height),
                         frame_time=frame_time, **kwargs)

    def update(self, out_times, warp, speed, keytimes=None, title=None) -> None:
        """See :func:`stagger_nb.plotting.warp_figure`."""
        self.figure = warp_figure(out_times, warp, speed, keytimes=keytimes, title=title, height=self._height)
