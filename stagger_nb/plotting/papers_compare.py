"""Figure builders for the tutorials' comparisons (pure functions, no browser; the conventions of
:mod:`.papers`: times in seconds, trace order documented, ``{"data": [...], "layout": {...}}``).

- :func:`distance_figure` — pose distances from a control frame, with an optional zoom panel (Dean Fig. 1–3, 5).
- :func:`speeds_figure` — warp speeds on a readable log axis, one row per warp (Hsu Fig. 5).
- :func:`support_figure` — left / right single-support bands per motion (Hsu V7, the limp).
- :func:`table_figure` — a table (Hsu Table 1).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ._style import _colour, base_layout, floats, same_length, vline
from .views import SPEED_LIMITS

__all__ = ["distance_figure", "speeds_figure", "support_figure", "table_figure"]

SPEED_TICKS = (0.1, 0.25, 0.5, 1, 2, 4, 10)


def _gradient(n: int) -> list[str]:
    """n colours from blue (first) to orange-red (last), for sweeps."""
    a = np.linspace(0, 1, max(n, 1))
    return [f"rgb({int(40 + 200 * v)},{int(90 + 40 * v)},{int(220 - 190 * v)})" for v in a][:n]



def distance_figure(x, curves: Mapping[str, Sequence[float]], control: int, *, zoom: int | None = None,
                    sweep: bool = False, x_title: str = "frame", title: str = "", height: int = 340) -> dict:
    """Normalised pose distances from a control frame (Dean et al. 2018, Fig. 1–3, 5).

    Parameters
    ----------
    x : (F,) frame numbers or seconds
    curves : ``name -> (F,)`` distances in [0, 1] (0 at the control frame)
    control : index of the control frame (drawn as a wide yellow bar, like the paper's figures)
    zoom : None, or a half-width in samples: a second panel shows ``control ± zoom`` with markers
    sweep : colour the curves from blue (first) to orange (last), e.g. a σ sweep (Fig. 5)

    Traces: one line per curve on the main panel, then (with ``zoom``) one per curve on x2/y2.
    """
    xx = floats(x, "x")
    if not 0 <= int(control) < len(xx):
        raise ValueError(f"control: must lie in [0, {len(xx)}), got {control}")
    cols = _gradient(len(curves)) if sweep else [_colour(i) for i in range(len(curves))]
    data = []
    ys = {}
    for i, (name, y) in enumerate(curves.items()):
        y = ys[name] = floats(y, f"curves[{name!r}]")
        same_length(x=xx, **{f"curves[{name!r}]": y})
        data.append(dict(type="scatter", x=xx, y=y, mode="lines", name=str(name), legendgroup=str(name),
                         line=dict(width=2, color=cols[i])))
    xc = float(xx[int(control)])
    shapes = [dict(vline(xc, "#ecc94b", "solid", 8), opacity=0.6)]
    extra = {}
    if zoom is not None:
        lo, hi = max(0, int(control) - int(zoom)), min(len(xx), int(control) + int(zoom) + 1)
        for i, (name, y) in enumerate(ys.items()):
            data.append(dict(type="scatter", x=xx[lo:hi], y=y[lo:hi], mode="lines+markers", name=str(name),
                             legendgroup=str(name), showlegend=False, xaxis="x2", yaxis="y2",
                             line=dict(width=2, color=cols[i]), marker=dict(size=5)))
        shapes.append(dict(vline(xc, "#ecc94b", "solid", 8, xref="x2"), opacity=0.6))
        extra = dict(xaxis=dict(domain=[0, 0.62], title=dict(text=x_title)),
                     xaxis2=dict(domain=[0.7, 1], anchor="y2", title=dict(text=f"{x_title} (zoom)")),
                     yaxis2=dict(anchor="x2", range=[-0.02, None], title=dict(text="")))
    layout = base_layout(title, height, x_title=x_title, y_title="normalised distance", shapes=shapes, **extra)
    return dict(data=data, layout=layout)


def speeds_figure(warps: Mapping[str, tuple], *, title: str = "", row_height: int | None = None,
                  height: int = 620) -> dict:
    """Warp speeds ``d(input)/d(output)`` on a log axis, one row per warp (Hsu et al. 2007, Fig. 5).

    warps : ``name -> (out_times (N,), speed (N,))``, seconds and dimensionless (1 = real time); speeds are
        clipped to [0.1, 10] and the axis is labelled 0.1×, 0.25×, 0.5×, 1×, 2×, 4×, 10×.

    row_height : px per row; default ``(height - 60) / rows`` capped at 150, so six warps take 620 px (it was
        150 px a row: 960 px, more than a 1280 x 800 screen shows).  Rows under 110 px get the ticks 0.1×, 1×,
        10× and their names as horizontal labels beside the row (a vertical axis title no longer fits).

    Traces: one line per warp, on axes x/y, x2/y2, ... (row i uses ``xaxis{i}``/``yaxis{i}``); the real-time
    line (1×) is a shape in each row.
    """
    n = len(warps)
    if n == 0:
        raise ValueError("warps: give at least one warp")
    if row_height is None:
        row_height = int(min(150, max(60, (int(height) - 60) / n)))
    small = row_height < 110
    ticks = (0.1, 1, 10) if small else SPEED_TICKS
    annotations = []
    lo, hi = SPEED_LIMITS
    gap = 0.08
    h = (1 - gap * (n - 1)) / n
    data, shapes, axes = [], [], {}
    for i, (name, (x, s)) in enumerate(warps.items()):
        x, s = floats(x, f"warps[{name!r}] out_times"), floats(s, f"warps[{name!r}] speed")
        same_length(**{f"warps[{name!r}] out_times": x, f"warps[{name!r}] speed": s})
        k = "" if i == 0 else str(i + 1)
        data.append(dict(type="scatter", x=x, y=np.clip(s, lo, hi), mode="lines", name=str(name),
                         xaxis=f"x{k}", yaxis=f"y{k}", line=dict(width=2, color=_colour(i))))
        top = 1 - i * (h + gap)
        axes[f"xaxis{k}"] = dict(domain=[0, 1], anchor=f"y{k}", automargin=True,
                                 title=dict(text="output time (s)" if i == n - 1 else ""),
                                 showticklabels=not small or i == n - 1)
        axes[f"yaxis{k}"] = dict(domain=[max(0.0, top - h), top], anchor=f"x{k}", type="log",
                                 range=[np.log10(lo), np.log10(hi)], tickvals=list(ticks),
                                 ticktext=[f"{v:g}×" for v in ticks], title=dict(text="" if small else str(name)),
                                 automargin=True)
        if small:   # the row's name at its top left, inside the plot (a rotated title would not fit the row)
            annotations.append(dict(xref=f"x{k} domain", yref=f"y{k} domain", x=0.005, y=0.98, xanchor="left",
                                    yanchor="top", showarrow=False, text=str(name), font=dict(size=12),
                                    bgcolor="rgba(255,255,255,0.8)"))
        shapes.append(dict(type="line", xref=f"x{k} domain", yref=f"y{k}", x0=0, x1=1, y0=1, y1=1,
                           line=dict(color="#a0aec0", width=1), layer="below"))
    layout = base_layout(title, row_height * n + 60, x_title="", shapes=shapes, showlegend=False, **axes)
    if annotations:
        layout["annotations"] = annotations
    return dict(data=data, layout=layout)


def support_figure(rows: Mapping[str, tuple], *, title: str = "", height: int | None = None) -> dict:
    """Left / right single-support phases over time, one band per motion (Hsu et al. 2007, V7: a limp).

    rows : ``name -> (times (F,), left (F,) bool, right (F,) bool)``: seconds, and whether only the left /
        only the right foot is on the ground in each frame.

    Traces: per row, 0 left support (blue bars), 1 right support (orange bars), drawn as horizontal
    markers at y = the row's name.
    """
    data = []
    for i, (name, (t, left, right)) in enumerate(rows.items()):
        t = floats(t, f"rows[{name!r}] times")
        lm, rm = np.asarray(left, dtype=bool), np.asarray(right, dtype=bool)
        same_length(**{f"rows[{name!r}] times": t, f"rows[{name!r}] left": lm, f"rows[{name!r}] right": rm})
        for mask, side, col in ((lm, "left foot only", "#2b6cb0"), (rm, "right foot only", "#dd6b20")):
            data.append(dict(type="scatter", x=t[mask], y=[str(name)] * int(mask.sum()), mode="markers",
                             name=side, legendgroup=side, showlegend=i == 0,
                             marker=dict(symbol="line-ns", size=16, line=dict(width=3, color=col), color=col)))
    height = height or 90 + 45 * len(rows)
    layout = base_layout(title, height, yaxis=dict(type="category", autorange="reversed", automargin=True))
    return dict(data=data, layout=layout)


_TABLE_TITLE, _TABLE_HEADER, _TABLE_ROW = 40, 48, 22   # px: title margin, header (two lines), one row


def table_figure(header: Sequence[str], rows: Sequence[Sequence], *, title: str = "",
                 height: int | None = None) -> dict:
    """A table (Hsu et al. 2007, Table 1): ``header`` (C,) and ``rows`` (R, C) of already formatted cells.

    height : px, or None: as tall as its rows (title + a header of up to two lines + R rows of 22 px), not a
        fixed 320 px that left ~170 px empty under a 3-row table at 1280x800.
    """
    rows = [list(r) for r in rows]
    if any(len(r) != len(header) for r in rows):
        raise ValueError(f"rows: every row needs {len(header)} cells")
    if height is None:
        height = _TABLE_TITLE + _TABLE_HEADER + _TABLE_ROW * len(rows) + 8
    columns = [[str(r[c]) for r in rows] for c in range(len(header))]
    data = [dict(type="table", header=dict(values=list(header)),
                 cells=dict(values=columns, height=_TABLE_ROW))]
    layout = dict(title=dict(text=title, x=0.01, xanchor="left", font=dict(size=14)), height=int(height),
                  margin=dict(l=10, r=10, t=40, b=0), template="plotly_white")
    return dict(data=data, layout=layout)
