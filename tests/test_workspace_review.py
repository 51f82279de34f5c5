"""The StaggerEditor's details a browser review found (issue 22, JupyterLab at 1280x800): the quality line reads
whole, a pose time's arrow keys move one frame and a refusal is said once, the edit-mode labels are whole, the
IK target sliders wait for an effector, the picked-poses list says what it does, the tools' tabs do not widen
the column, and "frame all" fills the view. Widget and model state only (the browser test of the same page:
tests/test_browser_workspace.py)."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest
from editor_helpers import from_browser

import stagger_nb as sn
from stagger_nb import scene3d
from stagger_nb.widgets import SkeletonView, StaggerEditor


@pytest.fixture
def editor():
    ed = StaggerEditor(sn.data.load("walk"), precompute=False)
    yield ed
    ed.close()


def _chromium_step(value: float, step: float, up: bool = True) -> float:
    """What Chromium's ``<input type=number step=...>`` (no min: the step base is 0) holds after ArrowUp /
    ArrowDown from ``value``: value ± step when ``value`` is on the step grid (to a float32's precision of a step:
    Chromium's StepRange::AcceptableError), else the nearest multiple above (up) or below (down)."""
    n = value / step
    if abs(n - round(n)) <= 2.0 ** -24:
        return (round(n) + (1 if up else -1)) * step
    return (math.floor(n) + 1 if up else math.ceil(n) - 1) * step


def test_arrow_keys_in_the_pose_time_box_move_one_frame_each_shown_at_the_displayed_precision(editor):
    ed, box = editor, editor.controls["pose_time"]
    ed.model.pose = 3
    lo, hi = ed.model.pose_time_range()
    ft = ed.session.source.frame_time
    assert box.step == pytest.approx(ft)
    start = box.value
    frames = [round(start / ft)]
    for up in (True,) * 4 + (False,) * 2:
        from_browser(box, value=_chromium_step(box.value, box.step, up))
        frames.append(round(box.value / ft))
        assert box.value == ed.model.pose_time                      # the box shows what the model holds
        assert box.value == round(box.value, 3)                     # 60 Hz: 3 decimals, no float tail
        assert abs(box.value - frames[-1] * ft) < 5e-4              # a frame's time, to the shown precision
    assert lo < box.value < hi
    assert np.diff(frames).tolist() == [1, 1, 1, 1, -1, -1]          # one frame per press, both ways
    assert ed.session.ops[-1] == {"op": "retime", "pose": 3, "time": box.value}


def test_a_typed_pose_time_passes_as_typed(editor):
    ed, box = editor, editor.controls["pose_time"]
    ed.model.pose = 3
    t = round((ed.model.pose_times[2] + 2 * ed.model.pose_times[3]) / 3, 4) + 0.0003   # between two frames
    from_browser(box, value=t)
    assert ed.model.pose_time == pytest.approx(t, abs=1e-3) and box.value == ed.model.pose_time


def test_a_refused_pose_time_is_said_once_under_its_field(editor):
    ed = editor
    ed.model.pose = 3
    from_browser(ed.controls["pose_time"], value=999.0)
    note, line = ed.pose_time_note.value, ed.message.value
    assert "pose time must lie between" in note and "999" in note
    assert "pose time must" not in line                              # not a second time in the message line
    from_browser(ed.controls["pose_time"], value=round(ed.model.pose_times[3] + 0.01, 3))   # a valid one clears it
    assert not ed.pose_time_note.value and "pose time" not in ed.message.value


def _parts(value: str) -> list:
    return re.findall(r'<span class="sn-quality-part" style="([^"]*)">(.*?)</span></span>', value)


def test_the_quality_line_wraps_between_whole_parts_in_two_lines_of_the_top_bar(editor):
    ed = editor
    ed.model.w_r = 2.0
    ed.model.s = 0.08                                                  # a strong edit: a long summary
    q = ed.model.quality
    parts = _parts(ed.quality.value)
    assert len(parts) == len(q["items"]) >= 3
    for style, _ in parts:                                            # each part moves to the next line whole
        assert "display:inline-block" in style
    box = re.search(r'<div title="[^"]*" style="([^"]*)"', ed.quality.value).group(1)
    assert "white-space:normal" in box and "ellipsis" not in box and "nowrap" not in box
    line_px = int(re.search(r"line-height:(\d+)px", box).group(1))
    assert re.search(r"max-height:(\d+)px", box).group(1) == str(2 * line_px) and 2 * line_px <= 28   # the buttons'
    assert ed.quality.tooltip == q["text"]                            # the whole summary on hover


def test_the_progress_bar_leaves_the_top_bar_while_idle(editor):
    ed = editor
    assert ed.progress.layout.display == "none"
    seen = []   # the bar as it is while the session's work runs (this listener is called after the editor's)
    ed.session.observe_busy(lambda kind, started: seen.append((kind, started, ed.progress.layout.display,
                                                               ed.progress.description)))
    ed.session.wand_graph()                                           # not computed yet: precompute=False
    assert seen == [("graph", True, None, "pose graph"), ("graph", False, "none", "pose graph")]
    assert ed.progress.layout.display == "none"


def test_the_tools_tabs_take_the_columns_width_without_side_margins(editor):
    lay = editor.tools.layout
    assert lay.width == "100%" and lay.margin.split()[1] in ("0", "0px")   # 100 % plus a margin scrolled sideways


def test_the_edit_mode_buttons_are_as_wide_as_their_labels(editor):
    assert editor.controls["edit_mode"].style.button_width == "auto"


def test_the_ik_target_sliders_wait_for_an_effector_and_say_so(editor):
    ed, c = editor, editor.controls
    sliders = [c["ik_" + a] for a in "xyz"]
    assert ed.model.ik_joint == "" and c["ik_joint"].label == "(none)"
    assert all(s.disabled and "choose an IK effector" in s.tooltip for s in sliders)
    assert ed.ik_hint.layout.display is None and "choose an IK effector" in ed.ik_hint.value
    from_browser(c["ik_joint"], index=1)                               # a foot
    assert ed.model.ik_joint and not any(s.disabled for s in sliders)
    assert ed.ik_hint.layout.display == "none" and all(ed.model.ik_joint in s.tooltip for s in sliders)
    from_browser(c["ik_joint"], index=0)                               # (none) again
    assert all(s.disabled for s in sliders) and ed.ik_hint.layout.display is None


def test_the_picked_poses_list_says_what_it_does(editor):
    ed, keep = editor, editor.controls["keep"]
    row = next(r for r in ed.tools.children[0].children if keep in r.children)
    hint = next(w for w in row.children if "sn-keep-hint" in w.get_state().get("_dom_classes", ()))   # as sent
    assert "probability plot" in hint.value and "select" in hint.value
    assert keep.disabled and "picked" in keep.tooltip                  # inert: how to use it
    ed.model.cull_by = "keep"
    assert not keep.disabled and "probability plot" in keep.tooltip    # active: what it does


# -- "frame all" ---------------------------------------------------------------------------------------------

def _brute_distance(corners, d, fov, aspect, margin):
    """The nearest distance along ``d`` at which every corner projects inside ``margin`` of the canvas, by
    bisection on :func:`scene3d.project` (the straightforward reference of the closed form)."""
    def fits(dist):
        eye = d * dist
        if np.any((corners - eye) @ (-d) <= 0):
            return False
        px = scene3d.project(corners, eye, (0, 0, 0), fov, 1000 * aspect, 1000)
        ndc = np.abs(px / [1000 * aspect, 1000] * 2 - 1)
        return bool(ndc.max() <= margin)
    lo, hi = 1e-6, 1e6
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        lo, hi = (lo, mid) if fits(mid) else (mid, hi)
    return hi


def test_frame_box_sees_the_box_from_its_nearest_side_by_brute_force():
    rng = np.random.default_rng(5)
    for _ in range(6):
        half = rng.uniform(0.2, 3.0, size=3)
        corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
        fov, aspect = rng.uniform(30, 60), rng.uniform(0.8, 2.0)
        d, dist = scene3d.frame_box(corners, fov, aspect)
        d0 = np.array([0.62, 0.28, 0.73]) / np.linalg.norm([0.62, 0.28, 0.73])
        assert d[1] == pytest.approx(d0[1]) and np.linalg.norm(d) == pytest.approx(1.0)   # the same elevation
        best = min(_brute_distance(corners, np.array([np.cos(a) * d0[0] + np.sin(a) * d0[2], d0[1],
                                                      -np.sin(a) * d0[0] + np.cos(a) * d0[2]]), fov, aspect, 0.94)
                   for a in np.radians(np.arange(0, 360, 10)))
        assert dist == pytest.approx(best, rel=1e-6)                  # bisection to 1e-6 relative


@pytest.mark.parametrize("name, least", [("cmu_01_01", 0.40), ("walk", 0.28), ("jump", 0.30)])
def test_frame_all_fills_the_view_with_the_clip_and_keeps_every_frame_inside(name, least):
    """The figure as large as the whole clip allows (figures measured on the 400x236 editor view: cmu_01_01
    0.47 of the canvas height, walk 0.33, jump 0.36; the bounding sphere's framing gave 0.27, 0.21, 0.21)."""
    m = sn.data.load(name)
    v = SkeletonView(m, width=400, height=236, camera="all")
    P = scene3d.skeleton_points(m)
    eye, target = v.camera_framing.world(0)
    px = scene3d.project(P.reshape(-1, 3), eye, target, v.camera_framing.fov, 400, 236)
    assert px.min() > 0 and px[:, 0].max() < 400 and px[:, 1].max() < 236       # every frame in view
    span = max((px[:, 0].max() - px[:, 0].min()) / 400, (px[:, 1].max() - px[:, 1].min()) / 236)
    assert span > 0.75                                                            # the clip fills the canvas
    heights = [v.drawn_height(f) for f in range(0, m.num_frames, max(1, m.num_frames // 40))]
    assert np.median(heights) >= least
    v.close()
