"""Issue 24 on the staggered side: pose weights on the geometric edits (one offset spread to every pose), per-pose
scales of the timing offsets, and the source time of every pose. Each result is compared with a closed form or
with the same edit written another way (a naive loop, the unweighted tool)."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data
from stagger_nb import staggered as st
from stagger_nb.core.rotations import quat_angle, quat_conj, quat_exp, quat_hemisphere, quat_log, quat_mul


@pytest.fixture(scope="module")
def sm():
    return st.extract(data.load("walk"))


def _spread_loop(offsets, weights):
    """spread_offsets the most straightforward way: pose by pose, joint by joint."""
    E, J, _ = offsets.shape
    K = weights.shape[1]
    out = np.zeros((K, J, 4))
    for k in range(K):
        for j in range(J):
            v = sum(weights[e, k] * quat_log(quat_hemisphere(offsets[e, j])) for e in range(E))
            out[k, j] = quat_exp(v)
    return out


def test_spread_offsets_matches_a_loop_and_keeps_exact_offsets(rng):
    offsets = quat_exp(rng.normal(scale=0.4, size=(3, 5, 3)))
    w = rng.uniform(-0.5, 1.5, size=(3, 7))
    w[:, 2] = [0.0, 1.0, 0.0]                     # pose 2 takes offset 1 exactly
    w[:, 4] = 0.0                                 # pose 4 none
    got = st.spread_offsets(offsets, w)
    assert np.max(quat_angle(got, _spread_loop(offsets, w))) < 1e-12
    assert np.array_equal(got[2], offsets[1])     # bit-identical, not exp(log δ)
    assert np.array_equal(got[4], np.tile([0.0, 0.0, 0.0, 1.0], (5, 1)))


def test_edit_pose_one_hot_weights_are_the_plain_edit(sm):
    k = 6
    w = np.zeros(sm.num_poses)
    w[k] = 1.0
    a = st.edit_pose(sm, k, deltas={"LeftArm": [0.0, 0.0, 0.35]}, root_offset=[1.0, 0.0, 0.0])
    b = st.edit_pose(sm, k, deltas={"LeftArm": [0.0, 0.0, 0.35]}, root_offset=[1.0, 0.0, 0.0], weights=w)
    ea, eb = st.evaluate(a), st.evaluate(b)
    assert np.array_equal(ea.local_quats, eb.local_quats) and np.array_equal(ea.root_positions, eb.root_positions)


def test_edit_pose_weights_give_every_pose_its_share_in_its_own_knots(sm, rng):
    k, j = 6, sm.skeleton.index("LeftArm")
    delta = np.array([0.1, -0.2, 0.3])                     # rotation vector, radians
    w = rng.uniform(0.0, 1.0, sm.num_poses)
    w[k] = 1.0
    out = st.edit_pose(sm, k, deltas={"LeftArm": delta}, weights=w)
    share = quat_exp(0.5 * w[:, None] * delta[None])       # exp(w log δ), log δ = δ / 2 (half-angle axis)
    # both knots of every pose: v̂ = v ⊕ δ_w, v̂⁰ = v⁰ ⊕ δ_w (§5.1, the mutual constraint)
    assert np.max(quat_angle(out.values[:, j], quat_mul(sm.values[:, j], share))) < 1e-12
    assert np.max(quat_angle(out.editing_knots[:, j], quat_mul(sm.editing_knots[:, j], share))) < 1e-9
    # the motion at each pose time (the plateau) is the old one post-multiplied by the share
    before, after = st.evaluate(sm, sm.pose_times), st.evaluate(out, sm.pose_times)
    assert np.max(quat_angle(after.local_quats[:, j], quat_mul(before.local_quats[:, j], share))) < 1e-9
    # other joints do not move (to the re-measuring's rounding)
    others = np.delete(np.arange(sm.num_joints), j)
    assert np.max(quat_angle(after.local_quats[:, others], before.local_quats[:, others])) < 1e-9
    # zero weights everywhere: nothing changes (the input itself)
    assert st.edit_pose(sm, k, deltas={"LeftArm": delta}, weights=np.zeros(sm.num_poses)) is sm


def test_exaggerate_with_one_hot_rows_is_the_plain_exaggeration(sm):
    ks = [3, 8]
    w = np.zeros((2, sm.num_poses))
    w[0, 3] = w[1, 8] = 1.0
    a = st.evaluate(st.exaggerate(sm, ks, 0.7, reference="mean"))
    b = st.evaluate(st.exaggerate(sm, ks, 0.7, reference="mean", weights=w))
    assert np.array_equal(a.local_quats, b.local_quats)
    # a spread row changes the poses it weights by their share of pose 3's offset (closed form at the knots)
    w[0, 5] = 0.5
    c = st.exaggerate(sm, ks, 0.7, reference="mean", weights=w)
    vals = sm.editing_knots
    mean = st.mean_pose(vals)
    d3 = quat_exp(0.7 * quat_log(quat_hemisphere(quat_mul(quat_conj(mean), vals[3]))))
    half = quat_exp(0.5 * quat_log(quat_hemisphere(d3)))
    assert np.max(quat_angle(c.values[5], quat_mul(sm.values[5], half))) < 1e-12


def test_ik_pose_weights_keep_the_solve_and_spread_the_limb_change(sm):
    k = 6
    base = st.ik_pose(sm, k, "LeftHand", [30.0, 100.0, 60.0])
    one = np.zeros(sm.num_poses)
    one[k] = 1.0
    same = st.ik_pose(sm, k, "LeftHand", [30.0, 100.0, 60.0], weights=one)
    assert np.array_equal(st.evaluate(base.staggered).local_quats, st.evaluate(same.staggered).local_quats)
    w = np.full(sm.num_poses, 0.5)
    res = st.ik_pose(sm, k, "LeftHand", [30.0, 100.0, 60.0], weights=w)
    assert res.error == pytest.approx(base.error, abs=1e-6)          # pose k keeps its solve
    delta = quat_mul(quat_conj(sm.values[k]), base.staggered.values[k])
    half = quat_exp(0.5 * quat_log(quat_hemisphere(delta)))
    other = [i for i in range(sm.num_poses) if i != k]
    assert np.max(quat_angle(res.staggered.values[other], quat_mul(sm.values[other], half[None]))) < 1e-9
    assert np.max(quat_angle(delta[None], np.tile([0, 0, 0, 1.0], (1, 1)))) > 0.05   # the solve moved the limb


@pytest.mark.parametrize("tool", ["succession", "random_timing"])
def test_timing_weights_scale_each_poses_offsets_before_the_saturation(sm, rng, tool):
    def run(**kw):
        if tool == "succession":
            return st.succession(sm, root="LeftShoulder", s=0.02, l=1.5, **kw)
        return st.random_timing(sm, tau=0.03, seed=4, **kw)
    w = rng.uniform(0.0, 1.0, sm.num_poses)
    w[[3, 7]] = 0.0
    # the paper's formula (no saturation): exactly w[k] times the offsets
    raw = run(limit=None)
    scaled = run(limit=None, weights=w)
    np.testing.assert_allclose(scaled.refinements - sm.refinements, w[:, None] * (raw.refinements - sm.refinements),
                               rtol=0, atol=1e-15)
    # saturated (the default): weights 1 are the plain edit, 0 leave the poses (all of them: the input itself)
    plain = run()
    assert np.array_equal(run(weights=np.ones(sm.num_poses)).refinements, plain.refinements)
    assert run(weights=np.zeros(sm.num_poses)) is sm
    sat = run(weights=w).refinements - sm.refinements
    # equal weights: the saturation only takes away from the scaled offsets, never adds: |kept| <= w |asked|
    asked = 0.6 * (raw.refinements - sm.refinements)
    even = run(weights=np.full(sm.num_poses, 0.6)).refinements - sm.refinements
    assert np.all(np.abs(even) <= np.abs(asked) + 1e-12) and np.all(even * asked >= 0)
    # unequal: where a region's edge squeezes a segment the lower-weight knot gives way (it may move more than
    # asked), and still every joint's knots stay in order, no segment plays more than the limit (1.5) faster
    src = sm.pose_times[:, None] + sm.refinements
    seg = np.diff(sm.pose_times[:, None] + sm.refinements + sat, axis=0)
    assert np.all(seg >= np.diff(src, axis=0) / st.TIMING_LIMIT - 1e-12)


def test_weights_are_checked(sm):
    with pytest.raises(ValueError, match=r"^weights must have shape \(14,\)"):
        st.succession(sm, root="Hips", s=0.01, weights=np.ones(3))
    with pytest.raises(ValueError, match="^weights must be finite"):
        st.edit_pose(sm, 2, deltas={"Hips": [0, 0, 0.1]}, weights=np.full(sm.num_poses, np.nan))
    with pytest.raises(ValueError, match=r"^weights must have shape \(2, 14\)"):
        st.exaggerate(sm, [1, 2], 0.5, weights=np.ones(sm.num_poses))


def test_source_pose_times_follow_retiming_insertion_deletion_and_cull(sm):
    t0 = np.array(sm.pose_times)
    assert np.array_equal(st.source_pose_times(sm), t0)                      # unedited: its own times
    moved = st.retime(sm, t0 * 1.5)
    assert np.array_equal(moved.pose_times, t0 * 1.5) and np.array_equal(st.source_pose_times(moved), t0)
    later = st.succession(moved, root="Hips", s=0.01)                          # timing edits carry the record
    assert np.array_equal(st.source_pose_times(later), t0)
    mid = 0.5 * (moved.pose_times[3] + moved.pose_times[4])
    ins = st.insert_pose(moved, mid)
    np.testing.assert_allclose(st.source_pose_times(ins), np.insert(t0, 4, 0.5 * (t0[3] + t0[4])), atol=1e-12)
    dele = st.delete_pose(moved, 5)
    assert np.array_equal(st.source_pose_times(dele), np.delete(t0, 5))
    culled = st.cull(moved, count=6)                                          # a subset of the poses at their times
    rows = np.searchsorted(moved.pose_times, culled.pose_times)
    np.testing.assert_allclose(st.source_pose_times(culled), t0[rows], atol=1e-12)


# -- the saturation at a region's edge: the knot of lower weight gives way ---------------------------------
def _ramp(o, priority=None):
    knots = np.arange(7.0)[:, None]                       # one column, segments of 1 s, floor 1 / 1.5
    return st.saturate_offsets(knots, np.asarray(o, float)[:, None], 1.5, priority=priority)[:, 0]


def test_a_delays_falling_edge_gives_way_on_the_low_weight_side():
    o = [0.0, 0.5, 0.5, 0.0, 0.0, 0.0, 0.0]                # segment 2-3 squeezed to 0.5 s (< 1 / 1.5)
    old, new = _ramp(o), _ramp(o, priority=[0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0])
    assert old[2] < 0.45                                   # the plain rule cuts the delay the squeeze came from
    assert new[1] == 0.5 and new[2] == 0.5                 # the region's poses keep theirs, bit for bit
    assert new[3] > 0.05 and new[0] == 0.0 and new[6] == 0.0   # the outside knot moved later; the ends stay
    seg = np.diff(np.arange(7.0) + new)
    assert np.all(seg >= 1 / 1.5 - 1e-12)                  # no segment faster than the limit
    assert np.diff(np.arange(7.0) + old)[2] == pytest.approx(seg[2], abs=1e-12)   # the same floored length


def test_a_leads_rising_edge_gives_way_before_it():
    o = [0.0, 0.0, 0.0, 0.0, -0.5, -0.5, 0.0]              # segment 3-4 squeezed by knot 4 moving earlier
    old, new = _ramp(o), _ramp(o, priority=[0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0.0])
    assert old[4] > -0.45
    assert new[4] == -0.5 and new[5] == -0.5 and new[3] < -0.05
    assert np.all(np.diff(np.arange(7.0) + new) >= 1 / 1.5 - 1e-12)


def test_priority_none_or_equal_is_the_plain_rule_and_the_share_is_continuous(rng):
    knots = np.cumsum(rng.uniform(0.2, 1.0, (9, 3)), axis=0)
    o = rng.uniform(-0.3, 0.3, (9, 3))
    plain = st.saturate_offsets(knots, o, 1.5)
    assert np.array_equal(st.saturate_offsets(knots, o, 1.5, priority=np.full(9, 0.7)), plain)
    p = rng.uniform(0.0, 1.0, 9)
    a = st.saturate_offsets(knots, o, 1.5, priority=p)
    b = st.saturate_offsets(knots, o, 1.5, priority=p + 1e-7 * rng.standard_normal(9))
    assert np.abs(a - b).max() < 1e-5                      # no jump as a sigma slider moves the weights
    with pytest.raises(ValueError, match=r"^priority must be 9 finite numbers"):
        st.saturate_offsets(knots, o, 1.5, priority=np.ones(4))
