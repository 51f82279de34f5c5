"""The tutorials' figure builders (stagger_nb.plotting.papers) without a browser: plotly validates every
figure, the drawn values are the given ones (or the documented transform of them), bad input names itself."""
from __future__ import annotations

import numpy as np
import plotly.graph_objects as go
import pytest

from stagger_nb import plotting

T = np.arange(31) / 30   # 1 s at 30 fps


def _valid(fig: dict) -> go.Figure:
    assert set(fig) == {"data", "layout"}
    return go.Figure(fig)   # raises ValueError on any property plotly does not know


def test_strobe_draws_every_bone_of_each_frame_once():
    # a 3-joint chain: root at the origin, child 10 up, grandchild 10 further; frame f shifts by f in x
    base = np.array([[0, 0, 0], [0, 10, 0], [0, 20, 0]], float)
    pos = np.stack([base + [f, 0, 0] for f in range(5)])
    f = plotting.skeleton_strobe_figure(pos, [-1, 0, 1], [1, 3], shift=[[0, 0, 0], [100, 0, 0]],
                                        names=["a", "b"], view="front")
    g = _valid(f)
    assert [tr.name for tr in g.data] == ["a", "b"] and all(tr.type == "scatter3d" for tr in g.data)
    x = np.asarray(g.data[1].x, dtype=float)
    assert np.allclose(x[~np.isnan(x)], 103)          # frame 3 (x = 3) shifted by 100, both bones
    assert np.isnan(x).sum() == 2                     # 2 bones: one gap after each
    assert g.layout.scene.camera.eye.z == 2.0         # front view
    for view in ("side", "front", "top"):   # the axis seen end-on (largest eye component) carries no labels
        sc = _valid(plotting.skeleton_strobe_figure(pos, [-1, 0, 1], [0], view=view)).layout.scene
        eye = {k: abs(sc.camera.eye[k]) for k in "xyz"}
        for k in "xyz":
            assert (sc[f"{k}axis"].showticklabels is False) == (k == max(eye, key=eye.get)), (view, k)
    with pytest.raises(ValueError, match="frames"):
        plotting.skeleton_strobe_figure(pos, [-1, 0, 1], [7])
    with pytest.raises(ValueError, match="parents"):
        plotting.skeleton_strobe_figure(pos, [-1, 0], [0])
    with pytest.raises(ValueError, match="view"):
        plotting.skeleton_strobe_figure(pos, [-1, 0, 1], [0], view="iso")


def test_strobe_tells_apart_frames_of_one_colour_and_keeps_tick_labels_level():
    """Notebook 01's Fig. 6 and 8 give an original and an edited pose the same colour twice: each repeat is drawn
    darker and dashed (so the legend's swatches differ), and no axis turns its tick labels (it showed them 90°)."""
    base = np.array([[0, 0, 0], [0, 10, 0], [0, 20, 0]], float)
    pos = np.stack([base + [f, 0, 0] for f in range(5)])
    cols = ["#90cdf4", "#805ad5", "#90cdf4", "#805ad5"]
    for view in ("side", "front"):
        g = _valid(plotting.skeleton_strobe_figure(pos, [-1, 0, 1], range(4), colors=cols, view=view))
        lines = [(tr.line.color, tr.line.dash) for tr in g.data]
        assert len(set(lines)) == 4, lines                           # four different legend swatches
        assert lines[0] == ("#90cdf4", None) and lines[2][1] == "dash" and lines[2][0] != "#90cdf4"
        assert all(g.layout.scene[f"{k}axis"].tickangle == 0 for k in "xyz")


