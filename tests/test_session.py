"""Edit-session model: op validation, replay with memoised prefixes, undo/redo, JSON save/load, BVH export."""
from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest
from helpers import assert_load_names_the_field, assert_refuses_the_source

import stagger_nb as sn
from stagger_nb.core.rotations import quat_angle
from stagger_nb.session import OPS, Session, validate_op
from stagger_nb.session.ops import Op, number
from stagger_nb.session.runners import RUNNERS

CLIP = "bandai_run_cycle.bvh"  # 24 frames, small and fast
REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def counting_op():
    """A motion op (an Op subclass + its runner) that shifts the root by ``dx`` and counts its calls
    (removed afterwards)."""
    calls = []

    @dataclass(frozen=True)
    class Shift(Op):
        name: ClassVar[str] = "_test_shift"
        needs: ClassVar[str] = "motion"
        dx: float = field(metadata={"check": number()})

    def run(m, op, ctx):
        calls.append(op.dx)
        return m.replace(root_positions=m.root_positions + np.array([op.dx, 0.0, 0.0]))

    RUNNERS[Shift] = run
    yield calls
    del OPS["_test_shift"], RUNNERS[Shift]


@pytest.fixture
def session(shared_motion):
    from conftest import shared_clip_path
    return Session.from_bvh(shared_clip_path(CLIP))


def _joint(m, k=3):
    return m.skeleton.names[k]


# -- validation --------------------------------------------------------------------------------------
@pytest.mark.parametrize("op, field", [
    ({"op": "nope"}, "op.op"),
    ({"op": "succession", "root": "Hips"}, "op.s"),                          # missing required
    ({"op": "succession", "root": "Hips", "s": "0.1"}, "op.s"),              # wrong type
    ({"op": "succession", "root": "Hips", "s": 0.1, "speed": 1}, "op.speed"),  # unknown field
    ({"op": "cull", "percent": 120}, "op.percent"),                           # out of range
    ({"op": "random_timing", "tau": 0.1, "seed": 1.5}, "op.seed"),           # non-integer seed
    ({"op": "succession", "root": "Hips", "s": True}, "op.s"),               # bool is not a number
    ({"op": "edit_frame", "frame": 2, "deltas": {"Hips": [1, 2]}}, "op.deltas.Hips"),
    ({"op": "guided_warp", "duration": 1.0, "reference": {"segment": [2, 1]}}, "op.reference.segment"),
    ("succession", "op"),
])
def test_validate_op_names_the_bad_field(op, field):
    with pytest.raises(ValueError, match=rf"^{field.replace('.', '[.]')}\b"):
        validate_op(op)


def test_validate_op_fills_defaults_and_copies():
    op = {"op": "random_timing", "tau": 0.05, "joints": ["A", "B"]}
    v = validate_op(op)
    assert v == {"op": "random_timing", "tau": 0.05, "seed": 0, "joints": ["A", "B"], "limit": 1.5}
    v["joints"].append("C")
    assert op["joints"] == ["A", "B"]  # the caller's dict is not aliased


# -- replay ------------------------------------------------------------------------------------------
def test_edit_frame_rotates_one_joint_at_one_frame(session):
    m = session.source
    j = 3
    session.add({"op": "edit_frame", "frame": 5, "deltas": {_joint(m, j): [0.0, 30.0, 0.0]}})
    e = session.edited()
    ang = quat_angle(m.local_quats, e.local_quats)  # (F, J) radians
    # closed form: post-multiplying by a 30-degree rotation changes that joint by exactly 30 degrees
    assert ang[5, j] == pytest.approx(np.radians(30.0), abs=1e-9)  # 1e-9: arctan2 round-off
    ang[5, j] = 0.0
    assert ang.max() < 1e-7  # every other rotation untouched (1e-7: renormalisation round-off in arccos form)
    assert np.array_equal(e.root_positions, m.root_positions)


def test_unknown_joint_in_replay_names_op_and_field(session):
    session.add({"op": "edit_frame", "frame": 1, "deltas": {"NoSuchJoint": [1, 0, 0]}})
    with pytest.raises(ValueError, match=r"ops\[0\] \(edit_frame\): deltas.NoSuchJoint"):
        session.edited()


