"""session.runners and replay: each op's runner against the technique call it stands for; replay linear in the
number of ops; notes (messages) from the last replay."""
from __future__ import annotations

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import staggered, timewarp, wand
from stagger_nb.core import skeleton_height
from stagger_nb.core.rotations import quat_angle
from stagger_nb.session import Session
from stagger_nb.session import ops as O
from stagger_nb.session import runners as R


@pytest.fixture(scope="module")
def walk():
    return sn.data.load("walk").slice(0, 150)  # 2.5 s at 60 Hz: a few poses, fast extraction


@pytest.fixture(scope="module")
def walk_sm(walk):
    return Session(walk).extraction()  # the module's extraction, computed once (a StaggeredMotion is frozen)


def _fresh(walk, ops):
    """A new session of the module's clip with ``ops`` (its own caches: the extraction of 150 frames takes
    ~0.06 s once the package is loaded)."""
    return Session(walk, ops)


def _same_motion(a, b, tol=1e-12):
    assert a.num_frames == b.num_frames
    assert quat_angle(a.local_quats, b.local_quats).max() <= tol
    np.testing.assert_allclose(a.root_positions, b.root_positions, atol=tol)


def test_cull_by_count_and_by_keep_list(walk, walk_sm):
    sm = walk_sm
    K = sm.num_poses
    assert K >= 4
    s = _fresh(walk, [{"op": "cull", "count": 3}])
    assert s.staggered().num_poses == 3
    np.testing.assert_array_equal(s.staggered().pose_times, staggered.cull(sm, count=3).pose_times)
    keep = [2]
    s = _fresh(walk, [{"op": "cull", "keep": keep}])
    np.testing.assert_array_equal(s.staggered().pose_times, sm.pose_times[[0, 2, K - 1]])  # first and last stay
    # deleting poses keeps the motion (§5.1): the evaluated motion is close to the unculled one
    assert quat_angle(s.edited().local_quats, staggered.evaluate(sm).local_quats).max() < 0.05
    with pytest.raises(ValueError, match=r"^ops\[0\] \(cull\): keep\[0\]: 99 is outside"):
        _fresh(walk, [{"op": "cull", "keep": [99]}]).edited()


def test_staggered_tools_match_their_technique_calls(walk, walk_sm):
    sm = walk_sm
    names = walk.skeleton.names
    t_new = 0.5 * (sm.pose_times[1] + sm.pose_times[2])
    cases = [
        ({"op": "exaggerate", "w_r": 0.5, "reference": 1, "poses": [2]},
         staggered.exaggerate(sm, [2], 0.5, reference=1)),
        ({"op": "edit_pose", "pose": 1, "deltas": {names[3]: [20.0, 0.0, 0.0]}, "mode": "unstaggered"},
         staggered.edit_pose(sm, 1, deltas={names[3]: np.radians([20.0, 0, 0])}, mode="unstaggered")),
        ({"op": "retime", "pose": 1, "time": float(sm.pose_times[1] + 0.05)},
         staggered.retime(sm, {1: float(sm.pose_times[1] + 0.05)})),
        ({"op": "insert_pose", "time": float(t_new)}, staggered.insert_pose(sm, float(t_new))),
        ({"op": "delete_pose", "pose": 1}, staggered.delete_pose(sm, 1)),
    ]
    for op, want in cases:
        s = _fresh(walk, [op])
        assert s.staggered().num_poses == want.num_poses, op
        _same_motion(s.edited(), staggered.evaluate(want))
    # with deltas the two edit modes give the same motion (staggered.edit_pose applies the same change to
    # both knots, §5.1); with targets the mode chooses the knot the user edits (Fig. 6a vs 6b)
    j = names[3]
    q = [0.0, 0.0, np.sin(0.3), np.cos(0.3)]
    a, b = (_fresh(walk, [{"op": "edit_pose", "pose": 1, "targets": {j: q}, "mode": mode}]).edited()
            for mode in ("staggered", "unstaggered"))
    f = int(round(sm.pose_times[1] / sm.frame_time))
    assert abs(sm.pose_times[1] - f * sm.frame_time) < 1e-9  # extracted poses sit on frames
    ji = names.index(j)
    assert quat_angle(a.local_quats[f, ji], np.array(q)) < 1e-6  # staggered mode: the true pose at t_k
    assert quat_angle(b.local_quats[f, ji], np.array(q)) > 1e-4  # unstaggered mode: the extreme values
    assert quat_angle(a.local_quats, b.local_quats).max() > 1e-4