def test_strobe_scene_is_as_tall_as_its_drawing_and_keeps_the_visible_coordinates():
    # six 170-unit figures 120 apart (front view: x across, y up, z the depth seen end-on, 200 deep)
    base = np.array([[0, 0, 0], [0, 170, 0], [30, 100, 200]], float)
    pos = np.stack([base + [120 * f, 0, 0] for f in range(6)])
    wide = plotting.skeleton_strobe_figure(pos, [-1, 0, 1], range(6), view="front")
    one = plotting.skeleton_strobe_figure(pos, [-1, 0, 1], [0], view="front", height=420)
    assert wide["layout"]["height"] < 300 <= one["layout"]["height"] <= 420   # a wide strobe: a short scene
    for f in (wide, one):
        for tr in f["data"]:   # what is seen (x, y) is the data; only the end-on depth may be squeezed
            got = np.asarray(tr["x"], float)
            assert np.isnan(got).sum() == 2 and np.nanmax(got) - np.nanmin(got) == 30
    z = np.asarray(wide["data"][0]["z"], float)
    assert 0 < np.nanmax(z) - np.nanmin(z) < 200   # squeezed: the 200-deep chain would shrink the drawing


def test_lines_stacking_offsets_and_highlights():
    f = plotting.lines_figure({"a": (T, np.zeros(31)), "b": (T[:5], np.ones(5))}, stacked=1.5, vlines=[0.2, 0.4],
                              highlight={"marks": ([0.1], [0.5])})
    g = _valid(f)
    assert [tr.mode for tr in g.data] == ["lines", "lines", "markers"]
    assert np.allclose(g.data[0].y, 1.5) and np.allclose(g.data[1].y, 1.0)   # first curve on top
    assert g.layout.yaxis.showticklabels is False and [s.x0 for s in g.layout.shapes] == [0.2, 0.4]
    assert _valid(plotting.lines_figure({"a": (T, T + 1)}, log_y=True)).layout.yaxis.type == "log"
    with pytest.raises(ValueError, match=r"series\['a'\] x=31, series\['a'\] y=3"):
        plotting.lines_figure({"a": (T, [1, 2, 3])})


def test_knots_figure_puts_each_knot_on_its_curve_in_the_curve_colour():
    curves = np.stack([np.sin(2 * np.pi * T), np.cos(2 * np.pi * T)])
    kt = np.array([[0.25, 0.3], [0.75, 0.5]])
    kv = np.stack([np.interp(kt[:, i], T, curves[i]) for i in range(2)], 1)
    g = _valid(plotting.knots_figure(T, curves, kt, kv, names=["hip", "knee"], pose_times=[0.25, 0.75]))
    assert len(g.data) == 4 and g.data[2].marker.color == g.data[0].line.color
    assert np.allclose(g.data[3].x, [0.3, 0.5]) and len(g.layout.shapes) == 2
    with pytest.raises(ValueError, match="knot_times, knot_values"):
        plotting.knots_figure(T, curves, kt[:, :1], kv[:, :1])
    with pytest.raises(ValueError, match="curves"):
        plotting.knots_figure(T[:5], curves, kt, kv)


def test_spline_displacement_rows():
    d = np.sin(T)
    g = _valid(plotting.spline_displacement_figure(T, d, 0.9 * d, [0.0, 1.0], [0.0, np.sin(1.0)], 0.1 * d))
    assert [tr.yaxis or "y" for tr in g.data] == ["y", "y", "y", "y2"]
    assert np.allclose(g.data[3].y, 0.1 * d)
    with pytest.raises(ValueError, match="spline_deg=5"):
        plotting.spline_displacement_figure(T, d, d[:5], [], [], d)


def test_heatmap_checks_its_labels():
    z = np.arange(6.0).reshape(2, 3)
    g = _valid(plotting.heatmap_figure(z, [0.1, 0.2, 0.3], ["hip", "knee"], colorbar="ms"))
    assert list(g.data[0].y) == ["hip", "knee"] and np.array_equal(np.asarray(g.data[0].z), z)
    with pytest.raises(ValueError, match=r"z: expected shape \(3, 3\)"):
        plotting.heatmap_figure(z, [1, 2, 3], ["a", "b", "c"])


