"""Shared look of every figure: fonts, margins, a legend below the axes, no fixed width.

Figures are plain plotly JSON dicts (``{"data": [...], "layout": {...}}``). Arrays stay numpy arrays (plotly
and :class:`stagger_nb.widgets.PlotView` both take them); nothing here touches a browser.
"""
from __future__ import annotations

import numpy as np

# one colour per rotation-vector component and per falloff method, used by every figure
COMPONENT_COLOURS = ("#d62728", "#2ca02c", "#1f77b4")
METHOD_COLOURS = {"green": "#1b7837", "isomap": "#d95f02", "diffusion": "#7570b3", "spline": "#4d4d4d"}
METHOD_NAMES = {"green": "Green's function", "isomap": "ISOMAP distance", "diffusion": "diffusion distance",
                "spline": "spline (time only)"}
POSE_COLOUR = "#dd6b20"
EDIT_COLOUR = "#b7791f"
# the papers' figures: one colour per curve, in order
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
           "#bcbd22", "#17becf")


def _colour(i: int, colours=None) -> str:
    return (colours[i] if colours is not None else PALETTE[i % len(PALETTE)])


def floats(a, name: str, ndim: int = 1) -> np.ndarray:
    """``a`` as a float array of ``ndim`` dimensions; ValueError naming ``name`` otherwise."""
    arr = np.asarray(a, dtype=float)
    if arr.ndim != ndim:
        raise ValueError(f"{name}: expected a {ndim}-D array, got shape {arr.shape}")
    return arr


def same_length(**arrays) -> None:
    """ValueError naming the arrays when their first dimensions differ."""
    lengths = {k: len(v) for k, v in arrays.items()}
    if len(set(lengths.values())) > 1:
        raise ValueError("lengths differ: " + ", ".join(f"{k}={n}" for k, n in lengths.items()))


# Every time plot of an editor has the same left/right margins and x range, so one frame is one x position
# down the column (the playheads line up). The y-axis labels fit in MARGIN_LEFT (automargin only grows it
# for unusually wide labels); the legend sits under the x axis, so it never changes the plot's width and
# never covers data.
MARGIN_LEFT, MARGIN_RIGHT, MARGIN_TOP = 64, 16, 34
LEGEND_ROW = 22   # px per legend row under the axes (11 px font); figures add it to their height


def base_layout(title: str, height: int, x_title: str = "time (s)", y_title: str = "", x_range=None,
                **extra) -> dict:
    """A layout that takes the width it is given (no ``width``: the view sizes it to its output area),
    a title on the left, fixed left/right margins, the legend in one or more rows under the x axis (its
    height is reserved below the axis titles: it widens nothing and covers nothing), and a hover line
    along x so a click anywhere in the plot reports the nearest sample (the view uses it to seek).

    ``x_range`` : (2,) seconds, the x axis range (editors give all their time plots the same one: the
    playheads line up); None lets plotly fit the data.
    """
    # hover labels read "1.23" s and 3 significant digits, not float32 noise ("2.233333, 0.5840447")
    xaxis = dict(title=dict(text=x_title, standoff=4), automargin=True, zeroline=False, hoverformat=".2f")
    if x_range is not None:
        lo, hi = (float(v) for v in x_range)
        if not hi > lo:
            raise ValueError(f"x_range: expected (lo, hi) with hi > lo, got {x_range!r}")
        xaxis["range"] = [lo, hi]
        xaxis["autorange"] = False
    layout = dict(
        title=dict(text=title, x=0.01, xanchor="left", y=1, yanchor="top", yref="container",
                   pad=dict(t=8), font=dict(size=14)),
        height=int(height), autosize=True,
        margin=dict(l=MARGIN_LEFT, r=MARGIN_RIGHT, t=MARGIN_TOP, b=8, autoexpand=True),
        font=dict(size=12),
        showlegend=True,   # also with one trace: every curve is named
        # under the axes, anchored to the bottom of the figure (container coordinates): plotly reserves its
        # height below the x-axis title, so it never overlaps the axis or the data, at any height
        legend=dict(orientation="h", xref="paper", x=0, xanchor="left", yref="container", y=0,
                    yanchor="bottom", font=dict(size=11), tracegroupgap=0, itemwidth=30),
        hovermode="x", hoverdistance=-1,
        xaxis=xaxis,
        yaxis=dict(title=dict(text=y_title, standoff=4), automargin=True, hoverformat=".3g"),
        template="plotly_white",
        uirevision="keep",   # a user's zoom and legend clicks survive data updates
    )
    layout.update(extra)
    return layout