def test_keep_contacts_and_ik_pose_call_the_staggered_functions(walk, walk_sm):
    sm = walk_sm
    names = walk.skeleton.names
    ops = [{"op": "succession", "root": "Hips", "s": 0.02, "l": 1.0}, {"op": "keep_contacts"}]
    s = _fresh(walk, ops)
    want = staggered.keep_contacts(staggered.succession(sm, root="Hips", s=0.02, l=1.0), walk)
    _same_motion(s.edited(), want)
    hand = "LeftHand" if "LeftHand" in names else names[-1]
    k = 1
    pos, _ = sn.forward_kinematics(staggered.evaluate(sm))
    f = int(round(sm.pose_times[k] / sm.frame_time))
    reach = pos[f, names.index(hand)] + np.array([0.02, 0.0, 0.0]) * skeleton_height(walk)
    res = staggered.ik_pose(sm, k, hand, reach)
    s = _fresh(walk, [{"op": "ik_pose", "pose": k, "joint": hand, "target": [float(x) for x in reach]}])
    _same_motion(s.edited(), staggered.evaluate(res.staggered))
    assert s.messages() == ([res.message] if res.message else [])
    far = [1e4, 1e4, 1e4]
    s = _fresh(walk, [{"op": "ik_pose", "pose": k, "joint": hand, "target": far}])
    s.edited()
    msg = staggered.ik_pose(sm, k, hand, np.array(far)).message
    assert msg and msg in s.messages()


def test_timing_warnings_are_summarised_in_messages(walk):
    s = _fresh(walk, [{"op": "succession", "root": "Hips", "s": 0.3, "l": 3.0}])
    assert s.messages() == []  # nothing replayed yet
    s.edited()
    want = staggered.timing_summary(s.staggered())
    assert want.startswith("To keep each joint's poses in order, the delay was limited for")  # saturated
    assert s.messages() == [want]
    raw = _fresh(walk, [{"op": "succession", "root": "Hips", "s": 0.3, "l": 3.0, "limit": None}])
    raw.edited()
    assert raw.messages() == [staggered.timing_summary(raw.staggered())]
    assert "now play out of order" in raw.messages()[0]       # the paper's raw offsets cross poses
    mild = _fresh(walk, [{"op": "succession", "root": "Hips", "s": 0.005, "l": 1.0}])
    mild.edited()
    assert mild.messages() == [] and staggered.timing_warnings(mild.staggered()) == ()


def test_timing_warnings_once_per_state_and_equal_to_the_staggered_call(walk, monkeypatch):
    """Session.timing_warnings: the warnings of the last staggered state (what staggered.timing_warnings
    says of s.staggered()) and its summary; computed once per state, also across undo/redo back to it."""
    calls = []
    real = staggered.timing_warnings
    monkeypatch.setattr(staggered, "timing_warnings", lambda sm, **kw: calls.append(1) or real(sm, **kw))
    s = _fresh(walk, [{"op": "succession", "root": "Hips", "s": 0.3, "l": 3.0, "limit": None},
                              {"op": "edit_frame", "frame": 3, "deltas": {"Hips": [5.0, 0.0, 0.0]}}])
    summary, found = s.timing_warnings()
    want = real(s.staggered())
    assert found == tuple(want) and want  # crosses poses (else the check proves nothing)
    assert summary == staggered.timing_summary(s.staggered()) and summary and s.messages() == [summary]
    assert len(calls) == 1
    s.replace(1, {"op": "edit_frame", "frame": 4, "deltas": {"Hips": [5.0, 0.0, 0.0]}})   # after the state
    assert s.timing_warnings() == (summary, found) and len(calls) == 1
    s.replace(0, {"op": "succession", "root": "Hips", "s": 0.01, "l": 1.0})
    assert s.timing_warnings()[1] == tuple(real(s.staggered())) and len(calls) == 2
    s.undo()
    assert s.timing_warnings() == (summary, found) and len(calls) == 2   # the same state again
    assert _fresh(walk, []).timing_warnings() == ("", ())


