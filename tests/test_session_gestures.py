"""One gesture, one undo step (browser review D3, session 10): the values of one slider drag or burst of arrow
keys that reach the kernel (their number varies with load) are one undo step; a rest ends the gesture; toggles,
choices and code are a step each. ``History.commit(gesture=)`` is the mechanism, ``ModelBinding`` the rule."""
from __future__ import annotations

import pytest
from editor_helpers import from_browser, page_snap

import stagger_nb as sn
from stagger_nb.session import Session
from stagger_nb.session.history import History


@pytest.fixture(scope="module")
def walk():
    return sn.data.load("walk")


def test_history_commits_of_one_gesture_are_one_step():
    h = History()
    for i in range(1, 6):
        assert h.commit(("a",) * i, gesture="g")
    assert h.can_undo and h.undo() and h.ops == () and not h.can_undo   # back to before the gesture
    assert h.redo() and h.ops == ("a",) * 5
    h.commit(("b",), gesture="g")            # after an undo/redo the same token starts a new step
    h.commit(("c",), gesture="g")
    h.undo()
    assert h.ops == ("a",) * 5
    h.commit(("x",), gesture="k")
    h.commit(("y",))                         # no token: a step of its own
    h.undo()
    assert h.ops == ("x",)
    h.commit(("z",), gesture="m")
    h.commit(("x",), gesture="m")            # back where the gesture started: no step left
    assert h.ops == ("x",) and h.undo() and h.ops == ("a",) * 5


def _presses(control, n, sign=1):
    for _ in range(n):
        from_browser(control, value=page_snap(control, control.value + sign * control.step))


@pytest.mark.parametrize("presses", [3, 11])
def test_a_burst_of_arrow_keys_on_a_slider_is_one_undo_step(walk, presses):
    from stagger_nb.widgets import WarpEditor
    e = WarpEditor(walk)
    try:
        e.model.mode = "linear"                               # code: a step of its own
        ops0 = e.session.ops
        d0 = e.model.duration
        _presses(e.controls["duration"], presses)
        assert e.model.duration == pytest.approx(d0 + presses * walk.frame_time, abs=1e-3)   # (3 decimals at 60 Hz)
        assert e.session.undo() and e.session.ops == ops0 and e.model.duration == pytest.approx(d0)
        assert e.session.undo() and e.session.ops == [] and not e.session.can_undo
    finally:
        e.close()


def test_a_rest_ends_the_gesture_and_code_changes_are_a_step_each(walk):
    from stagger_nb.widgets import WarpEditor
    e = WarpEditor(walk)
    try:
        e.model.mode = "linear"
        e.binding.gesture_rest = 0.0                          # every change rests longer than that
        d0 = e.model.duration
        _presses(e.controls["duration"], 3)
        assert e.session.undo() and e.model.duration == pytest.approx(d0 + 2 * walk.frame_time, abs=1e-3)
        e.binding.gesture_rest = 60.0
        e.model.duration = 7.0                                 # code, however quick: a step each
        e.model.duration = 8.0
        assert e.session.undo() and e.model.duration == 7.0
    finally:
        e.close()


def test_the_wands_rotate_keys_are_one_step_per_slider(walk):
    from stagger_nb.widgets import WandEditor
    e = WandEditor(walk, frame=40, joint="LeftUpLeg", precompute=False)
    try:
        _presses(e.controls["rx"], 6)
        _presses(e.controls["ry"], 2, sign=-1)              # another slider: its own step
        assert e.model.edits[40]["LeftUpLeg"] == [6.0, -2.0, 0.0]
        assert e.session.undo() and e.model.edits[40]["LeftUpLeg"] == [6.0, 0.0, 0.0]
        assert e.session.undo() and e.session.ops == [] and not e.session.can_undo
    finally:
        e.close()


def test_a_session_without_gestures_keeps_one_step_per_change(walk):
    s = Session(walk)
    s.set_ops([{"op": "linear_warp", "duration": 5.0}])
    s.set_ops([{"op": "linear_warp", "duration": 6.0}])
    assert s.undo() and s.ops[0]["duration"] == 5.0
