"""staggered.refine (staggered/timing.py): one joint's knot of one pose moved in time (the dope sheet's drag), and
its session op."""
from __future__ import annotations

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import staggered
from stagger_nb.session import Session


@pytest.fixture
def walk_sm():
    m = sn.data.load("walk")
    return m, staggered.extract(m)


def _knots(sm):
    return sm.pose_times[:, None] + sm.refinements


def _interior_knot(sm, j):
    """(pose k, a time strictly inside the open interval of its neighbours, away from the old knot)."""
    T = _knots(sm)[:, j]
    k = int(np.argmax(np.diff(T)[1:-1] + np.diff(T)[:-2])) + 1   # the widest room
    return k, T[k] + 0.3 * (T[k + 1] - T[k])


def test_refine_moves_exactly_one_knot_and_only_that_joint(walk_sm):
    m, sm = walk_sm
    j = sm.skeleton.index("LeftForeArm")
    k, t = _interior_knot(sm, j)
    new = staggered.refine(sm, k, "LeftForeArm", t)
    T0, T1 = _knots(sm), _knots(new)
    assert abs(T1[k, j] - t) < 1e-12                     # the knot is where it was put (float rounding only)
    moved = np.abs(T1 - T0) > 0
    assert moved.sum() == 1 and moved[k, j]
    np.testing.assert_array_equal(new.pose_times, sm.pose_times)
    np.testing.assert_array_equal(new.root_refinements, sm.root_refinements)
    a, b = staggered.evaluate(sm), staggered.evaluate(new)
    others = [i for i in range(sm.num_joints) if i != j]
    np.testing.assert_array_equal(a.local_quats[:, others], b.local_quats[:, others])   # evaluated per joint
    np.testing.assert_array_equal(a.root_positions, b.root_positions)
    assert np.abs(a.local_quats[:, j] - b.local_quats[:, j]).max() > 1e-4   # the joint's motion did change


def test_refine_carries_the_segments_on_normalised_time(walk_sm):
    """Splines and displacement maps live on normalised segment time (§3): at the moved knot, and at the same
    fraction of each of its two segments, the joint takes the values it had at the old knot's fractions."""
    m, sm = walk_sm
    j = sm.skeleton.index("RightLeg")
    k, t = _interior_knot(sm, j)
    new = staggered.refine(sm, k, j, t)
    T0, T1 = _knots(sm)[:, j], _knots(new)[:, j]
    for u in (0.0, 0.25, 0.6):
        old_times = [T0[k] + u * (T0[k + 1] - T0[k]), T0[k - 1] + u * (T0[k] - T0[k - 1])]
        new_times = [T1[k] + u * (T1[k + 1] - T1[k]), T1[k - 1] + u * (T1[k] - T1[k - 1])]
        qa = staggered.evaluate(sm, np.array(old_times)).local_quats[:, j]
        qb = staggered.evaluate(new, np.array(new_times)).local_quats[:, j]
        # the same normalised time in the same segment: equal up to float rounding of t' (q ~ -q)
        assert np.abs(np.abs(np.sum(qa * qb, axis=1)) - 1).max() < 1e-9, u


def test_refine_of_the_root_moves_its_translation_knot_too(walk_sm):
    m, sm = walk_sm
    k, t = _interior_knot(sm, 0)
    new = staggered.refine(sm, k, "Hips", t)
    d = t - _knots(sm)[k, 0]
    assert abs((new.root_refinements - sm.root_refinements)[k] - d) < 1e-12
    assert np.count_nonzero(new.root_refinements - sm.root_refinements) == 1


def test_refine_refuses_out_of_order_and_end_knots(walk_sm):
    m, sm = walk_sm
    j = sm.skeleton.index("LeftFoot")
    T = _knots(sm)[:, j]
    k = 3
    for bad in (T[k + 1], T[k + 1] + 0.01, T[k - 1], T[k - 1] - 0.2):
        with pytest.raises(ValueError, match=r"time: LeftFoot's knot of pose 3 must stay between") as e:
            staggered.refine(sm, k, "LeftFoot", bad)
        assert f"{T[k - 1]:.3f} s < time < {T[k + 1]:.3f} s" in str(e.value)
    with pytest.raises(ValueError, match="pose: pose 0 is the clip's first frame"):
        staggered.refine(sm, 0, "LeftFoot", 0.01)
    with pytest.raises(ValueError, match="last frame"):
        staggered.refine(sm, -1, "LeftFoot", T[-1] - 0.01)
    with pytest.raises(ValueError, match="joints: "):
        staggered.refine(sm, k, "NoSuchJoint", T[k])
    with pytest.raises(ValueError, match="time must be finite"):
        staggered.refine(sm, k, "LeftFoot", float("nan"))
    with pytest.raises(ValueError, match="pose must be a pose index"):
        staggered.refine(sm, sm.num_poses, "LeftFoot", T[k])
    assert staggered.refine(sm, k, "LeftFoot", T[k]) is sm   # already there: nothing to do


def test_refine_op_replays_the_function_and_refuses_in_the_replay(walk_sm):
    m, sm = walk_sm
    j = sm.skeleton.index("LeftForeArm")
    k, t = _interior_knot(sm, j)
    s = Session(m, ops=[{"op": "refine", "pose": k, "joint": "LeftForeArm", "time": float(t)}])
    np.testing.assert_array_equal(s.staggered().refinements, staggered.refine(sm, k, j, t).refinements)
    assert s.ops == [{"op": "refine", "pose": k, "joint": "LeftForeArm", "time": float(t)}]
    bad = Session(m, ops=[{"op": "refine", "pose": k, "joint": "LeftForeArm", "time": float(_knots(sm)[k + 1, j])}])
    with pytest.raises(ValueError, match=r"ops\[0\] \(refine\).*must stay between"):
        bad.edited()
    with pytest.raises(ValueError, match=r"joint: no joint named 'Tail'"):
        Session(m, ops=[{"op": "refine", "pose": k, "joint": "Tail", "time": 1.0}]).edited()
