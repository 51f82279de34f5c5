"""Editor models without a browser: params <-> ops round trips, merging that keeps foreign ops in place, the
binding both ways (model -> session ops, session undo/redo/load -> model), values never clamped, unknown
names reported as text."""
from __future__ import annotations

import pathlib
import re
import sys

import hypothesis.strategies as st
import pytest
import traitlets
from hypothesis import given, settings

import stagger_nb as sn
from stagger_nb.session import Session
from stagger_nb.session import models as M

NAMES = ["Hips", "Spine", "LeftArm", "LeftHand", "RightUpLeg", "RightFoot"]


@pytest.fixture(scope="module")
def walk():
    return sn.data.load("walk")


def test_models_are_plain_hastraits_without_ipywidgets():
    for cls in (M.StaggerModel, M.WandModel, M.WarpModel):
        assert issubclass(cls, traitlets.HasTraits)
        assert not cls.__module__.startswith("stagger_nb.widgets")
        for name in cls().trait_names(op=True):
            assert cls.class_traits()[name].help, f"{cls.__name__}.{name} has no help"
    for path in pathlib.Path(M.__file__).parent.glob("*.py"):   # the models package, every module
        src = path.read_text(encoding="utf-8")
        assert not re.search(r"^\s*(import|from)\s+ipywidgets", src, re.M), path.name
    assert "stagger_nb.session.models" in sys.modules


def test_model_validation_names_the_trait():
    m = M.StaggerModel()
    for name, bad in [("percent", 0.0), ("percent", 150.0), ("l", 0.0), ("tau", -0.1), ("seed", -1),
                      ("s", float("nan"))]:
        with pytest.raises(traitlets.TraitError, match=name):
            setattr(m, name, bad)
    w = M.WandModel()
    with pytest.raises(traitlets.TraitError, match="sigma"):
        w.sigma = 0.0
    r = M.WarpModel()
    with pytest.raises(traitlets.TraitError, match="skip"):
        r.skip = -1
    with pytest.raises(traitlets.TraitError, match="reference"):
        r.reference = "nowhere"


# -- params <-> ops round trips ---------------------------------------------------------------------
finite = st.floats(-0.1, 0.1, allow_nan=False).map(lambda x: round(x, 4))
deltas = st.dictionaries(st.sampled_from(NAMES), st.lists(st.integers(-90, 90).map(float), min_size=3, max_size=3)
                         .filter(any), max_size=2)


@st.composite
def stagger_params(draw):
    p = M.StaggerModel(root="Hips").params()
    p["cull_by"] = draw(st.sampled_from(["percent", "count", "keep"]))
    p["percent"] = draw(st.sampled_from([100.0, 80.0, 50.0, 12.5]))
    p["count"] = draw(st.sampled_from([0, 3, 7]))
    p["keep"] = sorted(draw(st.sets(st.integers(0, 9), max_size=4)))
    p["s"] = draw(finite)
    p["root"] = draw(st.sampled_from(NAMES))
    p["l"] = draw(st.sampled_from([0.5, 1.0, 2.0]))
    p["joints"] = draw(st.lists(st.sampled_from(NAMES), unique=True, max_size=2))
    p["tau"] = abs(draw(finite))
    p["seed"] = draw(st.integers(0, 5))
    p["tau_joints"] = draw(st.lists(st.sampled_from(NAMES), unique=True, max_size=2))
    p["w_r"] = draw(st.sampled_from([0.0, 0.5, -0.3]))
    p["w_r_reference"] = draw(st.sampled_from(["previous", "next", "mean", 2]))
    p["pose_edits"] = {k: d for k, d in draw(st.dictionaries(st.integers(0, 5), deltas, max_size=2)).items() if d}
    p["edit_mode"] = draw(st.sampled_from(["staggered", "unstaggered"]))
    p["retimes"] = draw(st.dictionaries(st.integers(0, 5), st.sampled_from([0.25, 1.5]), max_size=2))
    p["ik_targets"] = draw(st.lists(st.fixed_dictionaries({"pose": st.integers(0, 5),
                                                           "joint": st.sampled_from(["LeftHand", "RightFoot"]),
                                                           "target": st.just([0.1, 0.9, -0.2])}),
                                    max_size=1))
    p["keep_contacts"] = draw(st.booleans())
    return p


