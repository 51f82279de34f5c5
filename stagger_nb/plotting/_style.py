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


def base_layout(title: str, height: int, x_title: str = "time (s)", y_title: str = "", **extra) -> dict:
    """A layout that takes the width it is given (no ``width``: the view sizes it to its output area),
    a title on the left, the legend right of the axes, and a hover line along x so a
    click anywhere in the plot reports the nearest sample (the view uses it to seek)."""
    layout = dict(
        title=dict(text=title, x=0.01, xanchor="left", font=dict(size=14)),
        height=int(height), autosize=True,
        margin=dict(l=60, r=20, t=40, b=10, autoexpand=True),
        font=dict(size=12),
        showlegend=True,   # also with one trace: every curve is named
        # right of the axes, top-aligned: plotly widens the right margin for it, so it never covers the
        # x-axis title (a horizontal legend under the axes did at 260 px height)
        legend=dict(orientation="v", x=1.01, xanchor="left", y=1, yanchor="top", font=dict(size=11),
                    tracegroupgap=4),
        hovermode="x", hoverdistance=-1,
        xaxis=dict(title=dict(text=x_title), automargin=True, zeroline=False),
        yaxis=dict(title=dict(text=y_title), automargin=True),
        template="plotly_white",
        uirevision="keep",   # a user's zoom and legend clicks survive data updates
    )
    layout.update(extra)
    return layout


def vline(x: float, color: str, dash: str = "dash", width: float = 1.0, xref: str = "x") -> dict:
    """A vertical line shape at data x = ``x`` spanning the whole plot height."""
    return dict(type="line", xref=xref, yref="paper", x0=float(x), x1=float(x), y0=0, y1=1,
                line=dict(color=color, width=width, dash=dash), layer="below")
