"""plotly ``FigureWidget`` views, updated in place under ``batch_update()`` (never rebuilt).

Each view draws arrays it is given (no math here beyond unit conversion for display) and reports clicks
as frame indices through ``on_frame_click(callback)`` so an editor can move its 3D view there.

- :class:`JointCurvesPlot` — a joint's rotation curves (edited vs original) with the staggered pose
  times and the joint's refinement knots ``t_k + r_{k,j}`` (Coleman et al. 2008, §3, Fig. 1/3).
- :class:`ProbabilityPlot` — the pose probability signal with candidate and kept poses (§4.1, Fig. 5).
- :class:`FalloffPlot` — Green's-function falloff / distance curves and comparisons (Dean et al. 2018,
  Fig. 1, 3, 5).
- :class:`WarpPlot` — a time-warp curve and its derivative on a log scale (Hsu et al. 2007, Fig. 5).
"""
from __future__ import annotations

import logging
from typing import Callable

import numpy as np
import plotly.graph_objects as go
from plotly.subplots import make_subplots

__all__ = ["JointCurvesPlot", "ProbabilityPlot", "FalloffPlot", "WarpPlot"]

_log = logging.getLogger(__name__)
_REPAIR_SKIPPED: list = []  # non-empty once the missing-private-method warning was given

_COMPONENT_COLOURS = ("#e53e3e", "#38a169", "#3182ce")
_COMPARISON_COLOURS = {"green": "#2f855a", "isomap": "#c05621", "diffusion": "#6b46c1", "spline": "#718096"}


PLOT_WIDTH = 520  # px: a 3D view and a plot side by side fit JupyterLab's default notebook width


def _layout(title: str, height: int, **kw) -> dict:
    return dict(title=dict(text=title, font=dict(size=13)), height=height, width=PLOT_WIDTH,
                margin=dict(l=50, r=10, t=35, b=35), legend=dict(orientation="h", y=-0.25), **kw)


def _same(a, b) -> bool:
    if a is b:
        return True
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and a.dtype.kind == b.dtype.kind and bool(np.array_equal(a, b))
    return a == b