def _ops_of(p):
    return M.stagger_params_to_ops(p)


@settings(max_examples=150, deadline=None)
@given(stagger_params())
def test_stagger_ops_params_ops_round_trip(p):
    ops = _ops_of(p)
    base = M.StaggerModel(root="Hips").params()
    back, notes = M.stagger_ops_to_params(ops, base, NAMES)
    assert notes == []
    assert _ops_of(back) == ops          # ops -> params -> ops is the identity
    back2, _ = M.stagger_ops_to_params(_ops_of(back), back, NAMES)
    assert back2 == back                 # and params reached from ops are a fixed point


@st.composite
def wand_params(draw):
    p = M.WandModel().params()
    p["sigma"] = draw(st.sampled_from([0.05, 0.1, 0.3]))
    p["edits"] = {k: d for k, d in draw(st.dictionaries(st.integers(0, 50), deltas, max_size=3)).items() if d}
    p["propagate"] = draw(st.booleans())
    p["frame_range"] = draw(st.sampled_from([[], [0, 40], [10, 60]]))
    p["repetitions"] = draw(st.sampled_from(["keep", "discard"]))
    return p


@settings(max_examples=100, deadline=None)
@given(wand_params())
def test_wand_ops_params_ops_round_trip(p):
    ops = M.wand_params_to_ops(p)
    back, notes = M.wand_ops_to_params(ops, M.WandModel().params(), NAMES)
    assert notes == [] and M.wand_params_to_ops(back) == ops
    assert sorted(back["edits"]) == sorted(f for f, d in p["edits"].items() if d)
    if len(p["edits"]) > 1 and p["propagate"]:
        assert len(ops) == 1 and ops[0]["frames"] == sorted(p["edits"])   # several edited frames, one op


@st.composite
def warp_params(draw):
    p = M.WarpModel(reference_options=["self", "segment", "ref"]).params()
    p["mode"] = draw(st.sampled_from(["guided", "linear"]))
    p["duration"] = draw(st.sampled_from([1.0, 2.5, 4.0]))
    p["free_length"] = draw(st.booleans())
    p["skip"] = draw(st.integers(1, 100))
    p["reference"] = draw(st.sampled_from(["self", "segment", "ref"]))
    p["segment"] = [0.5, 1.5]
    p["keytimes"] = draw(st.sampled_from([[], [[1.0, 0.5]]]))
    p["backward"] = draw(st.booleans())
    return p


@settings(max_examples=100, deadline=None)
@given(warp_params())
def test_warp_ops_params_ops_round_trip(p):
    refs = {"ref": {"path": "<memory:ref>"}}
    ops = M.warp_params_to_ops(p, refs, source_duration=4.0)
    back, notes, new = M.warp_ops_to_params(ops, M.WarpModel(reference_options=["self", "segment", "ref"]).params(),
                                            refs, source_duration=4.0)
    assert notes == [] and new == {}
    assert M.warp_params_to_ops(back, refs, source_duration=4.0) == ops


def test_warp_identity_writes_no_op_and_a_same_duration_style_warp_does():
    p = M.WarpModel(duration=3.0, reference_options=["self", "segment", "ref"]).params()
    assert M.warp_params_to_ops(p, {}, 3.0) == []
    p["reference"] = "ref"
    assert M.warp_params_to_ops(p, {"ref": {"path": "x.bvh"}}, 3.0) == [
        {"op": "guided_warp", "duration": 3.0, "skip": 8, "reference": {"path": "x.bvh"}}]


# -- merging keeps foreign ops in place -------------------------------------------------------------
FOREIGN = [{"op": "propagate", "frame": 10, "deltas": {"Spine": [5.0, 0.0, 0.0]}},
           {"op": "guided_warp", "duration": 2.0}]