def test_prefix_memo_replays_only_the_tail(session, counting_op):
    session.set_ops([{"op": "_test_shift", "dx": 1.0}, {"op": "_test_shift", "dx": 2.0}])
    e1 = session.edited()
    assert counting_op == [1.0, 2.0]
    session.replace(-1, {"op": "_test_shift", "dx": 5.0})
    e2 = session.edited()
    assert counting_op == [1.0, 2.0, 5.0]  # the first op came from the memo
    np.testing.assert_array_equal(e2.root_positions - e1.root_positions,
                                  np.broadcast_to([3.0, 0.0, 0.0], e1.root_positions.shape))
    session.undo()
    assert session.edited() is e1  # the previous result is memoised too
    assert counting_op == [1.0, 2.0, 5.0]


def test_progress_callback_counts_computed_ops(session, counting_op):
    seen = []
    session.set_ops([{"op": "_test_shift", "dx": 1.0}, {"op": "_test_shift", "dx": 2.0}])
    session.edited(progress=lambda d, t, label: seen.append((d, t, label)))
    assert seen == [(0, 2, "_test_shift"), (1, 2, "_test_shift"), (2, 2, "done")]


def test_undo_redo_matches_a_history_list(session, counting_op, rng):
    """Random edit sequence vs. a brute-force list of snapshots."""
    history, pos = [[]], 0
    for step in range(40):
        action = rng.integers(0, 4)
        if action == 0 or not session.ops:
            changed = session.add({"op": "_test_shift", "dx": float(step)})
        elif action == 1:
            changed = session.replace(int(rng.integers(0, len(session))), {"op": "_test_shift", "dx": -float(step)})
        elif action == 2:
            ok = session.undo()
            assert ok == (pos > 0)
            pos -= ok
            assert session.ops == history[pos]
            continue
        else:
            ok = session.redo()
            assert ok == (pos < len(history) - 1)
            pos += ok
            assert session.ops == history[pos]
            continue
        assert changed
        history = history[: pos + 1] + [session.ops]
        pos += 1
        assert session.ops == history[pos]
    assert session.set_ops(session.ops) is False  # no change, no undo step


def test_observers_are_called_on_change(session, counting_op):
    seen = []
    session.observe(lambda s: seen.append(len(s)))
    session.add({"op": "_test_shift", "dx": 1.0})
    session.add({"op": "_test_shift", "dx": 1.0})
    session.undo()
    session.clear()
    assert seen == [1, 2, 1, 0]


# -- files -------------------------------------------------------------------------------------------
def _edit_ops(m):
    return [{"op": "edit_frame", "frame": 2, "deltas": {_joint(m, 4): [5.0, -3.0, 12.5]}},
            {"op": "edit_frame", "frame": 7, "deltas": {_joint(m, 8): [0.1, 0.2, 0.3]}}]


@pytest.mark.parametrize("embed", [False, True])
def test_save_load_round_trip_bit_for_bit(session, tmp_path, embed):
    session.set_ops(_edit_ops(session.source))
    p = tmp_path / "s.json"
    session.save(p, embed_source=embed)
    data = json.loads(p.read_text())
    assert ("motion" in data["source"]) == embed
    s2 = Session.load(p)
    assert s2.ops == session.ops
    a, b = session.edited(), s2.edited()
    assert np.array_equal(a.local_quats, b.local_quats) and np.array_equal(a.root_positions, b.root_positions)
    assert not list(tmp_path.glob(".tmp-*"))  # the atomic write left no temporary file


def _technique_sessions(m, path):
    """Sessions using every technique: staggered cull/succession/random timing/pose edit, the magic wand, a
    guided warp."""
    names = m.skeleton.names
    return [Session.from_bvh(path, ops=[
                {"op": "cull", "percent": 60.0},
                {"op": "edit_pose", "pose": 1, "deltas": {names[3]: [5.0, 0.0, -4.0]}},
                {"op": "succession", "root": names[1], "s": 0.03, "l": 2.0},
                {"op": "random_timing", "tau": 0.04, "seed": 3, "joints": None}]),
            Session.from_bvh(path, ops=[{"op": "propagate", "frame": 50, "deltas": {names[2]: [20.0, 0.0, 0.0]},
                                         "sigma": 0.3, "frame_range": [10, 120]}]),
            Session.from_bvh(path, ops=[{"op": "guided_warp", "duration": 0.8, "skip": 6, "keytimes": [[0.5, 0.3]],
                                         "reference": {"segment": [0.1, 0.9]}}])]


