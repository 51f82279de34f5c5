"""The IK target controls' reach and step (StaggerModel.reach_ik) and the slider echo that records nothing
(a review finding in a real browser: choosing an effector recorded an IK edit at the world origin)."""
from __future__ import annotations

import pytest

from stagger_nb import data
from stagger_nb.session import Session
from stagger_nb.session.models import StaggerModel
from stagger_nb.session.models.views import reach_ik_targets


@pytest.mark.parametrize("extent, step", [(170.0, 1.0), (1.7, 0.01), (1.0, 0.005), (0.3, 0.002), (900.0, 5.0)])
def test_reach_ik_steps_are_round_numbers_near_a_two_hundredth_of_the_extent(extent, step):
    m = StaggerModel()
    m.reach_ik([-10.3, 0.0, 5.0], [20.0, 150.2, 7.0], extent)
    assert m.ik_step == pytest.approx(step)
    assert m.step("ik_x") == m.ik_step
    for (lo, hi), a, b in zip(m.ik_range, [-10.3, 0.0, 5.0], [20.0, 150.2, 7.0]):
        assert lo <= a - extent and hi >= b + extent                    # the box +- extent, at least
        # no more than a step wider (the reach only grows: the model's first reach is [-1, 1])
        assert lo > min(-1.0, a - extent - m.ik_step) - 1e-9 and hi < max(1.0, b + extent + m.ik_step) + 1e-9
        for v in (lo, hi):                                              # on the step's grid
            assert abs(v / m.ik_step - round(v / m.ik_step)) < 1e-9


def test_reach_ik_refuses_a_bad_extent():
    with pytest.raises(ValueError, match="extent"):
        StaggerModel().reach_ik([0, 0, 0], [1, 1, 1], 0.0)


def _session_model():
    walk = data.load("walk")
    s = Session(walk)
    from stagger_nb.widgets import StaggerEditor
    return StaggerEditor(s, precompute=False)


def test_the_sliders_echo_of_the_shown_target_records_nothing_but_a_move_does():
    e = _session_model()
    try:
        m = e.model
        assert m.ik_step == 1.0   # the walk's 1.8 m skeleton: 1 cm
        m.pose = 2
        m.ik_joint = "LeftFoot"
        shown = [m.ik_x, m.ik_y, m.ik_z]
        iks = lambda: [o for o in e.session.ops if o["op"] == "ik_pose"]   # noqa: E731
        assert iks() == []
        # the page gives each value back snapped to its grid (multiples of the step): no edit
        m.ik_x = round(shown[0] / m.ik_step) * m.ik_step
        m.ik_y = round(shown[1] / m.ik_step) * m.ik_step
        assert iks() == []
        # one key press (a step) is an edit; so is a typed value between grid points
        m.ik_x = round(shown[0]) + 1.0
        assert len(iks()) == 1 and iks()[0]["target"][0] == round(shown[0]) + 1.0
        m.ik_z = shown[2] + 0.3
        assert iks()[0]["target"][2] == pytest.approx(shown[2] + 0.3, abs=0.05)
    finally:
        e.close()


def test_reach_ik_targets_covers_every_joint_of_the_clip():
    walk = data.load("walk")
    s = Session(walk)
    m = StaggerModel()
    reach_ik_targets(m, s)
    pos = s.positions(walk)
    for axis, (lo, hi) in enumerate(m.ik_range):
        assert lo <= pos[..., axis].min() and hi >= pos[..., axis].max()


def test_a_cull_that_would_drop_an_ik_edited_pose_says_what_to_do_and_the_note_goes_once_it_stops_applying():
    """Browser review D9 (session 10): with an IK target on pose 10, "by count", keep 8 was refused with
    "...cannot be applied: pose: 10 is outside the 8 poses" (an IK message for a cull). The edits index the kept
    poses, so the cull cannot keep pose 10 as pose 10: refused, in a sentence saying what to do; nothing is
    recorded; the refusal is gone once another change goes through (it stayed after switching to "by %")."""
    e = _session_model()
    try:
        m = e.model
        m.pose = 10
        m.ik_joint = "LeftFoot"
        m.ik_x = round(m.ik_x) + 2.0
        ops = e.session.ops
        m.cull_by = "count"
        why = m.set_control("count", 8)
        assert why == ("the IK target of LeftFoot at pose 10 would be lost: only 8 poses would be left (0 to 7); "
                       "keep 11 poses or more, or undo or remove that edit first"), why
        assert e.session.ops == ops and why in e.message.value
        assert m.set_control("count", 11) == "" and [o["op"] for o in e.session.ops] == ["cull", "ik_pose"]
        assert m.notes == {} and "would be lost" not in e.message.value
        m.set_control("count", 8)
        m.cull_by = "percent"                          # another change, accepted
        assert m.notes == {} and "would be lost" not in e.message.value
    finally:
        e.close()


def test_the_ik_note_goes_when_the_ik_edit_does():
    """Browser review (session 10): the orange IK note stayed while the user worked in other tabs. It says a fact
    of the current edit (the target is out of reach), so it stays while that IK edit is in the op list (a change
    in another tab keeps it) and goes the moment the edit does (undo, or a cull that removes it)."""
    walk = data.load("walk")
    s = Session(walk, ops=[{"op": "ik_pose", "pose": 3, "joint": "LeftHand", "target": [0.0, 1e4, 0.0]}])
    from stagger_nb.widgets import StaggerEditor
    e = StaggerEditor(s, precompute=False)
    try:
        assert "cannot reach" in e.message.value
        e.model.s = 0.02                                 # work elsewhere: the IK edit is still there, so is its note
        assert "cannot reach" in e.message.value and [o["op"] for o in s.ops] == ["ik_pose", "succession"]
        e.model.ik_targets = []                          # the IK edit removed: no note
        assert "cannot reach" not in e.message.value and [o["op"] for o in s.ops] == ["succession"]
        s.undo()
        assert "cannot reach" in e.message.value
    finally:
        e.close()