def test_same_op_on_the_same_state_is_not_recomputed(walk, walk_sm, monkeypatch):
    """Two cull percents keeping the same poses give the same culled state: the ops after it are found by
    that state's content name and the op (not recomputed), and the result is the very same motion; a
    percent keeping other poses is computed, and equals a fresh replay."""
    sm = walk_sm
    by_keep = {}
    for p in np.arange(5.0, 100.0, 2.5):
        by_keep.setdefault(tuple(staggered.cull_keep(sm, p)), []).append(float(p))
    p1, p2 = next(v[:2] for v in by_keep.values() if len(v) > 1)
    p3 = next(v[0] for k, v in by_keep.items() if p1 not in v)
    tail = [{"op": "succession", "root": "Hips", "s": 0.02, "l": 1.0}, {"op": "keep_contacts"}]
    s = _fresh(walk, [{"op": "cull", "percent": p1}] + tail)
    first = s.edited()
    calls = []
    for name in ("succession", "hold_plants"):       # the keep_contacts op runs hold_plants (its notes)
        real = getattr(staggered, name)
        monkeypatch.setattr(staggered, name, lambda *a, _r=real, _n=name, **k: calls.append(_n) or _r(*a, **k))
    s.set_ops([{"op": "cull", "percent": p2}] + tail)
    assert s.edited() is first and calls == [] and s.messages() == _fresh(walk, s.ops).messages()
    s.set_ops([{"op": "cull", "percent": p3}] + tail)
    third = s.edited()
    assert calls == ["succession", "hold_plants"]
    monkeypatch.undo()
    fresh = Session(walk, s.ops).edited()   # a new cache: computed from scratch
    assert np.array_equal(third.local_quats, fresh.local_quats)
    assert np.array_equal(third.root_positions, fresh.root_positions)


def test_exaggerate_basis_built_once_per_pre_exaggerate_state(walk, walk_sm, monkeypatch):
    """A w_r move re-runs exaggerate with the cached pose_offset_basis of the state before it (one basis
    per such state); the result matches the plain technique call (to rounding: the basis reorders sums)."""
    if not hasattr(staggered, "pose_offset_basis"):
        pytest.skip("this staggered has no pose_offset_basis yet (eval-speed)")
    calls = []
    real = staggered.pose_offset_basis
    monkeypatch.setattr(staggered, "pose_offset_basis", lambda sm: calls.append(1) or real(sm))
    s = _fresh(walk, [])
    for w in (0.3, 0.6, -0.4):
        s.set_ops([{"op": "cull", "percent": 70.0}, {"op": "exaggerate", "w_r": w}])
        got = s.edited()
        culled = staggered.cull(walk_sm, 70.0)
        want = staggered.evaluate(staggered.exaggerate(culled, list(range(culled.num_poses)), w))
        _same_motion(got, want, tol=1e-9)   # rounding only (basis: ~1e-15 rad per knot)
    assert len(calls) == 1
    s.set_ops([{"op": "cull", "percent": 40.0}, {"op": "exaggerate", "w_r": 0.3}])
    s.edited()
    assert len(calls) == 2   # another pre-exaggerate state: its own basis


def test_propagate_several_frames_and_repetitions(walk):
    m = walk
    j = m.skeleton.names[2]
    op = {"op": "propagate", "frames": [20, 100], "deltas": [{j: [15.0, 0, 0]}, {j: [0, -10.0, 0]}], "sigma": 0.5,
          "repetitions": "discard"}
    s = _fresh(walk, [op])
    edited = np.stack([R.apply_pose_deltas(m.local_quats[f], m.skeleton, d) for f, d in
                       [(20, {j: [15.0, 0, 0]}), (100, {j: [0, -10.0, 0]})]])
    want = wand.propagate(m, [20, 100], edited, sigma=0.5, repetitions=False)
    _same_motion(s.edited(), want, tol=1e-9)
    keep = _fresh(walk, [dict(op, repetitions="keep")]).edited()
    assert quat_angle(keep.local_quats, s.edited().local_quats).max() > 1e-6


def test_guided_warp_same_duration_backward_and_free_length(walk):
    m = walk
    s = _fresh(walk, [{"op": "guided_warp", "duration": m.duration, "skip": 4,
                               "reference": {"segment": [0.5, 1.5]}}])
    out = s.edited()
    warp = s.warp_curve()
    assert out.num_frames == m.num_frames
    # same duration: the upsampled search (u = 2) of timewarp.guided_warp. (Against a segment of the same walk,
    # same speed, the default input-time weighting keeps the walk's timing: eq. 1 used to retime it by > 1
    # frame only because it prefers fewer output frames; issue 25.)
    seg = m.slice(int(round(0.5 / m.frame_time)), int(round(1.5 / m.frame_time)) + 1)
    _, direct = timewarp.guided_warp(m, seg, m.num_frames, skip=4)
    np.testing.assert_allclose(warp, direct, atol=1e-9)
    s = _fresh(walk, [{"op": "guided_warp", "duration": 0.8 * m.duration, "skip": 4, "backward": True}])
    s.edited()
    w = s.warp_curve()
    assert w[0] == pytest.approx(m.duration, abs=1e-6) and np.all(np.diff(w) <= 1e-9)  # plays backwards
    s = _fresh(walk, [{"op": "guided_warp", "free_length": True, "skip": 4}])
    n = s.edited().num_frames
    ref = timewarp.guided_warp(m, m, None, skip=4)[0]   # the function's own free-length search (warp_search)
    assert n == ref.num_frames


