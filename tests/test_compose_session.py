"""Issue 24 in a session: the ops that combine the papers replay the composition of the techniques' public
functions (checked against that composition written out by hand), refuse bad regions naming the field, and replay
bit-exactly after save and load (here and in a fresh interpreter)."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import REPO

from stagger_nb import data, timewarp, wand, write_bvh
from stagger_nb import staggered as st
from stagger_nb.session import Session
from stagger_nb.session.runners import even_upsample


@pytest.fixture(scope="module")
def walk():
    return data.load("walk")


@pytest.fixture(scope="module")
def slow_walk(walk):
    n = walk.num_frames
    return timewarp.linear_warp(walk, int(round((n - 1) * 1.5)) + 1)[0]


def _falloff_at(m, times, frame, sigma=None, frame_range=None):
    """The wand's falloff of ``m`` around ``frame`` read at ``times`` (seconds), by hand."""
    w = wand.falloff(m, frame, sigma=sigma, frame_range=frame_range)
    return np.interp(np.asarray(times) / m.frame_time, np.arange(m.num_frames), w)


def test_propagated_edit_pose_is_the_staggered_edit_with_the_wands_weights(walk):
    s = Session(walk)
    sm = s.extraction()
    k = 6
    f = int(round(sm.pose_times[k] / walk.frame_time))
    s.set_ops([{"op": "edit_pose", "pose": k, "deltas": {"LeftArm": [0.0, 0.0, 20.0]}, "propagate": True}])
    w = _falloff_at(walk, sm.pose_times, f)
    w[k] = 1.0
    by_hand = st.edit_pose(sm, k, deltas={"LeftArm": np.radians([0.0, 0.0, 20.0])}, weights=w)
    assert np.array_equal(s.edited().local_quats, st.evaluate(by_hand).local_quats)
    # some poses get the whole edit, some none, some part of it: a falloff, not a constant
    assert w.max() == 1.0 and w.min() < 0.05 and np.sum(w > 0.9) >= 3


def test_propagated_ik_and_exaggeration_with_sigma_and_range(walk):
    s = Session(walk)
    sm = s.extraction()
    sigma = 1.5 * s.wand_graph().default_sigma
    s.set_ops([{"op": "exaggerate", "w_r": 0.6, "poses": [4, 9], "propagate": True, "sigma": sigma,
                "frame_range": [20, 330]}])
    frames = np.rint(sm.pose_times[[4, 9]] / walk.frame_time).astype(int)
    W = np.stack([_falloff_at(walk, sm.pose_times, f, sigma, (20, 330)) for f in frames])
    W[0, 4] = W[1, 9] = 1.0
    M = W[:, [4, 9]].T                          # each edited pose keeps exactly its own offset (interpolation)
    W = np.linalg.lstsq(M, np.eye(2), rcond=1e-10)[0].T @ W
    W[:, [4, 9]] = np.eye(2)
    by_hand = st.exaggerate(sm, [4, 9], 0.6, weights=W)
    np.testing.assert_allclose(s.staggered().values, by_hand.values, rtol=0, atol=1e-12)
    # the IK edit: the target is met at its pose, the limb change spread with the falloff
    s.set_ops([{"op": "ik_pose", "pose": 6, "joint": "LeftHand", "target": [30.0, 100.0, 60.0], "propagate": True}])
    w = _falloff_at(walk, sm.pose_times, int(round(sm.pose_times[6] / walk.frame_time)))
    res = st.ik_pose(sm, 6, "LeftHand", [30.0, 100.0, 60.0], weights=w)
    assert np.array_equal(s.staggered().values, res.staggered.values)


@pytest.mark.parametrize("op", [{"op": "succession", "root": "LeftShoulder", "s": 0.03, "l": 1.5},
                                {"op": "random_timing", "tau": 0.04, "seed": 3}])
def test_timing_in_a_region_is_the_timing_edit_scaled_by_the_falloff(walk, op):
    s = Session(walk)
    sm = s.extraction()
    s.set_ops([dict(op, falloff={"frame": 150, "sigma": None})])
    w = _falloff_at(walk, sm.pose_times, 150)
    kw = {k: v for k, v in op.items() if k != "op"}
    by_hand = getattr(st, op["op"])(sm, weights=w, **kw)
    assert np.array_equal(s.staggered().refinements, by_hand.refinements)
    np.testing.assert_allclose(s.pose_falloff(150), w, rtol=0, atol=1e-15)


def test_a_region_past_the_clip_is_refused_naming_the_field(walk):
    s = Session(walk, ops=[{"op": "succession", "root": "Hips", "s": 0.02, "falloff": {"frame": 999}}])
    with pytest.raises(ValueError, match=r"^ops\[0\] \(succession\): falloff\.frame: 999 is outside the 361 frames"):
        s.edited()
    s = Session(walk, ops=[{"op": "edit_pose", "pose": 6, "deltas": {"LeftArm": [0, 0, 5]}, "propagate": True,
                            "frame_range": [0, 50]}])
    with pytest.raises(ValueError, match=r"^ops\[0\] \(edit_pose\): frame_range: the edited pose's source frame"):
        s.edited()


