"""Held-out-style acceptance checks of issue 11 without a browser, written independently of the editors' own
tests and through public names only (``editor.model``, ``editor.session``, ``editor.view``, ``Session``):
procedural clips and the real clips of ``../shared/mocap`` (skipped with the reason where absent).

Each check is what a user or the issue's held-out check would do: set every listed model trait, open an editor on
a session holding the other techniques' ops, undo/redo, save and reload, move the playhead, set invalid values,
make rapid changes, undo past the editor's own ops, cull away poses an op names.
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import traitlets
from conftest import shared_clip_path

import stagger_nb as sn
from stagger_nb import staggered
from stagger_nb.session import Session

REAL = ["xia_neutral_walk.bvh", "bandai_walk.bvh", "cmu_131_01_walk_startstop.bvh", "pymo_walk_turnaround.bvh",
        "xia_angry_run.bvh", "bandai_run_cycle.bvh"]


def _load(name):
    if name.endswith(".bvh"):
        return sn.read_bvh(shared_clip_path(name))
    return sn.data.load(name)


def _root(m):
    return "Hips" if "Hips" in m.skeleton.names else m.skeleton.names[0]


def _foreign_ops(m):
    """Ops of the other techniques (and staggered ops the StaggerEditor does not show as one control)."""
    names = m.skeleton.names
    arm = next(n for n in ("LeftArm", "LeftShoulder", "UpperArm_L") if n in names)
    return [{"op": "propagate", "frame": m.num_frames // 2, "deltas": {arm: [10.0, 0.0, 0.0]}},
            {"op": "guided_warp", "duration": round(0.8 * m.duration, 3)}]


def _stagger(session_or_motion):
    from stagger_nb.widgets import StaggerEditor
    return StaggerEditor(session_or_motion, precompute=False)


def _same(a, b):
    return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)


def _edited_q(s):
    e = s.edited()
    return np.asarray(e.local_quats).copy(), e.num_frames


# ----------------------------------------------------------------------------------------------------------
# the model: a HasTraits outside widgets, every listed trait live
# ----------------------------------------------------------------------------------------------------------
STAGGER_MOVES = [("percent", 60.0), ("s", 0.03), ("l", 2.0), ("tau", 0.04), ("seed", 3), ("w_r", 0.5),
                 ("keep_contacts", None)]   # None: toggle (an editor opened on ops without the op reads it off)


@pytest.mark.parametrize("clip", ["walk", "xia_neutral_walk.bvh", "bandai_walk.bvh"])
def test_stagger_every_trait_changes_ops_and_motion_and_keeps_foreign_ops(clip):
    m = _load(clip)
    foreign = _foreign_ops(m)
    s = Session(m, ops=[{"op": "succession", "root": _root(m), "s": 0.02, "l": 1.0}] + foreign)
    ed = _stagger(s)
    try:
        model = ed.model
        foreign = [o for o in s.ops if o["op"] in ("propagate", "guided_warp")]   # as the session stores them
        assert len(foreign) == 2
        assert isinstance(model, traitlets.HasTraits)
        assert not type(model).__module__.startswith("stagger_nb.widgets")
        assert ed.session is s
        assert model.s == pytest.approx(0.02) and model.root == _root(m)   # read from the session's op
        assert model.keep_contacts is False           # the session has no keep_contacts op
        for name, value in STAGGER_MOVES:
            ops0, (q0, n0) = s.ops, _edited_q(s)
            setattr(model, name, (not model.keep_contacts) if value is None else value)
            ops1, (q1, n1) = s.ops, _edited_q(s)
            assert not _same(ops0, ops1), f"{name} = {value} wrote no op change"
            assert n1 != n0 or not np.allclose(q0, q1), f"{name} = {value} left the edited motion unchanged"
            # every foreign op kept, unchanged, in its order, and after the staggered ops it follows
            kept = [o for o in ops1 if o["op"] in ("propagate", "guided_warp")]
            assert _same(kept, foreign), (name, ops1)
            idx = [i for i, o in enumerate(ops1) if o["op"] in ("propagate", "guided_warp")]
            assert idx == list(range(len(ops1) - len(foreign), len(ops1))), ops1
    finally:
        ed.close()


def test_wand_and_warp_every_trait_changes_ops_and_motion_and_keeps_foreign_ops():
    from stagger_nb.widgets import WandEditor, WarpEditor
    m = sn.data.load("run")
    root = _root(m)
    stag = [{"op": "succession", "root": root, "s": 0.02, "l": 1.0},
            {"op": "random_timing", "tau": 0.03, "seed": 1}, {"op": "keep_contacts"}]
    s = Session(m, ops=stag + [{"op": "propagate", "frame": 100, "deltas": {"LeftArm": [15.0, 0.0, 0.0]}}])
    stag = s.ops[:3]                                  # as the session stores them (defaults written out)
    ed = WandEditor(s, precompute=False)
    try:
        assert isinstance(ed.model, traitlets.HasTraits)
        assert not type(ed.model).__module__.startswith("stagger_nb.widgets")
        for name, value in (("sigma", 0.6 * ed.model.sigma), ("edit_frame", 160)):
            ops0, (q0, _) = s.ops, _edited_q(s)
            setattr(ed.model, name, value)
            ops1, (q1, _) = s.ops, _edited_q(s)
            assert not _same(ops0, ops1) and not np.allclose(q0, q1), name
            assert _same(ops1[:3], stag), ops1
    finally:
        ed.close()
    s = Session(m, ops=stag + [{"op": "guided_warp", "duration": round(0.8 * m.duration, 3)}])
    stag = s.ops[:3]
    ed = WarpEditor(s)
    try:
        assert not type(ed.model).__module__.startswith("stagger_nb.widgets")
        assert ed.model.duration == pytest.approx(round(0.8 * m.duration, 3))
        # skip 2: the 0.6x warp plays 1.67x on average; its steps stay within 1..3 since issue 25's speed penalty,
        # so skip 3 would not bind (eq. 1's bursts of 8 made it bind)
        for name, value in (("duration", round(0.6 * m.duration, 3)), ("skip", 2)):
            ops0, (q0, n0) = s.ops, _edited_q(s)
            setattr(ed.model, name, value)
            ops1, (q1, n1) = s.ops, _edited_q(s)
            assert not _same(ops0, ops1) and (n0 != n1 or not np.allclose(q0, q1)), name
            assert _same(ops1[:3], stag), ops1
    finally:
        ed.close()


# ----------------------------------------------------------------------------------------------------------
# undo / redo, save / load, playhead
# ----------------------------------------------------------------------------------------------------------
def test_stagger_undo_redo_and_reload_restore_every_parameter(tmp_path):
    m = sn.data.load("walk")
    s = Session(m, ops=_foreign_ops(m))
    ed = _stagger(s)
    try:
        model = ed.model
        states = [{k: getattr(model, k) for k, _ in STAGGER_MOVES}]
        for name, value in STAGGER_MOVES:
            setattr(model, name, (not model.keep_contacts) if value is None else value)
            states.append({k: getattr(model, k) for k, _ in STAGGER_MOVES})
        final_ops = s.ops
        for want in reversed(states[:-1]):
            assert s.undo()
            assert {k: getattr(model, k) for k, _ in STAGGER_MOVES} == pytest.approx(want)
        for want in states[1:]:
            assert s.redo()
            assert {k: getattr(model, k) for k, _ in STAGGER_MOVES} == pytest.approx(want)
        assert _same(s.ops, final_ops)
        p = tmp_path / "edit.json"
        s.save(p)
    finally:
        ed.close()
    s2 = Session.load(p)
    assert _same(s2.ops, final_ops)
    ed2 = _stagger(s2)
    try:
        assert {k: getattr(ed2.model, k) for k, _ in STAGGER_MOVES} == pytest.approx(states[-1])
        assert _same(s2.ops, final_ops)     # opening the editor rewrote nothing
        np.testing.assert_allclose(s2.edited().local_quats, Session(m, ops=final_ops).edited().local_quats,
                                   atol=1e-12)
    finally:
        ed2.close()


def test_wand_warp_undo_and_reload_restore_parameters(tmp_path):
    from stagger_nb.widgets import WandEditor, WarpEditor
    m = sn.data.load("run")
    s = Session(m, ops=[{"op": "propagate", "frame": 100, "deltas": {"LeftArm": [15.0, 0.0, 0.0]}}])
    ed = WandEditor(s, precompute=False)
    try:
        sig0 = ed.model.sigma
        ed.model.sigma = 0.5 * sig0
        ed.model.edit_frame = 150
        assert s.undo() and ed.model.edit_frame == 100 and ed.model.sigma == pytest.approx(0.5 * sig0)
        assert s.undo() and ed.model.sigma == pytest.approx(sig0)
        assert s.redo() and s.redo() and ed.model.edit_frame == 150
        s.save(tmp_path / "w.json")
    finally:
        ed.close()
    ed = WandEditor(Session.load(tmp_path / "w.json"), precompute=False)
    try:
        assert ed.model.edit_frame == 150 and ed.model.sigma == pytest.approx(0.5 * sig0)
    finally:
        ed.close()
    s = Session(m)
    ed = WarpEditor(s)
    try:
        ed.model.duration = round(0.7 * m.duration, 3)
        ed.model.skip = 5
        assert s.undo() and ed.model.skip != 5
        assert s.redo() and ed.model.skip == 5
        s.save(tmp_path / "t.json")
    finally:
        ed.close()
    ed = WarpEditor(Session.load(tmp_path / "t.json"))
    try:
        assert ed.model.skip == 5 and ed.model.duration == pytest.approx(round(0.7 * m.duration, 3))
    finally:
        ed.close()


def test_playhead_follows_a_shorter_warp_and_pose_choice_past_its_end():
    """A guided warp after the staggered ops shortens the edit: the playhead moves inside it, and choosing a pose
    whose (unwarped) time lies past the warped end moves the playhead to the last frame instead of failing."""
    m = sn.data.load("walk")
    s = Session(m, ops=[{"op": "succession", "root": "Hips", "s": 0.02, "l": 1.0}])
    ed = _stagger(s)
    try:
        ed.model.frame = m.num_frames - 1
        s.add({"op": "guided_warp", "duration": round(0.5 * m.duration, 3)})
        n = s.edited().num_frames
        assert n < m.num_frames and ed.model.frame == ed.view.frame <= n - 1
        ed.model.pose = len(ed.model.pose_times) - 1
        assert ed.model.frame == ed.view.frame == n - 1
        assert not ed.error
    finally:
        ed.close()


def test_model_frame_moves_the_view_in_every_editor():
    from stagger_nb.widgets import WandEditor, WarpEditor
    m = sn.data.load("walk")
    eds = [_stagger(m), WandEditor(m, precompute=False), WarpEditor(m)]
    try:
        for ed in eds:
            for k in (0, 17, m.num_frames // 2, 5):
                ed.model.frame = k
                assert ed.view.frame == k, type(ed).__name__
            n = ed.session.edited().num_frames
            ed.model.frame = n - 1
            assert ed.view.frame == n - 1
            for bad in (n, 10 ** 6):                 # past the edited motion: refused, the view stays in step
                with pytest.raises(traitlets.TraitError, match="frame"):
                    ed.model.frame = bad
                assert ed.model.frame == ed.view.frame == n - 1
    finally:
        for ed in eds:
            ed.close()


# ----------------------------------------------------------------------------------------------------------
# odd sequences a user makes
# ----------------------------------------------------------------------------------------------------------
BAD = {"percent": [0.0, -5.0, 101.0, float("nan")], "s": [float("inf"), 61.0],   # s < 0: the extremities lead
       "l": [0.0, -1.0, float("nan"), 11.0], "tau": [-0.01, float("nan"), 61.0], "w_r": [float("nan"), float("inf")],
       "seed": [-1]}


def test_invalid_trait_values_raise_clearly_and_commit_nothing():
    from stagger_nb.widgets import WandEditor, WarpEditor
    m = sn.data.load("walk")
    s = Session(m, ops=[{"op": "succession", "root": "Hips", "s": 0.02, "l": 1.0}] + _foreign_ops(m))
    ed = _stagger(s)
    try:
        for name, values in BAD.items():
            for v in values:
                ops0, before = s.ops, getattr(ed.model, name)
                with pytest.raises((traitlets.TraitError, ValueError), match=name):
                    setattr(ed.model, name, v)
                assert _same(s.ops, ops0), (name, v)
                assert getattr(ed.model, name) == before or (np.isnan(before) and np.isnan(getattr(ed.model, name)))
        assert not s.can_undo()                        # nothing was committed
    finally:
        ed.close()
    wand = Session(m, ops=[{"op": "propagate", "frame": 100, "deltas": {"LeftArm": [15.0, 0.0, 0.0]}}])
    for ed, bad in ((WandEditor(wand, precompute=False), {"sigma": [0.0, -1.0, float("nan")],
                                                       "edit_frame": [-1, m.num_frames]}),
                    (WarpEditor(m), {"duration": [0.0, -1.0, float("nan"), 1e9], "skip": [-1]})):
        try:
            for name, values in bad.items():
                for v in values:
                    ops0 = ed.session.ops
                    with pytest.raises((traitlets.TraitError, ValueError), match=name):
                        setattr(ed.model, name, v)
                    assert _same(ed.session.ops, ops0), (name, v)
        finally:
            ed.close()


def test_rapid_changes_end_in_the_last_value():
    m = sn.data.load("walk")
    s = Session(m, ops=_foreign_ops(m))
    ed = _stagger(s)
    try:
        for v in np.linspace(100, 30, 15):
            ed.model.percent = float(v)
        for v in np.linspace(0.0, 0.05, 11)[1:]:
            ed.model.s = float(v)
        for seed in range(8):
            ed.model.seed = seed
        ed.model.tau = 0.03
        want = Session(m, ops=s.ops)
        ops = s.ops
        cull = [o for o in ops if o["op"] == "cull"]
        succ = [o for o in ops if o["op"] == "succession"]
        assert len(cull) == 1 and cull[0]["percent"] == pytest.approx(30.0)
        assert len(succ) == 1 and succ[0]["s"] == pytest.approx(0.05)
        assert [o["seed"] for o in ops if o["op"] == "random_timing"] == [7]
        assert _same([o for o in ops if o["op"] in ("propagate", "guided_warp")],
                     Session(m, ops=_foreign_ops(m)).ops)
        np.testing.assert_allclose(s.edited().local_quats, want.edited().local_quats, atol=1e-12)
    finally:
        ed.close()


def test_undo_past_the_editors_own_ops():
    """Ops made in code before the editor opened, then the editor's moves; undo walks back through both and the
    model follows (an op the editor owns reappears as its traits; a removed foreign op is not resurrected)."""
    m = sn.data.load("walk")
    s = Session(m)
    s.add({"op": "succession", "root": "Hips", "s": 0.01, "l": 1.0})
    s.add(_foreign_ops(m)[0])
    ed = _stagger(s)
    try:
        ed.model.s = 0.04
        ed.model.percent = 70.0
        assert s.undo() and ed.model.percent == 100.0 and ed.model.s == pytest.approx(0.04)
        assert s.undo() and ed.model.s == pytest.approx(0.01)
        assert s.undo()                                # the propagate op added in code goes
        assert [o["op"] for o in s.ops] == ["succession"] and ed.model.s == pytest.approx(0.01)
        assert s.undo() and s.ops == [] and ed.model.s == 0.0
        while s.undo():
            pass
        assert ed.model.s == 0.0 and ed.model.percent == 100.0
        ed.model.tau = 0.02                            # a move after undoing everything works
        assert [o["op"] for o in s.ops if o["op"] != "keep_contacts"] == ["random_timing"]
        assert not s.can_redo()
        s.edited()
    finally:
        ed.close()


def test_editor_on_ops_naming_poses_that_a_later_cull_removes():
    """A session edits pose 20 (edit_pose, retime, ik_pose) and a later move culls to a few poses: the cull is
    refused in one plain sentence naming the edit it would break (no op index, no exception name), no op is
    dropped or rewritten, and the editor follows the next valid move."""
    m = sn.data.load("walk")
    sm = staggered.extract(m)
    k = sm.num_poses - 2
    t = float(sm.pose_times[k])
    ops = [{"op": "edit_pose", "pose": k, "deltas": {"LeftArm": [0.0, 0.0, 20.0]}},
           {"op": "retime", "pose": k, "time": t + 0.02},
           {"op": "succession", "root": "Hips", "s": 0.02, "l": 1.0}] + _foreign_ops(m)
    s = Session(m, ops=ops)
    ed = _stagger(s)
    try:
        ops0 = s.ops
        with pytest.raises(traitlets.TraitError) as refused:
            ed.model.percent = 10.0
        why = str(refused.value)
        assert f"pose {k}" in why and "ops[" not in why and "Error" not in why, why
        assert why in ed.message.value and ed.model.percent == 100.0 and _same(s.ops, ops0)
        assert ed.model.set_control("percent", 10.0) == why and ed.model.notes["percent"] == why
        ed.model.s = 0.03                  # the next valid move applies
        assert s.ops[2]["s"] == 0.03 and why not in ed.message.value
        s.edited()
    finally:
        ed.close()


# ----------------------------------------------------------------------------------------------------------
# keep_contacts and ik_pose through the session on the real walks
# ----------------------------------------------------------------------------------------------------------
CM = {"xia_neutral_walk.bvh": 2.54 / 0.45, "bandai_walk.bvh": 1.0, "cmu_131_01_walk_startstop.bvh": 2.54 / 0.45}


@pytest.mark.parametrize("clip", list(CM))
def test_keep_contacts_op_holds_feet_on_real_walks(clip):
    """The keep_contacts op through the session, measured by sn.quality.compare (issue 20; this replaced the
    older path-length measure, which a layer that keeps the source's own heel-toe roll cannot meet where the
    source itself drifts inside its contacts): inside the contacts as the layer and compare carry them (on the
    pelvis's timing) the feet follow the source's own motion within 1.5 cm (xia 0.01, bandai 0.10, cmu_131 0.01;
    16-40 cm without the op), inside the source's own intervals shrunk by 0.1 s within 4 cm (0.27, 0.30, 0.57;
    12-16 without; 3.7, 1.4, 3.5 while contacts were carried on each joint's own clock), the pelvis moved by at
    most 3 cm by the layer."""
    m = _load(clip)
    edit = [{"op": "succession", "root": _root(m), "s": 0.02, "l": 1.0},
            {"op": "random_timing", "tau": 0.05, "seed": 0}]
    plain, held = Session(m, ops=edit), Session(m, ops=edit + [{"op": "keep_contacts"}])
    r = sn.quality.compare(m, held.edited(), staggered=held.staggered(), baseline=plain.edited())
    r0 = sn.quality.compare(m, plain.edited(), staggered=plain.staggered())
    print(f"{clip}: feet travel {r0.foot_travel:.2f} -> {r.foot_travel:.2f} cm in carried contacts, "
          f"{r0.foot_travel_source:.2f} -> {r.foot_travel_source:.2f} cm in the source's; pelvis "
          f"{r.pelvis_vs_baseline:.2f} cm")
    assert r.foot_travel <= 1.5 and r.foot_travel < 0.1 * r0.foot_travel
    assert r.foot_travel_source <= 4.0 and r.foot_travel_source < 0.3 * r0.foot_travel_source
    assert r.pelvis_vs_baseline <= 3.0


def _effectors(names):
    groups = [("LeftHand", "LeftWrist", "Hand_L"), ("RightHand", "RightWrist", "Hand_R"),
              ("LeftFoot", "LeftAnkle", "Foot_L"), ("RightFoot", "RightAnkle", "Foot_R")]
    return [next(n for n in g if n in names) for g in groups]


def _limb(m, joint):
    """(upper, middle) joints of the two-bone limb above ``joint`` (zero-length bones skipped)."""
    sk = m.skeleton
    chain, j = [], sk.names.index(joint)
    while len(chain) < 2:
        p = sk.parents[j]
        if np.linalg.norm(sk.offsets[j]) > 1e-9:
            chain.append(p)
        j = p
    return chain[1], chain[0]


@pytest.mark.parametrize("clip", ["walk"] + REAL)
def test_ik_pose_reachable_within_1mm_and_unreachable_nearest(clip):
    m = _load(clip)
    cm = CM.get(clip, 2.54 / 0.45 if clip.startswith(("xia", "cmu")) else 1.0)
    mm = 0.1 / cm                                     # 1 mm in file units
    sm = Session(m).staggered()
    K = sm.num_poses
    rng = np.random.default_rng(0)
    worst = [0.0, 0.0]          # mm: reachable miss, unreachable distance from the nearest point
    for k in sorted({1, K // 2, K - 2}):
        tk = float(sm.pose_times[k])
        pos = sn.forward_kinematics(staggered.evaluate(sm, [tk]))[0][0]
        for eff in _effectors(m.skeleton.names):
            j = m.skeleton.names.index(eff)
            up, mid = _limb(m, eff)
            l1, l2 = np.linalg.norm(pos[mid] - pos[up]), np.linalg.norm(pos[j] - pos[mid])
            # reachable: a point at a distance inside the annulus, in a direction near the current one
            d = pos[j] - pos[up]
            d = d / np.linalg.norm(d) + 0.3 * rng.normal(size=3)
            d /= np.linalg.norm(d)
            r = abs(l1 - l2) + (0.3 + 0.5 * rng.uniform()) * (l1 + l2 - abs(l1 - l2))
            target = pos[up] + r * d
            assert np.linalg.norm(pos[j] - target) * cm > 1.0     # a real move (> 1 cm), not the pose as it is
            s = Session(m, ops=[{"op": "ik_pose", "pose": k, "joint": eff, "target": target.tolist()}])
            got = sn.forward_kinematics(staggered.evaluate(s.staggered(), [tk]))[0][0, j]
            assert np.linalg.norm(got - target) <= mm, (clip, k, eff, np.linalg.norm(got - target) * cm * 10)
            worst[0] = max(worst[0], float(np.linalg.norm(got - target)) * cm * 10)
            # unreachable: twice the limb's length away; the effector ends at the nearest point, and says so
            far = pos[up] + 2.0 * (l1 + l2) * d
            s = Session(m, ops=[{"op": "ik_pose", "pose": k, "joint": eff, "target": far.tolist()}])
            p2 = sn.forward_kinematics(staggered.evaluate(s.staggered(), [tk]))[0][0]
            nearest = p2[up] + (l1 + l2) * (far - p2[up]) / np.linalg.norm(far - p2[up])
            assert np.linalg.norm(p2[j] - nearest) <= 2 * mm, (clip, k, eff)
            worst[1] = max(worst[1], float(np.linalg.norm(p2[j] - nearest)) * cm * 10)
            assert any("reach" in t.lower() for t in s.messages()), s.messages()
    print(f"{clip}: IK at poses {sorted({1, K // 2, K - 2})}, {_effectors(m.skeleton.names)}: reachable miss "
          f"<= {worst[0]:.4f} mm, unreachable off the nearest point <= {worst[1]:.4f} mm")


def test_ik_unreachable_is_said_in_the_editor():
    m = sn.data.load("walk")
    sm = Session(m).staggered()
    ed = _stagger(Session(m, ops=[{"op": "ik_pose", "pose": 3, "joint": "LeftHand", "target": [0.0, 1e4, 0.0]}]))
    try:
        assert "reach" in ed.message.value.lower()
        assert sm.num_poses > 3
    finally:
        ed.close()


def _rich_ops(m, sm):
    names = m.skeleton.names
    hand = next(n for n in ("LeftHand", "LeftWrist", "Hand_L") if n in names)
    arm = next(n for n in ("LeftArm", "LeftShoulder", "UpperArm_L") if n in names)
    k = sm.num_poses // 2
    tk = float(sm.pose_times[k])
    pos = sn.forward_kinematics(staggered.evaluate(sm, [tk]))[0][0, names.index(hand)]
    return [{"op": "cull", "count": max(4, sm.num_poses - 2)},
            {"op": "ik_pose", "pose": 2, "joint": hand,
             "target": (pos * 1.0 + [0.0, 0.05 * abs(pos[1]), 0.0]).tolist()},
            {"op": "succession", "root": _root(m), "s": 0.02, "l": 1.0},
            {"op": "random_timing", "tau": 0.02, "seed": 4},
            {"op": "keep_contacts"},
            {"op": "propagate", "frame": m.num_frames // 3, "deltas": {arm: [12.0, 0.0, 0.0]}},
            {"op": "guided_warp", "duration": round(0.9 * m.duration, 3)}]


@pytest.mark.parametrize("clip", ["walk", "bandai_walk.bvh"])
def test_every_editor_keeps_every_op_it_does_not_change_in_place(clip):
    """Session with cull by count, ik_pose, succession, τ, keep_contacts, propagate, guided_warp: after each
    parameter change of each editor, every op that parameter does not map to is still there, unchanged, in
    the same order (a cull by count stays a cull by count until the user moves the cull control)."""
    from stagger_nb.widgets import WandEditor, WarpEditor
    m = _load(clip)
    sm = staggered.extract(m)
    s = Session(m, ops=_rich_ops(m, sm))
    stored = s.ops
    kinds = [o["op"] for o in stored]
    moves = [(_stagger, [("s", "succession", 0.03), ("tau", "random_timing", 0.04), ("seed", "random_timing", 9),
                         ("l", "succession", 2.0), ("w_r", "exaggerate", 0.3)]),
             (lambda x: WandEditor(x, precompute=False), [("sigma", "propagate", None),
                                                          ("edit_frame", "propagate", m.num_frames // 2)]),
             (WarpEditor, [("duration", "guided_warp", round(0.7 * m.duration, 3)), ("skip", "guided_warp", 4)])]
    for make, steps in moves:
        s.set_ops(stored)
        ed = make(s)
        try:
            assert _same(s.ops, stored), "opening the editor changed the ops"
            for trait, op, value in steps:
                before = s.ops
                setattr(ed.model, trait, 0.7 * ed.model.sigma if value is None else value)
                after = s.ops
                untouched = [o for o in before if o["op"] != op]
                assert _same([o for o in after if o["op"] != op], untouched), (trait, before, after)
                assert [o["op"] for o in after if o["op"] in kinds] == [k for k in kinds if
                                                                        k in [o["op"] for o in after]], after
                s.edited()
        finally:
            ed.close()


def test_untouched_pose_edits_keep_their_form_and_place():
    """A pose edit written as deltas in code (before the succession, and before a cull added later) stays
    exactly as written while the user moves other controls: it is not rewritten as targets nor moved after the
    cull (where its pose index would name a removed pose); the motion is the same as the op list says."""
    m = sn.data.load("walk")
    k = staggered.extract(m).num_poses - 2
    ops = [{"op": "edit_pose", "pose": k, "deltas": {"LeftArm": [0.0, 0.0, 20.0]}},
           {"op": "succession", "root": "Hips", "s": 0.02, "l": 1.0}, {"op": "cull", "percent": 10.0}]
    s = Session(m, ops=ops)
    stored = s.ops
    ed = _stagger(s)
    try:
        for trait, value in (("s", 0.03), ("tau", 0.03), ("w_r", 0.2)):
            setattr(ed.model, trait, value)
            assert _same(s.ops[0], stored[0]), s.ops
        assert [o["op"] for o in s.ops][:3] == ["edit_pose", "succession", "cull"]
        s.edited()
        assert not ed.error
        ed.model.rx = 5.0            # the user nudges the selected pose: that edit is the user's, written now
        assert not _same(s.ops, stored)
    finally:
        ed.close()


def test_every_op_parameter_survives_undo_redo_and_reload(tmp_path):
    """Every op trait of the StaggerModel (cull by count / pick, succession joints, τ joints, the exaggeration
    reference, pose edits in both modes, a retime, an IK target from the x/y/z controls): undo to the start and
    redo to the end give back each intermediate ``model.params()``; a saved and reloaded session opens with the
    same params and ops."""
    m = _load("bandai_walk.bvh")
    s = Session(m)
    ed = _stagger(s)
    model = ed.model
    try:
        steps = [("cull_by", "count"), ("count", 12), ("s", 0.02), ("joints", ["UpperArm_L", "LowerArm_L"]),
                 ("tau", 0.03), ("tau_joints", ["UpperLeg_R"]), ("seed", 5), ("w_r", 0.4), ("w_r_reference", "mean"),
                 ("pose", 4), ("joint", "UpperArm_L"), ("rz", 15.0), ("edit_mode", "unstaggered"),
                 ("pose_time", None), ("ik_joint", "Hand_R"), ("ik_x", None), ("cull_by", "keep"),
                 ("keep", [0, 2, 3, 4, 5, 6, 8, 10, 11, 13])]
        states, op_lists = [model.params()], [s.ops]
        for name, value in steps:
            if name == "pose_time":
                value = model.pose_times[4] + 0.5 * (model.pose_times[5] - model.pose_times[4])
            if name == "ik_x":
                value = model.ik_x + 2.0         # 2 cm along x: reachable for a hand
            setattr(model, name, value)
            if _same(s.ops, op_lists[-1]):
                continue                          # view state (pose, joint, ik_joint, cull_by): no op change
            states.append(model.params())
            op_lists.append(s.ops)
        assert len(states) >= 14

        def same(got, want, ops):   # cull_by without a cull op is a choice of control, not in any op
            return _same({k: v for k, v in got.items() if k != "cull_by" or any(o["op"] == "cull" for o in ops)},
                         {k: v for k, v in want.items() if k != "cull_by" or any(o["op"] == "cull" for o in ops)})
        assert [o["op"] for o in s.ops if o["op"] == "ik_pose"] == ["ik_pose"]
        final = s.ops
        for i, want in reversed(list(enumerate(states[:-1]))):
            assert s.undo()
            got = model.params()
            assert same(got, want, s.ops), (i, {k: (got[k], want[k]) for k in want if not _same(got[k], want[k])})
            assert _same(s.ops, op_lists[i])
        assert s.ops == [] and not s.can_undo()
        for i, want in enumerate(states[1:], 1):
            assert s.redo()
            assert same(model.params(), want, s.ops) and _same(s.ops, op_lists[i])
        s.save(tmp_path / "all.json")
        s.edited()
        assert not ed.error, ed.error
    finally:
        ed.close()
    s2 = Session.load(tmp_path / "all.json")
    ed2 = _stagger(s2)
    try:
        got = ed2.model.params()
        for k, v in states[-1].items():
            if k == "pose_edits":      # edited as targets (unstaggered mode): read back as the same nudge
                assert got[k].keys() == v.keys()
                for p in v:
                    for j in v[p]:
                        np.testing.assert_allclose(got[k][p][j], v[p][j], atol=1e-6)
            else:
                assert _same(got[k], v), (k, got[k], v)
        assert _same(s2.ops, final)
    finally:
        ed2.close()


@pytest.mark.parametrize("clip", ["bandai_walk.bvh", "cmu_131_01_walk_startstop.bvh"])
def test_editor_ik_controls_offer_hands_and_feet_and_meet_the_target(clip):
    """The IK effector menu lists both hands and feet whatever the naming (Hand_L, LeftWrist...); moving the
    target with the x/y/z controls writes an ik_pose op whose effector meets it within 1 mm at t_k."""
    m = _load(clip)
    ed = _stagger(Session(m.slice(0, min(m.num_frames, 300))))
    try:
        offered = [v for _, v in ed.controls["ik_joint"].options]
        effs = _effectors(m.skeleton.names)
        assert set(effs) <= set(offered), offered
        model = ed.model
        model.pose = 2
        model.ik_joint = effs[1]
        model.ik_y = model.ik_y + 5.0 / CM[clip]      # 5 cm up
        op = [o for o in ed.session.ops if o["op"] == "ik_pose"]
        assert len(op) == 1 and op[0]["joint"] == effs[1] and op[0]["pose"] == 2
        sm = ed.session.staggered()
        got = sn.forward_kinematics(staggered.evaluate(sm, [float(sm.pose_times[2])]))[0][0,
                                                                                         m.skeleton.names.index(effs[1])]
        assert np.linalg.norm(got - op[0]["target"]) * CM.get(clip, 1.0) <= 0.1
    finally:
        ed.close()


def test_bad_names_indices_and_times_are_refused_before_any_op_is_written():
    """Values every validator of a plain number accepts but the clip does not: unknown joints, poses or frames
    past the clip, keytimes out of order or past the source, a reference segment past the source. Each raises
    a TraitError naming the trait; the op list, the undo stack and the trait stay as they were."""
    from stagger_nb.widgets import WandEditor, WarpEditor
    m = sn.data.load("walk")
    cases = [
        (_stagger(Session(m, ops=[{"op": "succession", "root": "Hips", "s": 0.02, "l": 1.0}])),
         [("root", "Nope"), ("joints", ["Nope"]), ("tau_joints", ["Hips", "Nope"]), ("w_r_reference", 99),
          ("pose_edits", {99: {"LeftArm": [0.0, 0.0, 5.0]}}), ("pose_edits", {1: {"Nope": [0.0, 0.0, 5.0]}}),
          ("retimes", {99: 1.0}), ("retimes", {2: -5.0}), ("pose", 99), ("joint", "Nope"), ("ik_joint", "Nope"),
          ("ik_targets", [{"pose": 99, "joint": "LeftHand", "target": [0.0, 0.0, 0.0]}]),
          ("ik_targets", [{"pose": 1, "joint": "Nope", "target": [0.0, 0.0, 0.0]}])]),
        (WarpEditor(Session(m, ops=[{"op": "guided_warp", "duration": 4.0}])),
         [("keytimes", [[1.0, 1.0], [0.5, 2.0]]), ("keytimes", [[100.0, 1.0]]), ("segment", [0.0, 100.0]),
          ("segment", [5.0, 1.0]), ("duration", 1e9)]),
        (WandEditor(Session(m, ops=[{"op": "propagate", "frame": 100, "deltas": {"LeftArm": [15.0, 0.0, 0.0]}}]),
                    precompute=False),
         [("frame_range", [0, 10 ** 6]), ("frame_range", [50, 40]), ("edits", {5: {"Nope": [1.0, 0.0, 0.0]}}),
          ("edits", {10 ** 6: {"LeftArm": [1.0, 0.0, 0.0]}}), ("joint", "Nope"), ("edit_frame", m.num_frames)]),
    ]
    for ed, bad in cases:
        try:
            s = ed.session
            for name, value in bad:
                ops0, before, undo0 = s.ops, getattr(ed.model, name), s.can_undo()
                with pytest.raises(traitlets.TraitError, match=name.split("_")[0]):
                    setattr(ed.model, name, value)
                assert _same(s.ops, ops0) and s.can_undo() == undo0, (name, value, s.ops)
                assert _same(getattr(ed.model, name), before), (name, value)
            s.edited()
            assert not ed.error, ed.error
        finally:
            ed.close()


def test_inert_controls_on_fresh_editors_say_why():
    """On a fresh editor the traits that write no op (l while s = 0, the seed while τ = 0, keep_contacts with no
    timing edit, skip while the warp is the identity) sit on disabled controls with a tooltip saying why; once
    the cause is gone they act (write ops, change the motion)."""
    from stagger_nb.widgets import WarpEditor
    m = sn.data.load("walk")
    ed = _stagger(m)
    try:
        c = ed.controls
        assert c["l"].disabled and "s = 0" in c["l"].tooltip
        assert c["seed"].disabled and "τ = 0" in c["seed"].tooltip
        ed.model.s, ed.model.tau = 0.02, 0.02
        assert not c["l"].disabled and not c["seed"].disabled
        for name, value in (("l", 2.0), ("seed", 4), ("keep_contacts", not ed.model.keep_contacts)):
            ops0 = ed.session.ops
            setattr(ed.model, name, value)
            assert not _same(ops0, ed.session.ops), name
    finally:
        ed.close()
    w = WarpEditor(m)
    try:
        assert w.session.ops == [] and w.controls["skip"].disabled and "identity" in w.controls["skip"].tooltip
        w.model.duration = round(0.7 * m.duration, 3)
        assert not w.controls["skip"].disabled
        ops0 = w.session.ops
        w.model.skip = 3
        assert not _same(ops0, w.session.ops)
    finally:
        w.close()