def legend_line(name: str, color: str, dash: str = "solid", width: float = 1.5, xaxis: str = "x",
                yaxis: str = "y") -> dict:
    """A trace with no data and a legend entry: names the vertical marker lines (shapes have no legend)."""
    return dict(type="scatter", x=[None], y=[None], mode="lines", name=name, hoverinfo="skip",
                line=dict(color=color, dash=dash, width=width), xaxis=xaxis, yaxis=yaxis)


def data_span(*arrays):
    """(lo, hi) of the first non-empty array, or None (an x range that covers the data)."""
    for a in arrays:
        a = np.asarray(a, dtype=float)
        if a.size and np.isfinite(a).any():
            lo, hi = float(np.nanmin(a)), float(np.nanmax(a))
            return (lo, hi) if hi > lo else (lo - 0.5, hi + 0.5)
    return None


#: a second y axis over the plot, 0 (bottom) .. 1 (top), for vertical lines drawn as one trace
LINES_AXIS = dict(overlaying="y", range=[0, 1], visible=False, fixedrange=True)


def vlines_trace(xs, color: str, dash: str = "dash", width: float = 1.0, name: str = "",
                 showlegend: bool = True) -> dict:
    """Vertical lines at ``xs`` spanning the plot height, as ONE scatter trace on the overlay axis ``y2``
    (the layout needs ``yaxis2=LINES_AXIS``): plotly redraws one trace of a few hundred points much faster than
    dozens of shapes (a 43-pose clip: ~30 % of a joint-curves redraw). Its legend entry names the lines."""
    x = np.repeat(np.asarray(xs, dtype=float), 3)
    x[2::3] = np.nan
    y = np.tile([0.0, 1.0, np.nan], len(x) // 3)
    return dict(type="scatter", x=x if len(x) else [None], y=y if len(y) else [None], yaxis="y2", mode="lines",
                name=name, hoverinfo="skip", showlegend=showlegend, line=dict(color=color, dash=dash, width=width))


def decimate(x, y, max_points: int = 1200):
    """``(x, y)`` of a line with at most about ``max_points`` points that draws the same at plot resolution:
    each of ``max_points / 4`` buckets keeps its first, lowest, highest and last sample (so no peak is lost).
    Shorter lines are returned as they are."""
    x, y = np.asarray(x), np.asarray(y)
    n = len(x)
    if n <= max_points:
        return x, y
    size = -(-n // (max_points // 4))                         # samples per bucket (the last may be shorter)
    nb = -(-n // size)
    yy = np.where(np.isfinite(y), y, 0.0)
    grid = np.concatenate([yy, np.full(nb * size - n, yy[-1])]).reshape(nb, size)   # padded with the last value
    start = np.arange(nb) * size
    keep = np.concatenate([start, np.minimum(start + size - 1, n - 1), start + grid.argmin(axis=1),
                           start + grid.argmax(axis=1)])
    keep = np.unique(np.minimum(keep, n - 1))
    return x[keep], y[keep]


def vline(x: float, color: str, dash: str = "dash", width: float = 1.0, xref: str = "x") -> dict:
    """A vertical line shape at data x = ``x`` spanning the whole plot height."""
    return dict(type="line", xref=xref, yref="paper", x0=float(x), x1=float(x), y0=0, y1=1,
                line=dict(color=color, width=width, dash=dash), layer="below")
