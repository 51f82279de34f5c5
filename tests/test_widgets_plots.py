"""PlotView without a browser: the synced state a new view draws from, the typed-array wire format, the
shared plotly.js library, the playhead frame that is never echoed, clicks that seek."""
from __future__ import annotations

import base64
import json

import numpy as np
import pytest
import traitlets
from widget_messages import sends

from stagger_nb import plotting
from stagger_nb.widgets import FalloffPlot, JointCurvesPlot, PlotView, ProbabilityPlot, WarpPlot
from stagger_nb.widgets.plots import figure_to_json

T = np.arange(31) / 30


def _decode(spec):
    return np.frombuffer(base64.b64decode(spec["bdata"]), dtype="<" + spec["dtype"])


def test_state_holds_the_current_figure_as_typed_arrays():
    v = PlotView(plotting.falloff_figure(T, {"green": T}), frame_time=1 / 30)
    fig = plotting.falloff_figure(T, {"green": T ** 2, "isomap": 1 - T}, edited_times=[0.5])
    v.figure = fig
    state = v.store.get_state()["figure"]   # what every new view (e.g. after a page reload) draws
    assert "figure" not in v.get_state()   # only in the store: anywidget may drop kernel updates to the view
    assert v.get_state()["store"] == "IPY_MODEL_" + v.store.model_id
    assert [tr["name"] for tr in state["data"]] == ["Green's function", "ISOMAP distance", "edited frame"]
    # float32 on the wire: 7 significant digits are plenty to draw
    np.testing.assert_allclose(_decode(state["data"][0]["y"]), T ** 2, rtol=1e-6)
    assert state["data"][0]["x"]["dtype"] == "f4"
    assert state["layout"]["shapes"][0]["x0"] == 0.5
    with pytest.raises(traitlets.TraitError, match="figure"):
        v.figure = {"traces": []}
    with pytest.raises(traitlets.TraitError, match="frame_time"):
        v.frame_time = 0.0
    with pytest.raises(traitlets.TraitError, match="figure"):
        PlotView({"traces": []})
    v.frame_time, v.playhead_x, v.frame = 0.04, [0.0, 0.5], 1
    st = v.store.get_state()
    assert (st["frame_time"], st["playhead_x"], st["frame"]) == (0.04, [0.0, 0.5], 1)
    v.store.frame = 2   # a click in the browser seeks through the store
    assert v.frame == 2
    v.close()
    assert v.store.comm is None   # closing the view closes its store


def test_plotly_js_is_sent_on_request_never_in_the_state():
    v = PlotView(plotting.falloff_figure(T, {"green": T}))
    state, stored = v.get_state(), v.store.get_state()
    assert len(json.dumps(figure_to_json(state))) < 30_000   # the small module: no plotly.js
    assert len(json.dumps(figure_to_json(stored))) < 30_000   # the figure: no plotly.js
    assert "http" not in state["_esm"]   # no URL to fetch anything from
    sent = []
    orig = v.store.comm.send
    v.store.comm.send = lambda data=None, metadata=None, buffers=None: sent.append((data, buffers))
    try:   # what the browser's first view sends (to a store: its messages always arrive)
        v.store._handle_msg({"content": {"data": {"method": "custom", "content": {"event": "need_plotly"}}},
                             "buffers": []})
    finally:
        v.store.comm.send = orig
    (data, buffers), = sent
    from plotly.offline import get_plotlyjs
    assert data["content"] == {"event": "plotly.js"} and bytes(buffers[0]) == get_plotlyjs().encode()


def test_frame_from_the_browser_is_not_echoed_and_updates_are_one_message():
    v = PlotView(plotting.falloff_figure(T, {"green": T}), frame_time=1 / 30)
    log, stored = sends(v), sends(v.store)
    for f in range(1, 31):   # what a jsdlink from a Play widget sends during playback
        v.set_state({"frame": f})
    # drawn in the browser already: nothing goes back, and the store's kernel copy (what a reload draws) follows
    assert v.frame == 30 and log == [] and stored == [] and v.store.frame == 30
    stored.clear()
    v.store.set_state({"frame_time": 0.04})   # an echoed trait, for contrast: the check above can fail
    assert [m["method"] for m in stored] == ["echo_update"]
    stored.clear()
    v.figure = plotting.falloff_figure(T, {"green": 1 - T})
    v.frame = 3
    # the figure once (to the store), the frame to both (the view's model may be the one a jsdlink drives)
    assert [sorted(m["state"]) for m in stored] == [["figure"], ["frame"]]
    assert [sorted(m["state"]) for m in log] == [["frame"]]


def test_click_seeks_to_the_nearest_frame_and_reports():
    v = PlotView(frame_time=1 / 30)
    got = []
    v.on_click(lambda x, y, frame: got.append((x, y, frame)))
    assert v.click(0.51, 2.0) == 15 and v.frame == 15 and got == [(0.51, 2.0, 15)]
    v.playhead_x = [0.0, 0.5, 0.7, 1.4]   # e.g. a warp: input time of each output frame
    v.click(0.65)
    assert v.frame == 2
    # a click message from the browser (which sets frame itself) only calls the callbacks
    v.frame = 0
    v.store._handle_msg({"content": {"data": {"method": "custom", "content": {"event": "click", "x": 1.3,
                                                                                "y": None, "frame": 3}}},
                         "buffers": []})
    assert got[-1] == (1.3, None, 3) and v.frame == 0
    v.seek_on_click = False
    v.click(0.7)
    assert v.frame == 0


def test_deprecated_plot_classes_build_the_same_figures():
    jp = JointCurvesPlot(1 / 30)
    jp.update(T, np.stack([T, 2 * T, 3 * T], 1), np.zeros((31, 3)), pose_times=[0.2], knot_times=[0.25])
    ref = plotting.joint_curves_figure(T, np.stack([T, 2 * T, 3 * T], 1), np.zeros((31, 3)), T,
                                       pose_times=[0.2], knot_times=[0.25], height=jp.figure["layout"]["height"])
    np.testing.assert_allclose(jp.figure["data"][6]["y"], ref["data"][6]["y"])
    np.testing.assert_allclose(jp.figure["data"][3]["x"], T)
    pp = ProbabilityPlot(1 / 30)
    pp.update(T, np.sin(T), [0.1, 0.5], [0.3, 0.8], [0.5], [0.8])
    assert "1 of 2" in pp.figure["layout"]["title"]["text"]
    fp = FalloffPlot(1 / 30, sweep=2)
    fp.update(T, {"green": T}, frame=6)
    assert fp.figure["layout"]["shapes"][0]["x0"] == pytest.approx(0.2)
    wp = WarpPlot(1 / 30)
    wp.update(T, T, np.ones(31))
    got = []
    for p in (jp, pp, fp, wp):
        p.on_frame_click(got.append)
        p.click_time(0.5)
    assert got == [15] * 4