class _ClickablePlot:
    """Common part: a FigureWidget whose traces report clicked x (seconds) as frame indices, and which sets
    a property only when its value changed (plotly validates every assignment: skipping the unchanged ones
    keeps a slider move cheap)."""

    def __init__(self, fig: go.FigureWidget, frame_time: float):
        self.figure = fig
        self.frame_time = float(frame_time)
        self._callbacks: list[Callable] = []
        self._last: dict = {}
        self.repairs = 0  # views repaired by _on_view_rendered
        self._wire_clicks()
        # before plotly's own handler of the same report: that one raises KeyError on the empty delta of
        # a trace the view never drew, and the observers after it would not run
        own = getattr(type(fig), "_handler_js2py_traceDeltas", None)
        if own is not None:
            fig.unobserve(own, names="_js2py_traceDeltas")
        fig.observe(self._on_view_rendered, names="_js2py_traceDeltas")
        if own is not None:
            fig.observe(own, names="_js2py_traceDeltas")

    def _on_view_rendered(self, change) -> None:
        """Repair a front-end view drawn with fewer traces than the figure.

        A view reports one trace delta per trace of its model's data after its first draw; a trace the
        view did not draw gives an empty delta (no ``uid``), and the model's data may have arrived between
        the draw and the report, so the drawn traces are the deltas with a ``uid``. plotly's widget state
        (``_widget_data``/``_widget_layout``) is set only by ``FigureWidget._repr_mimebundle_``, and edits
        made before a view exists travel as one-shot messages that view never sees (plotly.py #4933, fixed
        for a displayed figure by #4956); under load a view nested in a box can also be drawn before its
        model received the state, and then shows empty default axes. Such a view gets the missing traces
        and the layout again. This needs two private plotly methods (no public call re-sends traces without
        adding them to the Python figure); without them the repair is skipped and logged once (re-running
        the cell redraws the view). Messages go to every view of the figure: a second, complete view of
        the same figure would draw the re-sent traces twice."""
        msg = change.get("new") or {}
        if "trace_deltas" not in msg:  # plotly resets the trait to None after handling it
            return
        fig = self.figure
        drawn = [d for d in msg["trace_deltas"] if isinstance(d, dict) and "uid" in d]
        if len(drawn) < len(msg["trace_deltas"]):
            msg["trace_deltas"] = drawn  # the message plotly's handler reads next: empty deltas say nothing
        have = len(drawn)
        if have >= len(fig.data):
            return
        add = getattr(fig, "_send_addTraces_msg", None)
        relayout = getattr(fig, "_send_relayout_msg", None)
        if add is None or relayout is None:
            if not _REPAIR_SKIPPED:
                _REPAIR_SKIPPED.append(True)
                _log.warning("a plot view was drawn without its data and this plotly version offers no way to "
                             "re-send it; re-run the cell to redraw it")
            return
        from copy import deepcopy
        self.repairs += 1
        add([deepcopy(t) for t in fig._data[have:]])
        relayout(deepcopy(fig._layout))

    def _put(self, i, **props) -> None:
        """``figure.data[i].<prop> = value`` for the props whose value changed (call inside batch_update)."""
        tr = self.figure.data[i]
        for k, v in props.items():
            if isinstance(v, np.ndarray):
                v = np.array(v)  # own copy: the caller's array may be a view that changes later
            key = (i, k)
            if key in self._last and _same(self._last[key], v):
                continue
            self._last[key] = v
            setattr(tr, k, v)

    def _put_layout(self, **props) -> None:
        for k, v in props.items():
            key = ("layout", k)
            if key in self._last and _same(self._last[key], v):
                continue
            self._last[key] = v
            if k == "title":
                self.figure.layout.title.text = v
            else:
                setattr(self.figure.layout, k, v)

    def _wire_clicks(self):
        for tr in self.figure.data:
            tr.on_click(self._clicked)

    def sync_state(self) -> None:
        """Copy the figure's current data/layout into the widget state that a *new* front-end view renders
        from. plotly does this in ``FigureWidget._repr_mimebundle_`` only, i.e. when the figure itself is
        displayed (plotly.py #4956); inside an editor (a VBox) the editor calls this when it is displayed,
        through that same display hook (no private attributes of plotly touched here)."""
        self.figure._repr_mimebundle_()

    def on_frame_click(self, callback: Callable[[int], None]) -> None:
        """Call ``callback(frame_index)`` when a point of any trace is clicked."""
        self._callbacks.append(callback)

    def _clicked(self, trace, points, state=None):
        xs = getattr(points, "xs", None) or []
        if xs:
            self.click_time(float(xs[0]))

    def click_time(self, seconds: float) -> None:
        """What a click at x = ``seconds`` does (also callable from code and tests)."""
        frame = int(round(seconds / self.frame_time))
        for cb in self._callbacks:
            cb(frame)

    def _ipython_display_(self):  # pragma: no cover - display hook
        from IPython.display import display
        display(self.figure)