@settings(max_examples=150, deadline=None)
@given(stagger_params(), stagger_params(), st.integers(0, 2))
def test_merge_keeps_every_foreign_op_in_order(p_old, p_new, where):
    old, new = _ops_of(p_old), _ops_of(p_new)
    current = FOREIGN[:where] + old + FOREIGN[where:]
    merged = M.merge_ops(current, old, new, M.STAGGER_OPS, home=lambda ops: 0)
    assert [o for o in merged if o["op"] not in M.STAGGER_OPS] == FOREIGN
    assert [o for o in merged if o["op"] in M.STAGGER_OPS] == new       # owned ops: exactly the new ones, in order
    # an unchanged parameter set changes nothing
    assert M.merge_ops(current, old, old, M.STAGGER_OPS) == current


def test_merge_replaces_in_place_and_keeps_fields_it_does_not_control():
    current = [{"op": "exaggerate", "w_r": 0.5, "poses": [1, 2], "mode": "unstaggered"},
               {"op": "propagate", "frame": 3, "deltas": {}}]
    old = [{"op": "exaggerate", "w_r": 0.5}]
    new = [{"op": "exaggerate", "w_r": 0.8}, {"op": "succession", "root": "Hips", "s": 0.02, "l": 1.0}]
    merged = M.merge_ops(current, old, new, M.STAGGER_OPS)
    assert merged[0] == {"op": "exaggerate", "w_r": 0.8, "poses": [1, 2], "mode": "unstaggered"}
    assert merged[1]["op"] == "succession" and merged[2]["op"] == "propagate"
    # an owned op the params do not describe (a second succession) survives an unrelated change
    two = [{"op": "succession", "root": "Spine", "s": 0.01, "l": 1.0}] + merged
    again = M.merge_ops(two, new, [{"op": "exaggerate", "w_r": 0.9}] + new[1:], M.STAGGER_OPS)
    assert again[0] == two[0] and again[1]["w_r"] == 0.9 and again[2] == two[2]


# -- the binding -----------------------------------------------------------------------------------
QUICKSTART = [{"op": "succession", "root": "Hips", "s": 0.02, "l": 1.0},
              {"op": "propagate", "frame": 60, "deltas": {"LeftUpLeg": [10.0, 0.0, 0.0]}},
              {"op": "guided_warp", "duration": 5.0}]


def test_binding_keeps_other_techniques_ops_and_undo_restores_every_parameter(walk):
    s = Session(walk, ops=QUICKSTART)
    m = M.StaggerModel(root="Hips")
    M.ModelBinding(m, s)
    assert (m.s, m.l, m.root, m.keep_contacts) == (0.02, 1.0, "Hips", False)  # read from the ops
    before = m.params()
    m.percent = 50.0
    m.tau = 0.03
    m.seed = 4
    assert [o["op"] for o in s.ops] == ["cull", "succession", "random_timing", "propagate", "guided_warp"]
    assert s.ops[3] == Session(walk, ops=QUICKSTART).ops[1] and s.ops[4] == Session(walk, ops=QUICKSTART).ops[2]
    s.undo()
    assert (m.seed, m.tau, m.percent) == (0, 0.03, 50.0)
    s.undo()
    s.undo()
    assert m.params() == before
    s.redo()
    assert m.percent == 50.0 and m.tau == 0.0


def test_binding_session_values_are_kept_not_clamped_and_unknown_joints_are_text(walk):
    s = Session(walk, ops=[{"op": "guided_warp", "duration": 2.0, "skip": 100}])
    w = M.WarpModel()
    M.ModelBinding(w, s)
    assert w.skip == 100 and s.ops[0]["skip"] == 100
    w.duration = 3.0
    assert s.ops[0]["skip"] == 100 and s.ops[0]["duration"] == 3.0

    s2 = Session(walk, ops=[{"op": "succession", "root": "NoSuchJoint", "s": 0.02, "l": 1.0}])
    m = M.StaggerModel(root="Hips")
    M.ModelBinding(m, s2)                      # no TraitError from an observer
    assert "NoSuchJoint" in m.message and m.root == "Hips"
    m.tau = 0.02                               # an unrelated change keeps the op as the session had it
    assert s2.ops[0]["root"] == "NoSuchJoint"


