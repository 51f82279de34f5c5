"""The editors' recurring views as plotly figure dicts (pure functions, no browser, no widgets).

Glossary: F frames, K staggered poses, N output frames of a time warp, M keytimes. Times in seconds,
rotations as rotation vectors in degrees (x, y, z components). Every builder returns
``{"data": [...], "layout": {...}}`` whose trace order is fixed and documented (views and tests index it).

- :func:`pose_probability_figure` — P(t) with candidate and kept poses (Coleman et al. 2008, §4.1, Fig. 5).
- :func:`joint_curves_figure` — one joint's rotation, edited vs original, pose times and the joint's
  refinement knots ``t_k + r_{k,j}`` (Coleman et al. 2008, §3, Fig. 1/3).
- :func:`falloff_figure` — falloff from the edited frames: Green's function beside ISOMAP, diffusion and
  spline comparisons, optional σ sweep (Dean et al. 2018, Fig. 1, 3, 5).
- :func:`warp_figure` — a time warp (input time of each output frame) with keytimes, and its speed on a log
  axis (Hsu et al. 2007, §4 and Fig. 5).
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from ._style import (
    COMPONENT_COLOURS,
    EDIT_COLOUR,
    LEGEND_ROW,
    LINES_AXIS,
    METHOD_COLOURS,
    METHOD_NAMES,
    POSE_COLOUR,
    base_layout,
    data_span,
    decimate,
    floats,
    legend_line,
    same_length,
    vline,
    vlines_trace,
)

__all__ = ["pose_probability_figure", "joint_curves_figure", "falloff_figure", "warp_figure",
           "SPEED_LIMITS"]

REGION_COLOUR = METHOD_COLOURS["green"]   # a magic-wand region: the Green's falloff's colour
SPEED_LIMITS = (0.1, 10.0)   # speed axis range: tenfold slow motion to tenfold fast forward (Hsu et al. 2007, §4.3)


def pose_probability_figure(times, probability, candidate_times, candidate_values, kept_times, kept_values, *,
                            title: str | None = None, height: int = 240 + LEGEND_ROW, x_range=None,
                            region=None) -> dict:
    """Pose probability ``P(t)`` with the candidate poses and the staggered poses kept after culling.

    Parameters
    ----------
    times, probability : (F,) seconds and P(t) in [0, 1], or both None when the signal is not available
    candidate_times, candidate_values : (C,) seconds and P at each candidate pose (all peaks, §4.1)
    kept_times, kept_values : (K,) seconds and P at each kept (staggered) pose
    title : str, default "pose probability P(t): K of C candidate poses kept"
    x_range : (2,) seconds or None (the span of ``times``, else of the candidates); an editor gives all
        its time plots the same range so their playheads line up

    region : (K,) in [0, 1] or None
        The magic-wand region of a timing edit: the falloff at each kept pose (the scale of its timing offsets,
        Dean et al. 2018 §3.3 on Coleman et al. §5.2), drawn as trace 4, a shaded step line on the same [0, 1]
        axis.

    Traces: 0 ``P(t)`` line (at most ~1200 points: :func:`~.decimate`), 1 candidates (hollow circles),
    2 kept poses (filled diamonds), 3 their dotted vertical lines (one trace on the overlay axis ``y2``),
    4 the region (when given).
    """
    ct, cv = floats(candidate_times, "candidate_times"), floats(candidate_values, "candidate_values")
    kt, kv = floats(kept_times, "kept_times"), floats(kept_values, "kept_values")
    same_length(candidate_times=ct, candidate_values=cv)
    same_length(kept_times=kt, kept_values=kv)
    if (times is None) != (probability is None):
        raise ValueError("times, probability: give both or neither")
    if times is None:
        t, p = np.zeros(0), np.zeros(0)
    else:
        t, p = floats(times, "times"), floats(probability, "probability")
        same_length(times=t, probability=p)
    data = [
        dict(type="scatter", x=t, y=p, mode="lines", name="P(t)", line=dict(color="#2b6cb0", width=2)),
        dict(type="scatter", x=ct, y=cv, mode="markers", name=f"candidates ({len(ct)})",
             marker=dict(size=7, color="rgba(0,0,0,0)", line=dict(color="#4a5568", width=1.5)), cliponaxis=False),
        dict(type="scatter", x=kt, y=kv, mode="markers", name=f"staggered poses ({len(kt)})",
             marker=dict(size=10, color=POSE_COLOUR, symbol="diamond"), cliponaxis=False),
        vlines_trace(kt, POSE_COLOUR, "dot", showlegend=False),
    ]
    if len(t):
        data[0]["x"], data[0]["y"] = decimate(t, p)
    if region is not None:
        rw = floats(region, "region")
        same_length(kept_times=kt, region=rw)
        data.append(dict(type="scatter", x=kt, y=rw, mode="lines+markers", name="region (timing edits × weight)",
                         line=dict(color=REGION_COLOUR, width=1.5, shape="spline"), fill="tozeroy",
                         fillcolor="rgba(27,120,55,0.15)", marker=dict(size=5, color=REGION_COLOUR)))
    if title is None:
        title = f"pose probability P(t): {len(kt)} of {len(ct)} candidate poses kept"
    layout = base_layout(title, height, y_title="P(t)", x_range=x_range if x_range is not None else data_span(t, ct),
                         yaxis=dict(title=dict(text="P(t)", standoff=4), rangemode="tozero", automargin=True,
                                    hoverformat=".3g"), yaxis2=LINES_AXIS)
    return dict(data=data, layout=layout)


def joint_curves_figure(times, edited_deg, original_deg=None, original_times=None, *, pose_times=(),
                        knot_times=(), title: str | None = None, height: int = 280 + LEGEND_ROW,
                        x_range=None, pose_label: str = "pose times t<sub>k</sub>",
                        pose_colour: str = POSE_COLOUR) -> dict:
    """One joint's rotation over time as a rotation vector, edited (solid) against original (dotted).

    Parameters
    ----------
    times : (F,) seconds of ``edited_deg``
    edited_deg : (F, 3) rotation vector (x, y, z) of the joint in degrees, edited motion
    original_deg : (F0, 3) degrees or None; the original may have another length (time warps)
    original_times : (F0,) seconds of ``original_deg`` (required with it)
    pose_times : (K,) seconds, staggered pose times ``t_k`` drawn as dashed vertical lines
    knot_times : (K,) seconds, this joint's refinement knots ``t_k + r_{k,j}``, drawn on the edited curves
    x_range : (2,) seconds or None (the span of ``times``)
    pose_label, pose_colour : legend name and colour of the dashed vertical lines (e.g. "edited frames" in
        the wand editor, in the falloff plot's edited-frame colour ``plotting.EDIT_COLOUR``)

    Traces: 0–2 edited x, y, z; 3–5 original x, y, z (empty when ``original_deg`` is None; each curve at most
    ~1200 points, :func:`~.decimate`: the same drawing at plot resolution); 6 knots; 7 "original
    (dotted)" legend entry (no data); 8 the pose lines (one trace on the overlay axis ``y2``). The legend shows
    x, y, z once each (a click hides a component, edited and original together).
    """
    t = floats(times, "times")
    e = floats(edited_deg, "edited_deg", ndim=2)
    if e.shape != (len(t), 3):
        raise ValueError(f"edited_deg: expected shape ({len(t)}, 3), got {e.shape}")
    if original_deg is not None:
        o = floats(original_deg, "original_deg", ndim=2)
        if original_times is None:
            raise ValueError("original_times: required with original_deg")
        ot = floats(original_times, "original_times")
        if o.shape != (len(ot), 3):
            raise ValueError(f"original_deg: expected shape ({len(ot)}, 3), got {o.shape}")
    else:
        o, ot = np.zeros((0, 3)), np.zeros(0)
    pt, kt = floats(pose_times, "pose_times"), floats(knot_times, "knot_times")
    data = [dict(type="scatter", **dict(zip("xy", decimate(t, e[:, i]))), mode="lines", name=c, legendgroup=c,
                 line=dict(color=col, width=2)) for i, (c, col) in enumerate(zip("xyz", COMPONENT_COLOURS))]
    data += [dict(type="scatter", **dict(zip("xy", decimate(ot, o[:, i]))), mode="lines", name=f"{c} original",
                  legendgroup=c, showlegend=False, line=dict(color=col, width=1.2, dash="dot"))
             for i, (c, col) in enumerate(zip("xyz", COMPONENT_COLOURS))]
    if len(kt) and len(t):
        ky = np.stack([np.interp(kt, t, e[:, i]) for i in range(3)], axis=1)   # (K, 3) on the edited curves
        kx, ky = np.repeat(kt, 3), ky.reshape(-1)
    else:
        kx, ky = np.zeros(0), np.zeros(0)
    data.append(dict(type="scatter", x=kx, y=ky, mode="markers", name="knots t<sub>k</sub> + r<sub>kj</sub>",
                     marker=dict(symbol="diamond", size=7, color="#1a202c"), showlegend=bool(len(kx)),
                     cliponaxis=False))   # a knot at the clip's first or last frame is drawn whole
    data.append({**legend_line("original", "#4a5568", "dot"), "showlegend": bool(len(ot))})
    data.append(vlines_trace(pt, pose_colour, "dash", name=pose_label, showlegend=bool(len(pt))))
    layout = base_layout(title or "joint rotation: edited (solid) vs original (dotted)", height,
                         y_title="rotation (°)", x_range=x_range if x_range is not None else data_span(t, ot),
                         yaxis2=LINES_AXIS)
    return dict(data=data, layout=layout)


def falloff_figure(times, curves: Mapping[str, Sequence[float]], *, edited_times=(), sweep=None,
                   title: str | None = None, height: int = 260 + LEGEND_ROW, x_range=None) -> dict:
    """Falloff weights from the edited frames over the timeline, one named curve per method.

    Parameters
    ----------
    times : (F,) seconds
    curves : maps ``"green"`` / ``"isomap"`` / ``"diffusion"`` / ``"spline"`` to (F,) weights in [0, 1];
        missing names are left out. Other names are drawn too, after those four, named as given.
    edited_times : (E,) seconds of the edited frames, drawn as solid vertical lines (w = 1 there)
    sweep : list of ``(label, (F,) weights)``, drawn thin from blue (first) to orange (last), e.g. a σ sweep
        (Dean et al. 2018, Fig. 5)
    x_range : (2,) seconds or None (the span of ``times``)

    Traces: the present methods in the order green, isomap, diffusion, spline, others; then the sweep;
    last, the "edited frame" legend entry of the vertical lines (no data). Every curve has a legend entry.
    """
    t = floats(times, "times")
    names = [n for n in METHOD_COLOURS if n in curves] + [n for n in curves if n not in METHOD_COLOURS]
    data = []
    for n in names:
        y = floats(curves[n], f"curves[{n!r}]")
        same_length(times=t, **{f"curves[{n!r}]": y})
        data.append(dict(type="scatter", x=t, y=y, mode="lines", name=METHOD_NAMES.get(n, n), meta=n,
                         line=dict(color=METHOD_COLOURS.get(n), width=3 if n == "green" else 1.8)))
    sweep = list(sweep or [])
    for k, (label, y) in enumerate(sweep):
        y = floats(y, f"sweep[{k}]")
        same_length(times=t, **{f"sweep[{k}]": y})
        a = k / max(1, len(sweep) - 1)
        data.append(dict(type="scatter", x=t, y=y, mode="lines", name=str(label), meta=f"sweep{k}", opacity=0.8,
                         line=dict(width=1.2,
                                   color=f"rgb({int(40 + 200 * a)},{int(90 + 60 * a)},{int(220 - 180 * a)})")))
    et = floats(edited_times, "edited_times")
    if len(et):
        data.append(legend_line("edited frame" if len(et) == 1 else "edited frames", EDIT_COLOUR, "solid", 3))
    layout = base_layout(title or "falloff from the edited frame", height, y_title="weight",
                         x_range=x_range if x_range is not None else data_span(t),
                         yaxis=dict(title=dict(text="weight", standoff=4), range=[-0.05, 1.05], automargin=True,
                                    hoverformat=".3g"),
                         shapes=[vline(x, EDIT_COLOUR, "solid", 3) for x in et])
    return dict(data=data, layout=layout)


def warp_figure(out_times, warp, speed, *, keytimes=None, title: str | None = None, height: int = 420 + LEGEND_ROW,
                x_range=None, speed_limit: float | None = None) -> dict:
    """A time warp and its speed: top, input time against output time with the linear warp and the
    keytimes; bottom, the speed ``d(input)/d(output)`` on a log axis labelled 0.1×, 0.5×, 1×, 2×, 10× (clipped
    to [0.1, 10]; a backward warp's speed is negative: its size is drawn, named "speed (backward)").

    Parameters
    ----------
    out_times : (N,) seconds, output time of each output frame
    warp : (N,) seconds, input time shown at each output frame
    speed : (N,) dimensionless warp derivative (1 = original speed)
    keytimes : (M, 2) (input, output) seconds or None
    x_range : (2,) output seconds or None (the span of ``out_times``)
    speed_limit : float or None
        The guided warp's skip limit s (Hsu et al. 2007, §3.1: at most s input frames per output frame), drawn
        as a dashed line on the speed row (its axis grows to hold it); None: not drawn.

    Traces: 0 linear warp (dotted), 1 warp, 2 keytimes (legend entry only when there are some), 3 speed (on
    x2/y2), 4 the speed limit (when given). Both rows share the x axis, so a playhead at x = output time spans
    both. The legend sits under the lower row (it covers neither curve).
    """
    x, w, s = floats(out_times, "out_times"), floats(warp, "warp"), floats(speed, "speed")
    same_length(out_times=x, warp=w, speed=s)
    kt = np.zeros((0, 2)) if keytimes is None or np.size(keytimes) == 0 else floats(keytimes, "keytimes", ndim=2)
    if kt.shape[1:] != (2,):
        raise ValueError(f"keytimes: expected shape (M, 2), got {kt.shape}")
    lo, hi = SPEED_LIMITS
    if speed_limit is not None:
        speed_limit = float(speed_limit)
        if not (math.isfinite(speed_limit) and speed_limit > 0):
            raise ValueError(f"speed_limit: expected a positive number or None, got {speed_limit!r}")
        hi = max(hi, 1.25 * speed_limit)
    linear = dict(x=x[[0, -1]], y=w[[0, -1]]) if len(x) else dict(x=np.zeros(0), y=np.zeros(0))
    data = [
        dict(type="scatter", mode="lines", name="linear", line=dict(color="#a0aec0", dash="dot"), **linear),
        dict(type="scatter", x=x, y=w, mode="lines", name="warp", line=dict(color="#2b6cb0", width=2.5)),
        dict(type="scatter", x=kt[:, 1], y=kt[:, 0], mode="markers", name="keytimes", showlegend=bool(len(kt)),
             marker=dict(size=11, color=POSE_COLOUR, symbol="x-thin", line=dict(width=3, color=POSE_COLOUR)),
             cliponaxis=False),
        # a backward warp (input time running down) has a negative speed: its size is drawn (a log axis has no
        # negatives: it sat on the axis' floor and looked blank) and the legend says it runs backward
        dict(type="scatter", x=x, y=np.clip(np.abs(s), lo, hi), mode="lines", xaxis="x2", yaxis="y2",
             name="speed (backward)" if len(s) and np.nanmedian(s) < 0 else "speed",
             line=dict(color="#2f855a", width=2)),
    ]
    if speed_limit is not None:
        ends = [float(v) for v in (x_range if x_range is not None else data_span(x) or (0.0, 0.0))]
        data.append(dict(type="scatter", x=ends, y=[speed_limit, speed_limit], mode="lines", xaxis="x2", yaxis="y2",
                         name=f"fastest {speed_limit:g}×", hoverinfo="name",
                         line=dict(color="#c05621", width=1.5, dash="dash")))
    ticks = [0.1, 0.5, 1, 2, 10]   # five labels fit the lower row's ~120 px
    span = x_range if x_range is not None else data_span(x)
    layout = base_layout(title or "time warp", height, x_title="",
                         xaxis=dict(domain=[0, 1], anchor="y", matches="x2", showticklabels=False, automargin=True,
                                    zeroline=False),
                         yaxis=dict(domain=[0.48, 1], anchor="x", title=dict(text="input time (s)", standoff=4),
                                    automargin=True, hoverformat=".2f"),
                         xaxis2=dict(domain=[0, 1], anchor="y2", title=dict(text="output time (s)", standoff=4),
                                     automargin=True, zeroline=False, hoverformat=".2f"),
                         yaxis2=dict(domain=[0, 0.36], anchor="x2", type="log", range=[np.log10(lo), np.log10(hi)],
                                     tickvals=ticks, ticktext=[f"{v:g}×" for v in ticks],
                                     title=dict(text="speed", standoff=4), automargin=True, hoverformat=".2f"),
                         shapes=[dict(type="line", xref="x2 domain", yref="y2", x0=0, x1=1, y0=1, y1=1,
                                      line=dict(color="#a0aec0", width=1), layer="below")])
    if span is not None:   # both rows (x matches x2): the range is set on x2, the axis that is drawn
        lo_x, hi_x = base_layout("", 1, x_range=span)["xaxis"]["range"]
        layout["xaxis2"].update(range=[lo_x, hi_x], autorange=False)
    return dict(data=data, layout=layout)
