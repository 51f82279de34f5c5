"""Figure builders for the tutorials: the papers' figures as plotly figure dicts (pure functions, no browser).

Glossary: F frames, J joints, K staggered poses, D degrees of freedom (curves), N output frames of a warp.
Times in seconds, positions in the clip's units (cm for the sample clips), angles in degrees. Every builder
returns ``{"data": [...], "layout": {...}}`` whose trace order is documented; notebooks show one with
``plotly.io.show(fig)`` or ``go.Figure(fig)``.

- :func:`skeleton_strobe_figure` — skeletons at several frames, side by side (Coleman Fig. 6/8, Dean Fig. 4).
- :func:`lines_figure` — named curves, each with its own x, optional stacking, vertical markers and
  highlighted samples (evidence signals Fig. 4, elbow angles Fig. 7, root heights, ankle paths).
- :func:`knots_figure` — D curves with their knots, aligned or staggered (Coleman Fig. 1/2).
- :func:`spline_displacement_figure` — data, spline, knots and displacement map of one channel (Coleman Fig. 3).
- :func:`heatmap_figure` — a (rows, columns) table of numbers, e.g. timing refinements in ms.

In :mod:`.papers_compare` (re-exported here):

- :func:`distance_figure` — pose distances from a control frame, with an optional zoom panel (Dean Fig. 1–3, 5).
- :func:`speeds_figure` — warp speeds on a readable log axis, one row per warp (Hsu Fig. 5).
- :func:`support_figure` — left / right single-support bands per motion (Hsu V7, the limp).
- :func:`table_figure` — a table (Hsu Table 1).
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ._style import PALETTE, POSE_COLOUR, _colour, base_layout, floats, same_length, vline
from .papers_compare import distance_figure, speeds_figure, support_figure, table_figure

__all__ = ["skeleton_strobe_figure", "lines_figure", "knots_figure", "spline_displacement_figure",
           "heatmap_figure", "distance_figure", "speeds_figure", "support_figure", "table_figure", "PALETTE"]

def _repeat_line(colour: str, k: int) -> dict:
    """The line of the ``k``-th trace given ``colour`` (0 = the first): a colour given twice (original / edited
    pairs) is told apart, in the drawing and in the legend, by a darker shade and a dash."""
    if k == 0:
        return dict(width=5, color=colour)
    from plotly.colors import hex_to_rgb, unlabel_rgb
    rgb = hex_to_rgb(colour) if colour.startswith("#") else unlabel_rgb(colour)
    f = 0.6 ** k
    shade = "rgb({},{},{})".format(*(int(round(c * f + 26 * (1 - f))) for c in rgb))
    return dict(width=5, color=shade, dash=_DASHES[k % len(_DASHES)])


def skeleton_strobe_figure(positions, parents, frames, *, colors=None, names=None, shift=None,
                           view: str = "side", title: str = "", height: int = 420) -> dict:
    """Skeletons at several frames as 3D line drawings (a strobe), orthographic, Y up.

    Parameters
    ----------
    positions : (F, J, 3) world joint positions (from ``sn.forward_kinematics``), clip units
    parents : (J,) parent index of each joint, root = -1
    frames : (S,) frame indices to draw (one trace each)
    colors, names : S colours / legend names (default: palette, ``"frame f"``)
    shift : (S, 3) offset added to each drawn skeleton (to place poses side by side), or None
    view : ``"side"`` (camera on +x), ``"front"`` (on +z) or ``"top"`` (on +y)
    height : the figure's largest height, px; a wide strobe gets less (as tall as its drawing needs)

    Traces: one ``scatter3d`` polyline per drawn frame, bones separated by gaps; a colour given to several
    frames is drawn as given, then darker and dashed, then darker still and dotted (the legend tells them apart).
    """
    p = floats(positions, "positions", ndim=3)
    if p.shape[2] != 3:
        raise ValueError(f"positions: expected shape (F, J, 3), got {p.shape}")
    par = np.asarray(parents, dtype=int)
    if par.shape != (p.shape[1],):
        raise ValueError(f"parents: expected shape ({p.shape[1]},), got {par.shape}")
    fr = np.asarray(frames, dtype=int).reshape(-1)
    if fr.size and (fr.min() < 0 or fr.max() >= len(p)):
        raise ValueError(f"frames: indices must lie in [0, {len(p)}), got {fr.min()}..{fr.max()}")
    off = np.zeros((len(fr), 3)) if shift is None else floats(shift, "shift", ndim=2)
    if off.shape != (len(fr), 3):
        raise ValueError(f"shift: expected shape ({len(fr)}, 3), got {off.shape}")
    if view not in ("side", "front", "top"):
        raise ValueError(f"view must be 'side', 'front' or 'top', got {view!r}")
    child = np.flatnonzero(par >= 0)
    data = []
    cols = [_colour(n, colors) for n in range(len(fr))]
    for n, f in enumerate(fr):
        seg = np.full((len(child), 3, 3), np.nan)           # parent, child, gap
        seg[:, 0] = p[f, par[child]] + off[n]
        seg[:, 1] = p[f, child] + off[n]
        seg = seg.reshape(-1, 3)
        data.append(dict(type="scatter3d", x=seg[:, 0], y=seg[:, 1], z=seg[:, 2], mode="lines",
                         name=str(names[n]) if names is not None else f"frame {f}",
                         line=_repeat_line(cols[n], cols[:n].count(cols[n]))))
    eye = {"side": dict(x=2.0, y=0.3, z=0.0), "front": dict(x=0.0, y=0.3, z=2.0),
           "top": dict(x=0.0, y=2.0, z=0.01)}[view]
    # the axis along the line of sight is seen end-on: its tick labels pile up in one spot (unreadable), so it
    # is drawn without labels; the vertical axis gets few ticks (a wide strobe is a short scene)
    depth = {"side": "xaxis", "front": "zaxis", "top": "yaxis"}[view]
    scene_px = _strobe_fit(data, view, int(height) - _STROBE_TITLE)
    scene = dict(aspectmode="data", camera=dict(up=dict(x=0, y=1, z=0), eye=eye,
                                                 projection=dict(type="orthographic")))
    # tick labels stay horizontal (plotly turns a 3D axis' labels to follow the axis: 90° on an orthographic view)
    scene[depth] = dict(showticklabels=False, title=dict(text=""), showspikes=False)
    # the axis letters ("x", "y", "z") say nothing here and the vertical one is drawn on top of its middle tick
    # label (notebook 02, Fig. 4: "1y0"): the scene goes without axis titles (units are the clip's, in the text)
    for ax in ("xaxis", "yaxis", "zaxis"):
        scene.setdefault(ax, {}).setdefault("title", dict(text=""))
        scene[ax]["tickangle"] = 0
    if view != "top":
        scene["yaxis"]["nticks"] = 4
    layout = dict(title=dict(text=title, x=0.01, xanchor="left", font=dict(size=14)),
                  height=scene_px + _STROBE_TITLE, margin=dict(l=0, r=0, t=_STROBE_TITLE, b=0),
                  template="plotly_white", showlegend=True, scene=scene)
    return dict(data=data, layout=layout)


# With aspectmode "data", plotly.js scales each axis by its range over the geometric mean G of the three ranges
# and draws an orthographic scene at ~0.41 px per scaled unit per px of scene height (plotly 7.1, measured: a
# 6-frame walk strobe, 700 x 160 x 40 cm, was drawn ~650 px wide in a 380 px high scene; 4 standing poses,
# 280 x 155 x 40 cm, ~360 px).
_STROBE_PX_PER_UNIT, _STROBE_TITLE = 0.41, 40
_DASHES = ("solid", "dash", "dot", "dashdot")
_STROBE_WIDTH, _STROBE_FILL, _STROBE_MIN = 620, 0.7, 160   # px drawn at most across, share of the height, px


def _strobe_fit(data, view: str, max_px: int) -> int:
    """The scene height (px) of a strobe, and its depth coordinates squeezed in place (``data`` is changed):
    the drawing fills the scene (<= 620 px across, ~70 % of its height: room for the tick labels) instead of a
    fixed 380 px scene with ~250 px empty above and below a wide strobe, or a strobe deep along the line of sight
    drawn at a third of the width. The depth axis is seen end-on (orthographic): squeezing it changes the picture's
    scale, not its content (hover shows the squeezed depth; its tick labels are hidden)."""
    h, v, d = {"side": "zyx", "front": "xyz", "top": "xzy"}[view]
    span = {}
    for k in "xyz":
        a = np.concatenate([np.asarray(tr[k], dtype=float) for tr in data]) if data else np.zeros(1)
        a = a[np.isfinite(a)]
        span[k] = float(np.ptp(a)) if a.size else 0.0
    r_h, r_v, r_d = max(span[h], 1e-6), max(span[v], 1e-6), span[d]
    scene = int(np.clip(_STROBE_WIDTH * r_v / (_STROBE_FILL * r_h), _STROBE_MIN, max(max_px, _STROBE_MIN)))
    # the geometric mean that draws the wider of (70 % of the height, 620 px across) exactly
    g = max(_STROBE_PX_PER_UNIT * r_v / _STROBE_FILL, _STROBE_PX_PER_UNIT * scene * r_h / _STROBE_WIDTH)
    want = g ** 3 / (r_h * r_v)          # the depth range that gives it
    if r_d > want > 0:
        for tr in data:
            a = np.asarray(tr[d], dtype=float)
            mid = np.nanmean(a) if np.isfinite(a).any() else 0.0
            tr[d] = mid + (a - mid) * (want / r_d)
    return scene


def lines_figure(series: Mapping[str, tuple], *, stacked: float | None = None, vlines=(), vline_color=POSE_COLOUR,
                 highlight: Mapping[str, tuple] | None = None, colors: Mapping[str, str] | None = None,
                 x_title: str = "time (s)", y_title: str = "", title: str = "", height: int = 320,
                 log_y: bool = False) -> dict:
    """Named curves, each ``name -> (x (F_i,), y (F_i,))``, drawn as lines in the given order.

    stacked : None, or a vertical step: curve i is raised by ``step * (n - 1 - i)`` and the y tick labels are
        hidden (evidence signals, Coleman Fig. 4)
    vlines : (V,) x positions drawn as dotted vertical lines (e.g. pose times)
    highlight : ``name -> (x (H,), y (H,))`` drawn as markers after the lines (e.g. airborne frames)
    colors : ``name -> colour`` (default: the palette in order)
    log_y : a log y axis

    Traces: one line per series, then one marker trace per highlight.
    """
    names = list(series)
    data = []
    for i, name in enumerate(names):
        x, y = series[name]
        x, y = floats(x, f"series[{name!r}] x"), floats(y, f"series[{name!r}] y")
        same_length(**{f"series[{name!r}] x": x, f"series[{name!r}] y": y})
        if stacked is not None:
            y = y + float(stacked) * (len(names) - 1 - i)
        data.append(dict(type="scatter", x=x, y=y, mode="lines", name=str(name),
                         line=dict(width=1.8, color=(colors or {}).get(name, _colour(i)))))
    for k, (name, (x, y)) in enumerate((highlight or {}).items()):
        x, y = floats(x, f"highlight[{name!r}] x"), floats(y, f"highlight[{name!r}] y")
        same_length(**{f"highlight[{name!r}] x": x, f"highlight[{name!r}] y": y})
        data.append(dict(type="scatter", x=x, y=y, mode="markers", name=str(name),
                         marker=dict(size=5, color=(colors or {}).get(name, PALETTE[(len(names) + k) % 10]))))
    yaxis = dict(title=dict(text=y_title), automargin=True)
    if stacked is not None:
        yaxis["showticklabels"] = False
    if log_y:
        yaxis["type"] = "log"
    layout = base_layout(title, height, x_title=x_title, y_title=y_title, yaxis=yaxis,
                         shapes=[vline(v, vline_color, "dot") for v in floats(vlines, "vlines")])
    return dict(data=data, layout=layout)


def knots_figure(times, curves, knot_times, knot_values, *, names=None, pose_times=(), title: str = "",
                 height: int = 340) -> dict:
    """D degrees of freedom over time with their knots (Coleman et al. 2008, Fig. 1 and 2).

    Parameters
    ----------
    times : (F,) seconds
    curves : (D, F) value of each degree of freedom (degrees)
    knot_times : (K, D) seconds, the knot of each pose on each curve: all equal to ``t_k`` for aligned
        poses (Fig. 1a), ``t_k + r_{k,i}`` for staggered ones (Fig. 1b)
    knot_values : (K, D) value at each knot (degrees)
    names : D legend names
    pose_times : (K,) seconds drawn as dashed vertical lines

    Traces: D curves, then D knot-marker traces (same colour as their curve).
    """
    t = floats(times, "times")
    c = floats(curves, "curves", ndim=2)
    kt, kv = floats(knot_times, "knot_times", ndim=2), floats(knot_values, "knot_values", ndim=2)
    if c.shape[1] != len(t):
        raise ValueError(f"curves: expected shape (D, {len(t)}), got {c.shape}")
    if kt.shape != kv.shape or kt.shape[1] != c.shape[0]:
        raise ValueError(f"knot_times, knot_values: expected equal shapes (K, {c.shape[0]}), got {kt.shape}, "
                         f"{kv.shape}")
    names = [f"dof {i}" for i in range(len(c))] if names is None else list(names)
    data = [dict(type="scatter", x=t, y=c[i], mode="lines", name=names[i], legendgroup=names[i],
                 line=dict(width=1.8, color=_colour(i))) for i in range(len(c))]
    data += [dict(type="scatter", x=kt[:, i], y=kv[:, i], mode="markers", name=f"{names[i]} knots",
                  legendgroup=names[i], showlegend=False,
                  marker=dict(size=9, color=_colour(i), line=dict(width=1, color="#1a202c")))
             for i in range(len(c))]
    layout = base_layout(title, height, y_title="value (°)",
                         shapes=[vline(x, POSE_COLOUR) for x in floats(pose_times, "pose_times")])
    return dict(data=data, layout=layout)


def spline_displacement_figure(times, data_deg, spline_deg, knot_times, knot_deg, displacement_deg, *,
                               title: str = "", height: int = 440) -> dict:
    """One rotation channel: the data, the spline through the knots and the displacement map below
    (Coleman et al. 2008, §4.1.1, Fig. 3: ``v(t) = s(t') ⊕ d(t')``).

    Parameters
    ----------
    times : (F,) seconds
    data_deg, spline_deg, displacement_deg : (F,) degrees: the captured channel, the spline alone
        (displacement maps set to zero), and the displacement map
    knot_times, knot_deg : (K,) seconds and degrees of this joint's knots at ``t_k + r_{k,i}``

    Traces: 0 data (dots), 1 spline, 2 knots (upper row, x/y); 3 displacement (lower row, x2/y2).
    """
    t = floats(times, "times")
    d, s, dm = floats(data_deg, "data_deg"), floats(spline_deg, "spline_deg"), floats(displacement_deg,
                                                                                        "displacement_deg")
    same_length(times=t, data_deg=d, spline_deg=s, displacement_deg=dm)
    kt, kv = floats(knot_times, "knot_times"), floats(knot_deg, "knot_deg")
    same_length(knot_times=kt, knot_deg=kv)
    data = [
        dict(type="scatter", x=t, y=d, mode="markers", name="motion data", marker=dict(size=3, color="#718096")),
        dict(type="scatter", x=t, y=s, mode="lines", name="spline s(t')", line=dict(color="#c53030", width=2)),
        dict(type="scatter", x=kt, y=kv, mode="markers", name="knots at t_k + r_k,i",
             marker=dict(size=9, color="#2b6cb0", symbol="diamond")),
        dict(type="scatter", x=t, y=dm, mode="lines", name="displacement d(t')", xaxis="x2", yaxis="y2",
             line=dict(color="#2f855a", width=1.8)),
    ]
    layout = base_layout(title, height, x_title="",
                         xaxis=dict(domain=[0, 1], anchor="y", matches="x2", showticklabels=False),
                         yaxis=dict(domain=[0.4, 1], anchor="x", title=dict(text="rotation (°)"), automargin=True),
                         xaxis2=dict(domain=[0, 1], anchor="y2", title=dict(text="time (s)")),
                         yaxis2=dict(domain=[0, 0.3], anchor="x2", title=dict(text="displacement (°)"),
                                     automargin=True))
    return dict(data=data, layout=layout)


def heatmap_figure(z, x_labels, y_labels, *, colorbar: str = "", title: str = "", x_title: str = "",
                   height: int = 560, zmid: float | None = 0.0) -> dict:
    """A table of numbers as a heat map: ``z`` (rows, columns) with row and column labels.

    Traces: 0 the heatmap (diverging colours centred on ``zmid``).
    """
    z = floats(z, "z", ndim=2)
    if z.shape != (len(y_labels), len(x_labels)):
        raise ValueError(f"z: expected shape ({len(y_labels)}, {len(x_labels)}), got {z.shape}")
    data = [dict(type="heatmap", z=z, x=[str(v) for v in x_labels], y=[str(v) for v in y_labels],
                 colorscale="RdBu", zmid=zmid, colorbar=dict(title=dict(text=colorbar)))]
    layout = base_layout(title, height, x_title=x_title, showlegend=False, hovermode="closest")
    return dict(data=data, layout=layout)
