"""The editors' sliders and the page's grid (browser review, session 10): the page's slider snaps every value the
kernel gives it to ``min + n * step`` and sends the snapped value back as the user's. The kernel gives the
sliders values already on that grid, and takes a value equal to the slider's own up to float noise as no move:
the WarpEditor opens with nothing to undo, its segment slider does not flip between two frames for ever, and an
arrow step of a slider in seconds is not written back rounded (a press made meanwhile would start from it)."""
from __future__ import annotations

import ipywidgets as widgets
import pytest
from editor_helpers import from_browser, page_echoes, page_snap

import stagger_nb as sn


@pytest.fixture(scope="module")
def cmu_900():
    return sn.data.load("cmu_01_01").slice(0, 900)


@pytest.fixture(scope="module")
def walk():
    return sn.data.load("walk")


def _sliders(editor) -> dict:
    return {k: c for k, c in editor.controls.items()
            if isinstance(c, (widgets.FloatSlider, widgets.FloatRangeSlider))
            and not isinstance(c, widgets.FloatLogSlider)}


@pytest.mark.parametrize("clip", ["walk", "cmu_900"])
def test_the_warp_editor_opens_with_nothing_to_undo_after_the_pages_snaps(clip, request):
    from stagger_nb.widgets import WarpEditor
    m = request.getfixturevalue(clip)
    e = WarpEditor(m)
    try:
        echoes = {k: page_echoes(c) for k, c in _sliders(e).items()}
        assert set(echoes) >= {"duration", "segment"}
        assert all(n <= 1 for n in echoes.values()), echoes          # agreed at once, never flipping
        assert e.session.ops == [] and not e.session.can_undo and e.undo_button.disabled, e.session.ops
        assert e.model.duration == pytest.approx(m.duration, abs=1e-6)
        assert e.controls["skip"].disabled                         # the identity warp: skip cannot change it
        seg = list(e.model.segment)
        assert page_echoes(e.controls["segment"]) <= 1 and e.model.segment == seg
    finally:
        e.close()


def test_a_loaded_off_grid_value_is_snapped_by_the_page_once_not_stepped(walk):
    """A session's segment between two frames: the page's snap is taken as the nearest frame (not as an arrow step
    past it), and the page and the kernel then agree."""
    from stagger_nb.widgets import WarpEditor
    ft = walk.frame_time
    e = WarpEditor(walk)
    try:
        e.model.reference = "segment"
        e.model.segment = [0.0, round(10.4 * ft, 6)]
        assert page_echoes(e.controls["segment"]) <= 1
        assert round(e.model.segment[1] / ft) == 10          # the nearest frame (not 9: a step past it)
    finally:
        e.close()


def test_arrow_steps_on_the_wands_sliders_in_seconds_are_not_written_back(walk):
    """The edited-frame slider and the edit range (seconds on a frame grid): each press lands on the page's next
    grid point and the kernel leaves it there (a rounded write-back would be where a quick next press starts)."""
    from stagger_nb.widgets import WandEditor
    e = WandEditor(walk, frame=40, joint="LeftUpLeg", rotation=(10.0, 0.0, 0.0), precompute=False)
    try:
        e.model.propagate = True
        e.limit_range.value = True
        c = e.controls["edit_frame"]
        ops = e.session.ops
        assert page_echoes(c) <= 1 and page_echoes(e.range) <= 1     # (a float-noise echo, taken as no move)
        assert e.session.ops == ops and e.model.edit_frame == 40
        for k in range(1, 4):
            v = page_snap(c, c.value + c.step)
            from_browser(c, value=v)
            assert c.value == v and e.model.edit_frame == 40 + k
        lo0 = e.model.frame_range[0]
        for k in range(1, 4):
            v = [page_snap(e.range, e.range.value[0] + e.range.step), e.range.value[1]]
            from_browser(e.range, value=v)
            assert list(e.range.value) == v and e.model.frame_range[0] == lo0 + k
    finally:
        e.close()


def test_a_duration_step_at_60_hz_stays_where_the_page_put_it(walk):
    """60 Hz: the model keeps 3 decimals (6.033 for 6.0333 s, 2 % of a frame off the grid); the slider is still
    given the grid point, so a press is not written back (nor echoed) as 6.033."""
    from stagger_nb.widgets import WarpEditor
    e = WarpEditor(walk)
    try:
        c = e.controls["duration"]
        for k in range(1, 4):
            v = page_snap(c, c.value + c.step)
            from_browser(c, value=v)
            assert c.value == v and page_echoes(c) == 0
            assert round((e.model.duration - walk.duration) / walk.frame_time) == k
    finally:
        e.close()