def test_binding_refused_op_list_is_a_message_and_clears(walk):
    s = Session(walk)
    w = M.WandModel(joint="LeftUpLeg", sigma=0.1)
    with w.loading():
        w.edit_frame = 5000                    # beyond the clip: the session's replay refuses it later
    M.ModelBinding(w, s)                       # the binding knows the clip's frames: an edit there is refused
    with pytest.raises(traitlets.TraitError, match="5000"):
        w.rx = 10.0
    assert s.ops == [] and not s.can_undo()    # nothing committed
    w.edit_frame = 30                          # the cause is gone
    w.rx = 12.0
    assert s.ops[0]["frame"] == 30 and s.edited().num_frames == walk.num_frames


def test_warp_reference_survives_undo(walk):
    run = sn.data.load("run")
    s = Session(walk)
    refs = {"run": s.use_reference("<memory:run>", run)}
    w = M.WarpModel()
    M.ModelBinding(w, s, references=refs)
    w.reference = "run"
    w.duration = 4.0
    w.reference = "self"
    s.undo()
    assert w.reference == "run"
    w.skip = 10                                # the next change keeps the restored reference
    assert s.ops[-1]["reference"] == {"path": "<memory:run>"} and s.ops[-1]["skip"] == 10


def test_wand_model_moves_the_selected_edit_and_the_playhead():
    w = M.WandModel(joint="Spine")
    w.edit_frame = 10
    w.rx = 20.0
    assert w.edits == {10: {"Spine": [20.0, 0.0, 0.0]}} and w.frame == 10
    w.edit_frame = 40                          # moves the edit
    assert w.edits == {40: {"Spine": [20.0, 0.0, 0.0]}} and w.frame == 40
    w.add_edit(70)
    w.ry = 5.0
    assert w.edited_frames == [40, 70] and w.edits[70] == {"Spine": [0.0, 5.0, 0.0]}
    w.edit_frame = 40                          # an existing edit is selected, not merged
    assert w.edited_frames == [40, 70] and (w.rx, w.ry) == (20.0, 0.0)


def test_stagger_model_pose_and_playhead_follow_each_other():
    m = M.StaggerModel(frame_time=0.1)
    m.pose_times = [0.0, 1.0, 2.5]
    m.pose = 2
    assert m.frame == 25
    m.frame = 11                                # the playhead selects the nearest pose, without snapping
    assert m.pose == 1 and m.frame == 11
    m.joint = "Spine"
    m.rz = 7.0
    assert m.pose_edits == {1: {"Spine": [0.0, 0.0, 7.0]}}
    m.pose_time = 1.2                           # retime the selected pose
    assert m.retimes == {1: 1.2}
    ops = M.stagger_params_to_ops(m.params())
    assert {"op": "retime", "pose": 1, "time": 1.2} in ops and ops[-1]["op"] != "keep_contacts"   # off by default
    m.keep_contacts = True
    assert M.stagger_params_to_ops(m.params())[-1] == {"op": "keep_contacts"}


def test_a_reloaded_session_restores_every_parameter(walk, tmp_path):
    s = Session(walk)
    m = M.StaggerModel(root="Hips", joint="Spine", frame_time=walk.frame_time)
    M.ModelBinding(m, s)
    m.percent, m.s, m.l, m.tau, m.seed, m.w_r, m.w_r_reference = 60.0, 0.03, 2.0, 0.02, 3, 0.4, "mean"
    m.pose_edits = {2: {"Spine": [0.0, 10.0, 0.0]}}
    s.save(tmp_path / "s.json")
    m2 = M.StaggerModel(root="Hips", frame_time=walk.frame_time)
    M.ModelBinding(m2, Session.load(tmp_path / "s.json", source=walk))
    assert m2.params() == m.params()


def _angle(a, b):
    import numpy as np
    d = abs(float(np.dot(a, b)))
    return 2.0 * float(np.arccos(min(d, 1.0)))