class JointCurvesPlot(_ClickablePlot):
    """Rotation of one joint over time as a rotation vector (x, y, z components, degrees): the edited
    motion solid, the original dotted; pose times as vertical lines and the joint's refinement knots as
    diamonds on the edited curve."""

    def __init__(self, frame_time: float, height: int = 260):
        fig = go.FigureWidget(layout=_layout("joint rotation (rotation vector, degrees)", height,
                                             xaxis_title="time (s)"))
        for c, col in zip("xyz", _COMPONENT_COLOURS):
            fig.add_scatter(x=[], y=[], mode="lines", name=f"{c} edited", line=dict(color=col))
        for c, col in zip("xyz", _COMPONENT_COLOURS):
            fig.add_scatter(x=[], y=[], mode="lines", name=f"{c} original", line=dict(color=col, dash="dot", width=1))
        fig.add_scatter(x=[], y=[], mode="markers", name="refinement knots",
                        marker=dict(symbol="diamond", size=8, color="#1a202c"))
        super().__init__(fig, frame_time)

    def update(self, times: np.ndarray, edited_deg: np.ndarray, original_deg: np.ndarray | None,
               pose_times: np.ndarray | None = None, knot_times: np.ndarray | None = None,
               title: str | None = None) -> None:
        """Redraw in place.

        Parameters
        ----------
        times : (F,) seconds of ``edited_deg`` (the original may have another length)
        edited_deg : (F, 3) rotation vector of the joint, degrees
        original_deg : (F0, 3) or None, sampled every ``frame_time`` seconds
        pose_times : (K,) seconds, drawn as vertical lines
        knot_times : (K,) seconds ``t_k + r_{k,j}`` for this joint, drawn on the edited curve
        """
        with self.figure.batch_update():
            for i in range(3):
                self._put(i, x=np.asarray(times, dtype=float), y=np.asarray(edited_deg[:, i], dtype=float))
            for i in range(3):
                if original_deg is None:
                    self._put(3 + i, x=(), y=())
                else:
                    self._put(3 + i, x=np.arange(len(original_deg)) * self.frame_time,
                              y=np.asarray(original_deg[:, i], dtype=float))
            if knot_times is not None and len(knot_times):
                kt = np.asarray(knot_times, dtype=float)
                ys = np.stack([np.interp(kt, times, edited_deg[:, i]) for i in range(3)], axis=1)
                self._put(6, x=np.repeat(kt, 3), y=ys.reshape(-1))
            else:
                self._put(6, x=(), y=())
            self._put_layout(shapes=tuple(dict(type="line", xref="x", yref="paper", x0=float(t), x1=float(t), y0=0,
                                               y1=1, line=dict(color="#dd6b20", width=1, dash="dash"))
                                          for t in (pose_times if pose_times is not None else [])))
            if title is not None:
                self._put_layout(title=title)


class ProbabilityPlot(_ClickablePlot):
    """The aggregate pose probability ``P(t)`` with all candidate peaks and the poses kept after culling
    (staggered poses, §4.1 and Fig. 5)."""

    def __init__(self, frame_time: float, height: int = 220):
        fig = go.FigureWidget(layout=_layout("pose probability P(t)", height, xaxis_title="time (s)"))
        fig.add_scatter(x=[], y=[], mode="lines", name="P(t)", line=dict(color="#2b6cb0"))
        fig.add_scatter(x=[], y=[], mode="markers", name="candidates",
                        marker=dict(size=7, color="rgba(0,0,0,0)", line=dict(color="#4a5568", width=1)))
        fig.add_scatter(x=[], y=[], mode="markers", name="kept poses", marker=dict(size=9, color="#dd6b20"))
        super().__init__(fig, frame_time)

    def update(self, times: np.ndarray | None, signal: np.ndarray | None,
               candidate_times: np.ndarray, candidate_values: np.ndarray,
               kept_times: np.ndarray, kept_values: np.ndarray) -> None:
        """``times, signal`` (F,) the sampled ``P(t)`` (None when not available); candidates and kept
        poses as (K,) times in seconds and probability values."""
        f = lambda a: np.asarray(a, dtype=float)  # noqa: E731
        with self.figure.batch_update():
            if signal is None:
                self._put(0, x=(), y=())
            else:
                self._put(0, x=f(times), y=f(signal))
            self._put(1, x=f(candidate_times), y=f(candidate_values))
            self._put(2, x=f(kept_times), y=f(kept_values))
            self._put_layout(title=f"pose probability P(t): {len(kept_times)} of "
                                   f"{len(candidate_times)} candidate poses kept")


