"""The dope sheet without a browser: the knot table a session gives (session/timeline.py), the ops a drag writes,
and the Timeline view's state and requests (widgets/timeline.py)."""
from __future__ import annotations

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb.session import Session
from stagger_nb.session.timeline import knot_table
from stagger_nb.widgets.timeline import Timeline


@pytest.fixture
def walk():
    return sn.data.load("walk")


def test_knot_table_is_the_last_staggered_state(walk):
    s = Session(walk, ops=[{"op": "cull", "percent": 60.0}, {"op": "succession", "root": "Hips", "s": 0.02},
                           {"op": "keep_contacts"}])
    tb = knot_table(s)
    sm = s.staggered()
    np.testing.assert_array_equal(tb.pose_times, sm.pose_times)
    np.testing.assert_array_equal(tb.knots, sm.pose_times[:, None] + sm.refinements)
    assert tb.joints == walk.skeleton.names and tb.knots.shape == (sm.num_poses, walk.num_joints)
    assert sorted(j for _, js in tb.groups for j in js) == list(range(walk.num_joints))
    assert tb.duration == pytest.approx(s.edited().duration) and tb.frame_time == walk.frame_time
    # succession slides the knots of the limb below the root along their rows, away from the pose columns
    assert np.abs(tb.knots - tb.pose_times[:, None])[1:-1].max() > 0.01
    j = tb.to_json()
    assert j["groups"][0][0] == "trunk" and len(j["knots"]) == sm.num_poses and len(j["knots"][0]) == walk.num_joints


def test_refine_op_is_checked_against_the_neighbours_and_replays(walk):
    s = Session(walk)
    tb = knot_table(s)
    jn = "LeftForeArm"
    j = tb.joints.index(jn)
    k = 4
    lo, hi = tb.knot_range(k, jn)
    assert (lo, hi) == (tb.knots[k - 1, j], tb.knots[k + 1, j])
    for bad in (lo, hi, hi + 1.0, float("nan")):
        with pytest.raises(ValueError, match=f"{jn}'s knot of pose 4 must stay between its neighbours' knots"):
            tb.refine_op(k, jn, bad)
    with pytest.raises(ValueError, match="first frame"):
        tb.refine_op(0, jn, 0.1)
    with pytest.raises(ValueError, match="joint: no joint named 'Tail'"):
        tb.refine_op(k, "Tail", 1.0)
    t = lo + 0.25 * (hi - lo)
    op = tb.refine_op(k, jn, t)
    assert op == {"op": "refine", "pose": 4, "joint": jn, "time": t}
    s.set_ops(s.ops + [op])
    after = knot_table(s)
    assert abs(after.knots[k, j] - t) < 1e-12
    assert np.count_nonzero(after.knots != tb.knots) == 1
    with pytest.raises(ValueError, match="pose 4 must stay between poses 3 and 5"):
        tb.retime_time(4, tb.pose_times[5])
    assert tb.retime_time(4, tb.pose_times[4] + 0.01) == tb.pose_times[4] + 0.01


def test_timeline_view_state_and_requests(walk):
    tb = knot_table(Session(walk))
    view = Timeline(tb, x_range=[0.0, 6.0])
    assert view.store.table == tb.to_json() and view.store.x_range == [0.0, 6.0]
    seen = []
    view.on_refine(lambda k, j, t: seen.append(("refine", k, j, t)))
    view.on_retime(lambda k, t: seen.append(("retime", k, t)))
    view.on_select(lambda k, j: seen.append(("select", k, j)))
    view.drag_knot(3, "LeftFoot", 1.25)
    view.drag_pose(2, 0.9)
    view.select(4, "Head")
    assert seen == [("refine", 3, "LeftFoot", 1.25), ("retime", 2, 0.9), ("select", 4, "Head")]
    view.message = "refused"
    view.collapsed = ["left leg"]
    view.selected_joint = "Head"
    assert (view.store.message, view.store.collapsed, view.store.selected_joint) == ("refused", ["left leg"], "Head")
    view.store.collapsed = []          # what a click on a group's header does in the browser
    assert view.collapsed == []
    view.set_table(tb)
    assert view.message == ""
    view.frame = 12
    assert view.store.frame == 12
    view.store.frame = 20              # a click on the empty sheet seeks
    assert view.frame == 20
    view.close()


def test_the_editors_dope_sheet_writes_refine_ops_through_the_model(walk):
    from stagger_nb.widgets import StaggerEditor
    e = StaggerEditor(walk, precompute=False)
    try:
        t = e.timeline
        assert t.table == knot_table(e.session).to_json()       # the sheet shows the session's knots
        assert t.table["joints"] == list(walk.skeleton.names) and t.selected_joint == e.model.joint
        open_groups = [g for g, js in t.table["groups"] if g not in t.collapsed]
        assert open_groups == ["left arm"]                      # only the selected joint's limb is open
        k, j = 4, "LeftForeArm"
        lo, hi = knot_table(e.session).knot_range(k, j)
        want = e.model.snap_time(lo + 0.7 * (hi - lo))
        t.drag_knot(k, j, lo + 0.7 * (hi - lo))
        tail = ["keep_contacts"] if e.model.keep_contacts else []   # the contact layer follows the model's default
        assert [o["op"] for o in e.session.ops] == ["refine", *tail]
        assert e.session.ops[0]["time"] == want and abs(want - (lo + 0.7 * (hi - lo))) <= 0.5e-3   # to 1 ms at 60 Hz
        e.model.s = 0.02                                        # a later succession goes before the refine
        assert [o["op"] for o in e.session.ops] == ["succession", "refine", *tail]
        t.drag_knot(k, j, lo + 0.6 * (hi - lo))                  # the same knot again: the op replaced
        refines = [o for o in e.session.ops if o["op"] == "refine"]
        assert len(refines) == 1 and refines[0]["time"] == pytest.approx(lo + 0.6 * (hi - lo), abs=0.5e-3)
        shown = np.asarray(t.table["knots"])
        assert shown[k, t.table["joints"].index(j)] == pytest.approx(refines[0]["time"], abs=1e-4)
        n = len(e.session.ops)
        t.drag_knot(k, j, hi + 0.5)                              # past the next knot: refused, nothing written
        assert len(e.session.ops) == n and "must stay between" in t.message
        e.session.undo()                                         # undo: the model reads the refine back
        assert e.model.refines == [{"pose": k, "joint": j, "time": want}]
        t5 = float(t.table["pose_times"][5]) + 0.01
        t.drag_pose(5, t5)                                       # a pose's tab: the model's retime op
        assert {"op": "retime", "pose": 5, "time": e.model.snap_time(t5)} in e.session.ops
        assert t.table["pose_times"][5] == pytest.approx(t5, abs=0.5e-3)
        t.select(2, "Head")
        assert (e.model.pose, e.model.joint) == (2, "Head") and "trunk" not in t.collapsed
    finally:
        e.close()
