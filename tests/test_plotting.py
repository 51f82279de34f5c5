"""Figure builders of stagger_nb.plotting without a browser: plotly accepts every figure (its validators
reject unknown properties), trace order and values are what the docstrings say, bad input names itself."""
from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
import pytest

from stagger_nb import plotting

T = np.arange(31) / 30   # 1 s at 30 fps


def _valid(fig: dict) -> go.Figure:
    assert set(fig) == {"data", "layout"}
    assert "width" not in fig["layout"]   # the view gives it the width of its output area
    return go.Figure(fig)   # raises ValueError on any property plotly does not know


def test_pose_probability_marks_candidates_and_kept_poses():
    f = plotting.pose_probability_figure(T, np.sin(T), [0.1, 0.5, 0.9], [0.3, 0.8, 0.4], [0.5], [0.8])
    g = _valid(f)
    assert [tr.mode for tr in g.data] == ["lines", "markers", "markers", "lines"]
    assert list(g.data[2].x) == [0.5] and "1 of 3" in g.layout.title.text
    # each kept pose also a vertical line across the plot (one trace on the 0..1 overlay axis)
    assert g.data[3].yaxis == "y2" and list(g.layout.yaxis2.range) == [0, 1]
    np.testing.assert_array_equal(g.data[3].x, [0.5, 0.5, np.nan])   # (nan: a gap)
    np.testing.assert_array_equal(g.data[3].y, [0, 1, np.nan])
    assert not g.layout.shapes
    empty = _valid(plotting.pose_probability_figure(None, None, [0.1], [0.3], [], []))
    assert len(empty.data[0].x) == 0
    with pytest.raises(ValueError, match="times, probability"):
        plotting.pose_probability_figure(T, None, [], [], [], [])
    with pytest.raises(ValueError, match="kept_times=1, kept_values=2"):
        plotting.pose_probability_figure(T, T, [], [], [0.1], [0.1, 0.2])


def test_joint_curves_knots_sit_on_the_edited_curves():
    edited = np.stack([T, 2 * T, 3 * T], 1)
    f = plotting.joint_curves_figure(T, edited, np.zeros((10, 3)), np.arange(10) / 10,
                                     pose_times=[0.2, 0.6], knot_times=[0.25])
    g = _valid(f)
    assert [tr.name for tr in g.data][:6] == ["x", "y", "z", "x original", "y original", "z original"]
    # one legend entry per component (edited and original toggle together), then the dotted "original",
    # the knots and the pose lines' entries
    assert [tr.name for tr in g.data if tr.showlegend is not False] == [
        "x", "y", "z", "knots t<sub>k</sub> + r<sub>kj</sub>", "original", "pose times t<sub>k</sub>"]
    np.testing.assert_allclose(g.data[1].y, 2 * T)
    np.testing.assert_allclose(g.data[6].y, [0.25, 0.5, 0.75])   # linear curves: interpolation is exact
    np.testing.assert_array_equal(g.data[8].x, [0.2, 0.2, np.nan, 0.6, 0.6, np.nan])   # the pose lines
    assert not g.layout.shapes
    assert g.layout.yaxis.title.text == "rotation (°)" and g.layout.xaxis.title.text == "time (s)"
    with pytest.raises(ValueError, match="edited_deg"):
        plotting.joint_curves_figure(T, edited[:5])
    with pytest.raises(ValueError, match="original_times"):
        plotting.joint_curves_figure(T, edited, edited)


def test_long_curves_are_decimated_without_losing_a_peak():
    """2,751 frames (CMU 01_01) drawn with <= 1200 points a curve: every bucket keeps its first, lowest, highest
    and last sample, so the drawn extremes and ends are the data's and any sample lies inside its bucket's range."""
    rng = np.random.default_rng(3)
    t = np.arange(2751) / 120
    y = np.cumsum(rng.normal(size=t.size))
    y[1234] = 500.0                                       # a one-frame spike
    x2, y2 = plotting.decimate(t, y)
    assert len(x2) <= 1200 and y2.max() == 500.0 and y2.min() == y.min()
    assert (x2[0], x2[-1], y2[0], y2[-1]) == (t[0], t[-1], y[0], y[-1])
    np.testing.assert_array_equal(y2, y[np.searchsorted(t, x2)])         # samples of the data, in order
    f = plotting.joint_curves_figure(t, np.stack([y, y, y], 1), np.stack([y, y, y], 1), t)
    assert all(len(tr["x"]) <= 1200 for tr in f["data"][:6])
    short = plotting.decimate(T, np.sin(T))
    assert short[0] is not None and len(short[0]) == len(T)