def test_reload_in_a_new_process_is_bit_for_bit(session, tmp_path):
    from conftest import shared_clip_path
    path = shared_clip_path("xia_angry_run.bvh")
    sessions = [session] + _technique_sessions(sn.read_bvh(path), path)
    session.set_ops(_edit_ops(session.source))
    files = []
    for i, s in enumerate(sessions):
        files.append(tmp_path / f"s{i}.json")
        s.save(files[-1])
    out = tmp_path / "edited.npz"
    code = ("import sys, numpy as np; from stagger_nb.session import Session\n"
            "ms = [Session.load(p).edited() for p in sys.argv[2:]]\n"
            "np.savez(sys.argv[1], **{f'q{i}': m.local_quats for i, m in enumerate(ms)},"
            " **{f'r{i}': m.root_positions for i, m in enumerate(ms)})")
    subprocess.run([sys.executable, "-c", code, str(out)] + [str(f) for f in files], check=True, cwd=REPO,
                   timeout=300)  # generous: loaded CI machines
    got = np.load(out)
    for i, s in enumerate(sessions):
        e = s.edited()
        # each session really edits (so equality is not the trivial source == source)
        assert e.num_frames != s.source.num_frames or np.abs(e.local_quats - s.source.local_quats).max() > 1e-6
        assert np.array_equal(got[f"q{i}"], e.local_quats), s
        assert np.array_equal(got[f"r{i}"], e.root_positions), s


@pytest.mark.parametrize("mutate, field", [
    (lambda d: d["ops"].append({"op": "rm -rf"}), r"ops\[2\]\.op"),
    (lambda d: d["ops"][0].update(frame="2"), r"ops\[0\]\.frame"),
    (lambda d: d.update(format="pickle"), r"format"),
    (lambda d: d.update(version=99), r"version"),
    (lambda d: d.update(extra=1), r"extra"),
    (lambda d: d.update(ops={"op": "cull"}), r"ops"),
    (lambda d: d["source"].update(sha256="0" * 64), r"source\.sha256"),
    (lambda d: d["source"].update(path="/nonexistent/x.bvh"), r"source\.path"),
])
def test_load_validates_and_names_the_field(session, tmp_path, mutate, field):
    session.set_ops(_edit_ops(session.source))
    p = tmp_path / "s.json"
    session.save(p)
    d = json.loads(p.read_text())
    mutate(d)
    p.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=rf"^{field}"):
        Session.load(p)


def test_load_rejects_nan_and_garbage(session, tmp_path):
    session.set_ops([{"op": "edit_frame", "frame": 2, "deltas": {_joint(session.source): [1.0, 0.0, 0.0]}}])
    p = tmp_path / "s.json"
    session.save(p)
    p.write_text(p.read_text().replace("1.0", "NaN", 1))
    with pytest.raises(ValueError, match="NaN"):
        Session.load(p)
    p.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        Session.load(p)


def _embedded(d):
    return d["source"]["motion"]


@pytest.mark.parametrize("mutate, field", [
    (lambda d: d["ops"].append({"op": "cull", "percent": 10 ** 400}), r"ops\[2\]\.percent"),  # no float holds it
    (lambda d: d.update(extract_options={"bogus": 1}), r"extract_options\.bogus"),
    (lambda d: d.update(extract_options=[1]), r"extract_options"),
    (lambda d: _embedded(d).update(channels=[[1, 2]] * len(_embedded(d)["names"])), r"source\.motion\.channels\[0\]"),
    (lambda d: _embedded(d).update(parents="abc"), r"source\.motion\.parents"),
    (lambda d: _embedded(d).update(local_quats=[[1, 2], [3]]), r"source\.motion\.local_quats"),
    (lambda d: _embedded(d).update(local_quats=[[["1", 0, 0, 0]]]), r"source\.motion\.local_quats"),
    (lambda d: _embedded(d).update(root_positions=[[10 ** 400, 0, 0]]), r"source\.motion\.root_positions"),
    (lambda d: _embedded(d).update(end_sites={"x": [0, 0, 1]}), r"source\.motion\.end_sites"),
    (lambda d: _embedded(d).update(evil=1), r"source\.motion\.evil"),
    (lambda d: d.update(source={"path": __file__}), r"source\.path"),                  # not a BVH file
])
def test_load_names_the_field_of_hostile_values(session, tmp_path, mutate, field):
    session.set_ops(_edit_ops(session.source))
    p = tmp_path / "s.json"
    session.save(p, embed_source=True)
    assert_load_names_the_field(p, mutate, field)