def test_replay_of_4000_ops_is_linear(walk, monkeypatch):
    """Each op runs once; each op's canonical JSON is made once (no per-prefix re-serialisation); a change of
    the last op replays one op."""
    m = walk.slice(0, 10)
    calls, dumps = [0], [0]
    run = R.RUNNERS[O.EditFrame]

    def counted(state, op, r):
        calls[0] += 1
        return run(state, op, r)

    canonical = O.canonical

    def counted_dumps(v):
        dumps[0] += 1
        return canonical(v)

    batch = R.BATCHED[O.EditFrame]

    def counted_batch(state, ops):   # a run of edit_frame ops applied in one pass counts each of them
        calls[0] += len(ops)
        return batch(state, ops)

    monkeypatch.setitem(R.RUNNERS, O.EditFrame, counted)
    monkeypatch.setitem(R.BATCHED, O.EditFrame, counted_batch)
    monkeypatch.setattr(O.base, "canonical", counted_dumps)   # what Op.key calls
    j = m.skeleton.names[1]
    n = 4000
    s = Session(m, [{"op": "edit_frame", "frame": i % 10, "deltas": {j: [0.01, 0, 0]}} for i in range(n)])
    e = s.edited()
    assert calls[0] == n and dumps[0] == n
    s.replace(-1, {"op": "edit_frame", "frame": 0, "deltas": {j: [0.02, 0, 0]}})
    s.edited()
    assert calls[0] == n + 1 and dumps[0] == n + 1
    s.undo()
    assert s.edited() is e and calls[0] == n + 1  # the previous final state is still cached
    # closed form: 400 edits of 0.01 degree about x on each frame compose to 4 degrees
    ang = quat_angle(m.local_quats[:, 1], e.local_quats[:, 1])
    np.testing.assert_allclose(np.degrees(ang), 4.0, atol=1e-6)


def test_absent_staggered_function_gives_a_clear_error(walk, monkeypatch):
    monkeypatch.delattr(staggered, "ik_pose")
    s = _fresh(walk, [{"op": "ik_pose", "pose": 1, "joint": "Hips", "target": [0, 0, 0]}])
    with pytest.raises(ValueError, match=r"^ops\[0\] \(ik_pose\): op needs staggered\.ik_pose"):
        s.edited()


def test_warm_largest_skip_serves_smaller_skips_with_the_same_results(walk):
    # a skip slider's largest value is warmed once; every smaller skip is sliced from it (same numbers)
    m = walk
    warmed = Session(m)
    op = {"op": "guided_warp", "duration": 0.7 * m.duration, "skip": 12}
    assert warmed.warm(("warp_tables", [op])).result() == 1
    for skip in (3, 6, 12):
        for extra in ({}, {"backward": True}):
            ops = [dict(op, skip=skip, **extra)]
            warmed.set_ops(ops)
            fresh = Session(m, ops=ops)
            np.testing.assert_array_equal(warmed.edited().local_quats, fresh.edited().local_quats)
            np.testing.assert_array_equal(warmed.warp_curve(), fresh.warp_curve())


def test_replay_computes_no_timing_warnings_until_asked(walk, monkeypatch):
    """The staggered edits leave their timing warnings unread (computed on first read); the replay, its cache
    (whose byte estimate walks each state's metadata) included, never reads them: only
    Session.timing_warnings / messages compute those of the last staggered state, once."""
    from stagger_nb.staggered import timing_report
    calls = []
    real = timing_report._timing_warnings
    monkeypatch.setattr(timing_report, "_timing_warnings", lambda *a, **k: calls.append(1) or real(*a, **k))
    s = _fresh(walk, [{"op": "cull", "percent": 60.0}, {"op": "exaggerate", "w_r": 0.3},
                              {"op": "succession", "root": "Hips", "s": 0.3, "l": 3.0},
                              {"op": "random_timing", "tau": 0.05, "seed": 1}])
    s.edited()
    assert calls == []
    summary, found = s.timing_warnings()
    assert found and len(calls) == 1          # this succession does cross poses (else the check is empty)