def test_distance_zoom_panel_holds_the_window_around_the_control_frame():
    x = np.arange(40)
    curves = {"green": np.abs(x - 20) / 20, "isomap": ((x - 20) / 20) ** 2}
    g = _valid(plotting.distance_figure(x, curves, 20, zoom=3))
    assert len(g.data) == 4 and list(g.data[2].x) == list(range(17, 24))
    assert g.data[2].xaxis == "x2" and g.data[2].showlegend is False
    assert [s.x0 for s in g.layout.shapes] == [20, 20]
    swept = _valid(plotting.distance_figure(x, curves, 20, sweep=True))
    assert swept.data[0].line.color != swept.data[1].line.color and len(swept.data) == 2
    with pytest.raises(ValueError, match="control"):
        plotting.distance_figure(x, curves, 40)


def test_speeds_one_log_row_per_warp_with_readable_ticks():
    s = np.array([0.05, 0.5, 1.0, 3.0, 50.0])
    g = _valid(plotting.speeds_figure({"V4": (np.arange(5) / 30, s), "V8": (np.arange(3) / 30, [1, 1, 1])}))
    assert [tr.yaxis for tr in g.data] == ["y", "y2"]
    assert np.allclose(g.data[0].y, [0.1, 0.5, 1.0, 3.0, 10.0])      # clipped to tenfold
    assert g.layout.yaxis2.type == "log" and "0.25×" in g.layout.yaxis.ticktext
    assert g.layout.yaxis.domain[0] > g.layout.yaxis2.domain[1]       # rows do not overlap
    with pytest.raises(ValueError, match="warps"):
        plotting.speeds_figure({})


def test_support_bands_mark_only_the_support_frames():
    left = T < 0.3
    right = T > 0.7
    g = _valid(plotting.support_figure({"walk": (T, left, right), "limp": (T, right, left)}))
    assert len(g.data) == 4 and np.allclose(g.data[0].x, T[left]) and set(g.data[3].y) == {"limp"}
    assert [tr.showlegend for tr in g.data] == [True, True, False, False]
    with pytest.raises(ValueError, match="left"):
        plotting.support_figure({"walk": (T, left[:3], right)})


def test_table_rows_become_columns():
    g = _valid(plotting.table_figure(["a", "b"], [[1, "x"], [2, "y"]]))
    assert [list(c) for c in g.data[0].cells.values] == [["1", "2"], ["x", "y"]]
    with pytest.raises(ValueError, match="rows"):
        plotting.table_figure(["a", "b"], [[1]])


def test_table_is_as_tall_as_its_rows():
    # the default height grows by one row height per row (no fixed 320 px with empty space under 3 rows)
    h = [plotting.table_figure(["a"], [[i] for i in range(n)])["layout"]["height"] for n in (1, 3, 10)]
    assert h[1] - h[0] == 2 * (h[2] - h[1]) / 7 > 0 and h[1] < 200
    assert plotting.table_figure(["a"], [[1]], height=500)["layout"]["height"] == 500


def test_speeds_figure_of_six_warps_fits_a_screen():
    """Notebook 03's Fig. 5 (six warps) was 960 px tall at 150 px a row; it fits 620 px now, the rows keep
    readable ticks (0.1x, 1x, 10x) and their names, x ticks on the bottom row only."""
    t = np.arange(30) / 30
    g = _valid(plotting.speeds_figure({f"V{i}": (t, np.full(30, 1.0 + i)) for i in range(6)}))
    assert g.layout.height <= 640
    assert list(g.layout.yaxis.ticktext) == ["0.1×", "1×", "10×"]
    assert [a.text for a in g.layout.annotations] == [f"V{i}" for i in range(6)]
    assert g.layout.xaxis.showticklabels is False and g.layout.xaxis6.showticklabels is True
    doms = [g.layout[f"yaxis{'' if i == 0 else i + 1}"].domain for i in range(6)]
    assert all(a[0] > b[1] for a, b in zip(doms[:-1], doms[1:]))     # rows do not overlap