class FalloffPlot(_ClickablePlot):
    """Falloff weights (or distances) from the edited frame over the timeline: Green's function and
    optional comparison curves (magic wand, Fig. 1/3), plus an optional σ sweep (Fig. 5)."""

    def __init__(self, frame_time: float, height: int = 240, sweep: int = 0):
        fig = go.FigureWidget(layout=_layout("falloff from the edited frame", height, xaxis_title="time (s)",
                                             yaxis=dict(range=[-0.05, 1.05])))
        for name, col in _COMPARISON_COLOURS.items():
            fig.add_scatter(x=[], y=[], mode="lines", name=name, line=dict(color=col, width=3 if name == "green" else 1.5),
                            visible=True if name == "green" else "legendonly")
        for k in range(sweep):
            fig.add_scatter(x=[], y=[], mode="lines", showlegend=False, line=dict(width=1), opacity=0.6)
        self._names = list(_COMPARISON_COLOURS)
        super().__init__(fig, frame_time)

    def update(self, times: np.ndarray, curves: dict, frame: int | None = None, sweep: list | None = None,
               title: str | None = None) -> None:
        """``curves`` maps ``"green" / "isomap" / "diffusion" / "spline"`` to (F,) values in [0, 1]; names
        missing are hidden. ``sweep``: list of ``(label, (F,) values)`` drawn thin (blue = small σ)."""
        times = np.asarray(times, dtype=float)
        with self.figure.batch_update():
            for i, name in enumerate(self._names):
                y = curves.get(name)
                if y is None:
                    self._put(i, x=(), y=())
                else:
                    self._put(i, x=times, y=np.asarray(y, dtype=float))
                    if name != "green":
                        self._put(i, visible=True)
            sweep = sweep or []
            n_sweep = len(self.figure.data) - len(self._names)
            for k in range(n_sweep):
                i = len(self._names) + k
                if k < len(sweep):
                    label, y = sweep[k]
                    a = k / max(1, n_sweep - 1)
                    self._put(i, x=times, y=np.asarray(y, dtype=float), name=label,
                              line=dict(color=f"rgb({int(40 + 200 * a)},{int(90 + 60 * a)},{int(220 - 180 * a)})",
                                        width=1))
                else:
                    self._put(i, x=(), y=())
            self._put_layout(shapes=() if frame is None else (
                dict(type="line", xref="x", yref="paper", x0=frame * self.frame_time, x1=frame * self.frame_time,
                     y0=0, y1=1, line=dict(color="#d69e2e", width=3)),))
            if title is not None:
                self._put_layout(title=title)


class WarpPlot(_ClickablePlot):
    """A time warp (input time of each output frame) and its derivative on a log scale, with the unit
    line and the tenfold slow-motion / fast-forward limits (guided time warping, Fig. 5)."""

    def __init__(self, frame_time: float, height: int = 380):
        fig = go.FigureWidget(make_subplots(rows=2, cols=1, shared_xaxes=True, vertical_spacing=0.12,
                                            subplot_titles=("warp: input time of each output frame",
                                                            "speed d(input)/d(output), log scale")))
        fig.add_scatter(x=[], y=[], mode="lines", name="linear", line=dict(color="#a0aec0", dash="dot"), row=1, col=1)
        fig.add_scatter(x=[], y=[], mode="lines", name="warp", line=dict(color="#2b6cb0"), row=1, col=1)
        fig.add_scatter(x=[], y=[], mode="markers", name="keytimes", marker=dict(size=9, color="#dd6b20"), row=1, col=1)
        fig.add_scatter(x=[], y=[], mode="lines", name="speed", line=dict(color="#2f855a"), row=2, col=1)
        fig.update_yaxes(type="log", range=[-1, 1], row=2, col=1)
        fig.update_xaxes(title_text="output time (s)", row=2, col=1)
        fig.update_layout(**_layout("time warp", height))
        super().__init__(fig, frame_time)

    def update(self, out_times: np.ndarray, warp: np.ndarray, speed: np.ndarray,
               keytimes: np.ndarray | None = None, title: str | None = None) -> None:
        """``out_times, warp`` (N,) seconds; ``speed`` (N,) the warp's derivative (dimensionless,
        drawn on a log axis clipped to [0.1, 10]); ``keytimes`` (M, 2) (input, output) seconds."""
        out_times = np.asarray(out_times, dtype=float)
        warp = np.asarray(warp, dtype=float)
        with self.figure.batch_update():
            if len(out_times):
                self._put(0, x=(float(out_times[0]), float(out_times[-1])), y=(float(warp[0]), float(warp[-1])))
            self._put(1, x=out_times, y=warp)
            kt = np.zeros((0, 2)) if keytimes is None else np.asarray(keytimes, dtype=float).reshape(-1, 2)
            self._put(2, x=kt[:, 1], y=kt[:, 0])
            self._put(3, x=out_times, y=np.clip(np.asarray(speed, dtype=float), 0.1, 10.0))
            self._put_layout(shapes=(dict(type="line", xref="x2", yref="y2", x0=float(out_times[0]),
                                          x1=float(out_times[-1]), y0=1, y1=1,
                                          line=dict(color="#a0aec0", width=1)),) if len(out_times) else ())
            if title is not None:
                self._put_layout(title=title)