def test_guide_poses_retimes_the_poses_through_the_guided_warp(walk, slow_walk):
    s = Session(walk)
    s.use_reference("<memory:slow>", slow_walk)
    sm = s.extraction()
    s.set_ops([{"op": "guide_poses", "reference": {"path": "<memory:slow>"}}])
    out = s.staggered()
    n = slow_walk.num_frames                      # default duration: the reference's
    u = even_upsample(walk.num_frames, n, timewarp.required_upsample(walk.num_frames, n))
    _, warp = timewarp.guided_warp(walk, slow_walk, n, upsample=u)
    xs, inv = np.unique(np.maximum.accumulate(warp), return_inverse=True)
    ys = np.bincount(inv, np.arange(n) * walk.frame_time) / np.bincount(inv)
    np.testing.assert_allclose(out.pose_times, np.interp(sm.pose_times, xs, ys), rtol=0, atol=1e-12)
    assert np.array_equal(out.refinements, sm.refinements)           # the staggering is kept as it was
    assert np.array_equal(s.warp_curve(0), warp)
    # the timing edits stay editable after it: a succession adds exactly s d^l to the guided poses' refinements
    s.add({"op": "succession", "root": "LeftShoulder", "s": 0.02, "l": 1.0})
    assert np.array_equal(s.staggered().refinements, st.succession(out, root="LeftShoulder", s=0.02, l=1.0).refinements)


def test_a_pose_edit_after_guide_poses_reads_the_falloff_at_the_source_times(walk, slow_walk):
    edit = {"op": "edit_pose", "pose": 6, "deltas": {"LeftArm": [0.0, 0.0, 20.0]}, "propagate": True}
    guide = {"op": "guide_poses", "reference": {"path": "<memory:slow>"}}
    a, b = Session(walk), Session(walk)
    for s in (a, b):
        s.use_reference("<memory:slow>", slow_walk)
    a.set_ops([guide, edit])
    b.set_ops([edit, guide])
    # the knot values do not depend on the pose times: the same weights either way
    np.testing.assert_allclose(a.staggered().values, b.staggered().values, rtol=0, atol=1e-12)
    assert np.array_equal(a.staggered().pose_times, b.staggered().pose_times)


def _session_ops(ref_path: str) -> list:
    return [{"op": "cull", "percent": 80.0},
            {"op": "edit_pose", "pose": 5, "deltas": {"LeftArm": [0.0, 0.0, 20.0]}, "propagate": True},
            {"op": "ik_pose", "pose": 3, "joint": "RightHand", "target": [-30.0, 100.0, 40.0], "propagate": True,
             "sigma": 0.8},
            {"op": "exaggerate", "w_r": 0.4, "poses": [2], "propagate": True},
            {"op": "succession", "root": "LeftShoulder", "s": 0.03, "l": 1.5, "falloff": {"frame": 150, "sigma": None}},
            {"op": "random_timing", "tau": 0.02, "seed": 5, "falloff": {"frame": 60, "sigma": 1.2,
                                                                        "frame_range": [0, 200]}},
            {"op": "guide_poses", "reference": {"path": ref_path}},
            {"op": "keep_contacts"}]


def test_sessions_with_the_combined_ops_replay_bit_exactly_after_save_and_load(walk, slow_walk, tmp_path):
    ref = tmp_path / "slow.bvh"
    write_bvh(slow_walk, ref)
    s = Session(walk, ops=_session_ops(str(ref)))
    edited = s.edited()
    p = tmp_path / "combined.json"
    s.save(p)
    again = Session.load(p)
    assert again.ops == s.ops
    e2 = again.edited()
    assert np.array_equal(e2.local_quats, edited.local_quats) and np.array_equal(e2.root_positions,
                                                                                 edited.root_positions)
    # and in a fresh interpreter (no cache, no module state shared with this one) on the same machine set-up: it
    # inherits this process's environment, since OpenBLAS picks its kernels from it (OPENBLAS_CORETYPE,
    # OPENBLAS_L2_SIZE: another kernel moves the wand's solves by ~1e-8, which is not a replay difference)
    out = tmp_path / "replayed.npz"
    code = ("import sys, numpy as np; from stagger_nb.session import Session; "
            f"e = Session.load({str(p)!r}).edited(); np.savez({str(out)!r}, q=e.local_quats, r=e.root_positions)")
    env = {**os.environ, "PYTHONPATH": str(REPO), "OPENBLAS_NUM_THREADS": "1"}
    subprocess.run([sys.executable, "-c", code], check=True, timeout=600, cwd=REPO, env=env)
    z = np.load(out)
    assert np.array_equal(z["q"], edited.local_quats) and np.array_equal(z["r"], edited.root_positions)
    assert json.loads(p.read_text())["ops"][6]["op"] == "guide_poses"
