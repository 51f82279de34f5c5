"""Issue 24 in the editors: the StaggerModel's propagate toggle and timing region, the WarpModel's retiming of the
staggered poses, their ops both ways (params -> ops -> params), one session, undo, and the views' state
(public traits only; no browser)."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data
from stagger_nb.session import Session
from stagger_nb.session.models import (
    StaggerModel,
    WarpModel,
    stagger_ops_to_params,
    stagger_params_to_ops,
    warp_ops_to_params,
    warp_params_to_ops,
)


@pytest.fixture(scope="module")
def walk():
    return data.load("walk")


def test_stagger_params_write_propagate_and_region_and_read_them_back():
    p = StaggerModel().params()
    p.update(pose_edits={3: {"LeftArm": [0.0, 0.0, 20.0]}}, ik_targets=[{"pose": 2, "joint": "LeftHand",
                                                                       "target": [1.0, 2.0, 3.0]}],
             s=0.02, tau=0.01, propagate=True, sigma=0.7, region=True, region_frame=120)
    ops = stagger_params_to_ops(p)
    by = {o["op"]: o for o in ops}
    assert by["edit_pose"]["propagate"] is True and by["edit_pose"]["sigma"] == 0.7
    assert by["ik_pose"]["propagate"] is True
    assert by["succession"]["falloff"] == {"frame": 120, "sigma": 0.7} == by["random_timing"]["falloff"]
    back, notes = stagger_ops_to_params(ops, StaggerModel().params())
    assert not notes
    assert (back["propagate"], back["sigma"], back["region"], back["region_frame"]) == (True, 0.7, True, 120)
    # off: no field written (older sessions' JSON unchanged), and read back as off
    p.update(propagate=False, region=False, sigma=0.0)
    ops = stagger_params_to_ops(p)
    assert all("propagate" not in o and "falloff" not in o and "sigma" not in o for o in ops)
    back, _ = stagger_ops_to_params(ops, dict(StaggerModel().params(), propagate=True, region=True))
    assert back["propagate"] is False and back["region"] is False


def test_the_stagger_editor_model_drives_one_session_and_undo_restores_it(walk):
    from stagger_nb.widgets import StaggerEditor
    ed = StaggerEditor(walk, precompute=False)
    m, s = ed.model, ed.session
    m.joint, m.pose = "LeftArm", 6
    m.propagate = True
    m.rz = 20.0
    edit = next(o for o in s.ops if o["op"] == "edit_pose")
    assert edit["propagate"] is True and "targets" in edit
    m.s = 0.01
    m.region = True                                   # centred on the selected pose's source frame
    assert m.region_frame == m.pose_source_frames[6] == int(round(s.extraction().pose_times[6] / walk.frame_time))
    succ = next(o for o in s.ops if o["op"] == "succession")
    assert succ["falloff"] == {"frame": m.region_frame, "sigma": None}
    np.testing.assert_allclose(m.region_weights, s.pose_falloff(m.region_frame), rtol=0, atol=1e-12)
    assert ed.probability.figure["data"][-1]["name"].startswith("region")
    np.testing.assert_allclose(ed.probability.figure["data"][-1]["y"], m.region_weights)
    # the propagated edit and the region both act on the replayed motion: one session, ops in order
    tail = ["keep_contacts"] if m.keep_contacts else []   # the contact layer's op follows the model's default
    assert [o["op"] for o in s.ops] == ["edit_pose", "succession", *tail]
    assert s.undo() and not m.region and "falloff" not in next(o for o in s.ops if o["op"] == "succession")
    assert s.undo() and s.undo() and m.s == 0.0
    assert s.redo() and s.redo() and s.redo() and m.region and m.propagate
    with pytest.raises(Exception, match="sigma"):
        m.sigma = -1.0


def test_the_warp_model_retimes_the_staggered_poses_in_a_session_with_staggered_edits(walk):
    from stagger_nb.widgets import StaggerEditor, WarpEditor
    st_ed = StaggerEditor(walk, precompute=False)
    st_ed.model.s = 0.01
    session = st_ed.session
    w = WarpEditor(walk, session=session)
    assert w.model.has_staggered and w.model.target == "motion"
    w.model.target = "poses"
    w.model.duration = 1.5 * walk.duration
    ops = session.ops
    tail = ["keep_contacts"] if st_ed.model.keep_contacts else []   # the contact layer follows the model's default
    assert [o["op"] for o in ops] == ["succession", "guide_poses", *tail]   # among the staggered ops
    assert ops[1]["duration"] == pytest.approx(1.5 * walk.duration) and ops[1]["reference"] == "self"
    sm = session.staggered()
    assert sm.pose_times[-1] == pytest.approx(1.5 * session.extraction().pose_times[-1], abs=walk.frame_time)
    assert session.edited().duration == pytest.approx(1.5 * walk.duration, abs=walk.frame_time)
    # the StaggerEditor's succession is still its own op, editable after the retiming
    st_ed.model.s = 0.02
    assert [o["op"] for o in session.ops] == ["succession", "guide_poses", *tail]
    assert session.ops[0]["s"] == 0.02
    # back to the motion: the guided warp of the edited motion at the end
    w.model.target = "motion"
    assert [o["op"] for o in session.ops] == ["succession", *tail, "guided_warp"]
    p, _, _ = warp_ops_to_params(session.ops, w.model.params(), source_duration=walk.duration)
    assert p["target"] == "motion"


def test_warp_params_write_guide_poses_and_read_it_back():
    p = dict(WarpModel().params(), target="poses", duration=3.0, skip=4, backward=True,
             keytimes=[[1.0, 1.5]])
    [op] = warp_params_to_ops(p, source_duration=2.0)
    assert op == {"op": "guide_poses", "duration": 3.0, "skip": 4, "reference": "self", "keytimes": [[1.0, 1.5]]}
    back, notes, _ = warp_ops_to_params([op], WarpModel().params(), source_duration=2.0)
    assert back["target"] == "poses" and back["duration"] == 3.0 and back["skip"] == 4
    assert Session(data.load("walk"), ops=[op]).ops[0]["op"] == "guide_poses"    # a valid op