def test_falloff_every_curve_has_a_legend_and_the_edited_frames_are_marked():
    curves = {"spline": 1 - T, "green": T, "diffusion": T ** 2, "isomap": T / 2}
    f = plotting.falloff_figure(T, curves, edited_times=[0.2, 0.7], sweep=[("σ=1", T), ("σ=2", T)])
    g = _valid(f)
    assert [tr.meta for tr in g.data][:6] == ["green", "isomap", "diffusion", "spline", "sweep0", "sweep1"]
    assert all(tr.name and tr.showlegend is not False for tr in g.data)
    assert g.data[-1].name == "edited frames" and list(g.data[-1].x) == [None]   # names the vertical lines
    assert [s.x0 for s in g.layout.shapes] == [0.2, 0.7]
    assert len(_valid(plotting.falloff_figure(T, {"green": T})).data) == 1   # no edited frame, no entry
    with pytest.raises(ValueError, match=r"curves\['isomap'\]"):
        plotting.falloff_figure(T, {"isomap": T[:3]})


def test_warp_speed_is_clipped_on_a_labelled_log_axis():
    speed = np.array([0.01] + [1.5] * 29 + [50.0])
    f = plotting.warp_figure(T, 1.5 * T, speed, keytimes=[[0, 0], [1.5, 1.0]])
    g = _valid(f)
    assert list(g.data[3].y[:2]) == [0.1, 1.5] and g.data[3].y[-1] == 10.0
    assert g.layout.yaxis2.type == "log" and list(g.layout.yaxis2.ticktext) == ["0.1×", "0.5×", "1×", "2×", "10×"]
    assert list(g.data[2].x) == [0, 1.0] and list(g.data[2].y) == [0, 1.5]   # (input, output) -> x=output
    assert list(g.data[0].x) == [0, 1] and list(g.data[0].y) == [0, 1.5]      # the linear warp
    assert g.layout.xaxis2.title.text == "output time (s)" and g.layout.yaxis.title.text == "input time (s)"
    _valid(plotting.warp_figure(T, T, np.ones(31), keytimes=[]))
    with pytest.raises(ValueError, match="keytimes"):
        plotting.warp_figure(T, T, np.ones(31), keytimes=[[1, 2, 3]])
    with pytest.raises(ValueError, match="speed=3"):
        plotting.warp_figure(T, T, np.ones(3))


def test_time_plots_given_one_x_range_share_margins_and_range():
    """What lines an editor's playheads up: the same x range and the same left/right margins on every time
    plot (the legend under the axes widens nothing), whatever their titles, legends and y labels."""
    span = (0.0, 1.0)
    figs = [plotting.joint_curves_figure(T, np.stack([T, -100 * T, T], 1), pose_times=[0.2], x_range=span),
            plotting.pose_probability_figure(None, None, [0.1], [0.3], [], [], x_range=span),
            plotting.falloff_figure(T, {"green": T, "isomap": T, "spline": T}, edited_times=[0.5], x_range=span)]
    w = plotting.warp_figure(T, T, np.ones(31), x_range=span)
    for f in figs:
        g = _valid(f)
        assert list(g.layout.xaxis.range) == [0.0, 1.0] and g.layout.xaxis.autorange is False
        assert (g.layout.margin.l, g.layout.margin.r) == (figs[0]["layout"]["margin"]["l"],
                                                          figs[0]["layout"]["margin"]["r"])
        assert g.layout.legend.orientation == "h" and g.layout.legend.yref == "container"
    assert list(_valid(w).layout.xaxis2.range) == [0.0, 1.0]   # the drawn axis of the two rows
    # without a range the data's span, not plotly's padded autorange
    assert list(_valid(plotting.falloff_figure(T, {"green": T})).layout.xaxis.range) == [0.0, 1.0]
    with pytest.raises(ValueError, match="x_range"):
        plotting.falloff_figure(T, {"green": T}, x_range=(1.0, 1.0))


def test_a_backward_warps_speed_is_drawn_by_its_size_and_named_backward():
    """Browser review: the backward warp's speed plot looked blank (a negative speed on a log axis)."""
    from stagger_nb.plotting.views import warp_figure
    x = np.arange(10) / 30.0
    w = x[::-1].copy()
    fig = warp_figure(x, w, -np.ones(10))
    speed = fig["data"][3]
    assert speed["name"] == "speed (backward)" and np.allclose(speed["y"], 1.0)
    fwd = warp_figure(x, x, np.full(10, 2.0))["data"][3]
    assert fwd["name"] == "speed" and np.allclose(fwd["y"], 2.0)