def test_load_refuses_deeply_nested_json_and_binary_garbage(tmp_path):
    p = tmp_path / "s.json"
    p.write_text("[" * 200_000 + "]" * 200_000)  # past the JSON decoder's recursion limit
    with pytest.raises(ValueError, match="^session: .* nests JSON too deeply"):
        Session.load(p)
    p.write_bytes(b'{"format": "\xff\xfe"}')
    with pytest.raises(ValueError, match="^session: .* is not UTF-8 JSON text"):
        Session.load(p)


@pytest.mark.parametrize("op, field", [
    ({"op": "linear_warp", "duration": 1e12}, "duration"),   # 10**13 output frames must not be allocated
    ({"op": "resample", "frame_time": 1e-300}, "frame_time"),
])
def test_absurd_output_sizes_are_refused_before_allocating(session, op, field):
    session.set_ops([op])
    with pytest.raises(ValueError, match=rf"^ops\[0\] \({op['op']}\): {field}: .* more than 100 times"):
        session.edited()


def test_export_refuses_the_source_and_writes_atomically(session, tmp_path):
    src = tmp_path / "src.bvh"
    sn.write_bvh(session.source, src)
    s = Session.from_bvh(src, ops=_edit_ops(session.source))
    assert_refuses_the_source(s.export_bvh, src, tmp_path)
    out = tmp_path / "out.bvh"
    s.export_bvh(out)
    back = sn.read_bvh(out)
    # BVH stores Euler degrees as text: compare rotations up to the writer's printed precision
    assert quat_angle(back.local_quats, s.edited().local_quats).max() < 1e-5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.bvh", "out.bvh", "src.bvh"]


def test_expensive_heads_are_cached_and_reported(shared_motion):
    """The extraction runs once per source however the tail changes; busy listeners see it start/stop."""
    m = shared_motion("xia_angry_run.bvh")
    s = Session(m)
    seen = []
    s.observe_busy(lambda kind, started: seen.append((kind, started)))
    s.set_ops([{"op": "succession", "root": m.skeleton.names[1], "s": 0.02, "l": 1.0}])
    a = s.edited()
    for l in (1.5, 2.0):
        s.replace(0, {"op": "succession", "root": m.skeleton.names[1], "s": 0.02, "l": l})
        s.edited()
    assert seen == [("extract", True), ("extract", False)]
    s.undo()
    s.undo()
    assert s.edited() is a
    assert s.staggered() is s.states()[0] and s.extraction().num_poses == s.staggered().num_poses


def test_in_memory_reference_under_any_name(session):
    """``use_reference`` resolves the path reference to the given Motion (non-ASCII names included: the
    key is the op's canonical JSON, where such names are escaped)."""
    ref_motion = session.source.slice(0, 12)
    ref = session.use_reference("<memory:référence>", ref_motion)
    session.set_ops([{"op": "guided_warp", "duration": 0.5, "skip": 4, "reference": ref}])
    n = int(round(0.5 / session.source.frame_time)) + 1
    assert session.edited().num_frames == n
    from stagger_nb import timewarp
    _, warp = timewarp.guided_warp(session.source, ref_motion, n, skip=4)
    np.testing.assert_array_equal(session.warp_curve(), warp)  # the warp was guided by ref_motion
    with pytest.raises(ValueError, match="^motion"):
        session.use_reference("<memory:x>", "not a motion")


def test_deprecated_register_op_and_op_registry_still_work(session):
    import stagger_nb.session as S
    with pytest.warns(DeprecationWarning, match="register_op"):
        cls = S.register_op("_old_shift", "motion", {"dx": (None, Session.REQUIRED), "k": (None, 2)},
                            lambda st, p, ctx: st.replace(root_positions=st.root_positions + [p["dx"] * p["k"], 0, 0]))
    try:
        with pytest.warns(DeprecationWarning, match="OP_REGISTRY"):
            assert S.OP_REGISTRY["_old_shift"] is cls
        session.set_ops([{"op": "_old_shift", "dx": 1.5}])
        assert session.ops == [{"op": "_old_shift", "dx": 1.5, "k": 2}]
        d = session.edited().root_positions - session.source.root_positions
        np.testing.assert_allclose(d, np.broadcast_to([3.0, 0, 0], d.shape))
    finally:
        del OPS["_old_shift"], RUNNERS[cls]