def test_stagger_editor_pose_edit_mode_chooses_the_knot_that_takes_the_nudged_value(walk):
    """§5.1, Fig. 6a/6b: the nudge is written as a target (the shown true pose ⊕ nudge); staggered mode puts
    it on the editing knot at t_k, non-staggered mode on the extreme value, so the two motions differ where
    the joint's timing refinement is not zero, and agree where it is (there the two knots coincide)."""
    import numpy as np
    s = Session(walk.slice(0, 240))
    m = M.StaggerModel(root="Hips", frame_time=walk.frame_time, keep_contacts=False)
    M.ModelBinding(m, s)
    sm = s.extraction()
    names = list(sm.skeleton.names)
    r = np.abs(np.asarray(sm.refinements))
    k = int(np.argmax(r[1:-1].max(axis=1))) + 1           # an interior pose with a large refinement
    j = names[int(np.argmax(r[k]))]
    base = np.array(sm.editing_knots[k][names.index(j)])
    m.pose, m.joint = k, j
    m.rx, m.rz = 12.0, -5.0
    (op,) = [o for o in s.ops if o["op"] == "edit_pose"]
    assert op["targets"].keys() == {j} and "deltas" not in op
    from stagger_nb.core.rotations import quat_mul, rotvec_to_quat
    want = quat_mul(base, rotvec_to_quat(np.radians([12.0, 0.0, -5.0])))
    np.testing.assert_allclose(op["targets"][j], want, atol=1e-12)
    staggered_sm, staggered_motion = s.staggered(), s.edited()
    assert _angle(staggered_sm.editing_knots[k][names.index(j)], want) < 1e-6   # Fig. 6a: the true pose
    m.edit_mode = "unstaggered"
    unstaggered_sm, unstaggered_motion = s.staggered(), s.edited()
    assert _angle(unstaggered_sm.values[k][names.index(j)], want) < 1e-6        # Fig. 6b: the extreme value
    gap = np.max(np.abs(staggered_motion.local_quats - unstaggered_motion.local_quats))
    assert gap > 1e-3                                      # the toggle changes the motion
    assert (m.rx, m.ry, m.rz) == (12.0, 0.0, -5.0)         # and reads back as the same nudge
    s.undo()                                               # the mode change is one undo step
    assert m.edit_mode == "staggered"
    np.testing.assert_allclose(s.edited().local_quats, staggered_motion.local_quats, atol=1e-12)
    # a joint without refinement at that pose: both knots coincide, the modes agree
    flat = [n for i, n in enumerate(names) if r[k, i] == 0.0 and n != j]
    assert flat, "walk has joints without timing refinement at this pose"
    if flat:
        m.rx = m.rz = 0.0
        m.joint = flat[0]
        m.ry = 9.0
        a = s.edited()
        m.edit_mode = "unstaggered"
        np.testing.assert_allclose(s.edited().local_quats, a.local_quats, atol=1e-9)


def test_stagger_nudges_follow_a_new_cull_and_undo(walk):
    """Pose edits apply to the state after the cull: after a new cull the nudge is the same change of the new
    pose (not the old absolute value), and undoing the cull restores the first motion exactly."""
    import numpy as np

    from stagger_nb import staggered
    s = Session(walk.slice(0, 240))
    m = M.StaggerModel(root="Hips", frame_time=walk.frame_time, keep_contacts=False)
    M.ModelBinding(m, s)
    m.pose, m.joint, m.ry = 2, "LeftForeArm", 20.0
    first = s.edited()
    m.percent = 60.0
    culled = staggered.cull(s.extraction(), 60.0)
    direct = staggered.evaluate(staggered.edit_pose(culled, 2, deltas={"LeftForeArm": np.radians([0, 20.0, 0])}))
    np.testing.assert_allclose(s.edited().local_quats, direct.local_quats, atol=1e-9)
    m.edit_mode = "unstaggered"                 # the toggle still acts after the cull (targets again)
    assert any("targets" in o for o in s.ops if o["op"] == "edit_pose")
    s.undo()
    s.undo()
    assert m.percent == 100.0 and m.edit_mode == "staggered" and (m.rx, m.ry, m.rz) == (0.0, 20.0, 0.0)
    np.testing.assert_allclose(s.edited().local_quats, first.local_quats, atol=1e-12)
