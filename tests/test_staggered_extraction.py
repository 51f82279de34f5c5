"""Known answers for staggered-pose location (Coleman et al. 2008, §4.1): curvature, smoothing, tent filter,
pose times, refinements, priorities and culling."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import chain_motion

from stagger_nb import staggered
from stagger_nb.core.rotations import quat_angle, rotvec_to_quat
from stagger_nb.staggered.extraction import (
    candidate_poses,
    local_maxima,
    locate_poses,
    pose_priorities,
    tent_filter,
    timing_refinements,
)
from stagger_nb.staggered.features import laplacian_smooth, local_evidence, motion_trail_curvature

# -- curvature ------------------------------------------------------------------------------------

def test_curvature_of_sampled_circle_is_constant_sin_half_step(rng):
    step = 0.1
    a = np.arange(60) * step
    circle = 2.5 * np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1)
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]          # any orientation and centre in space
    k = motion_trail_curvature(circle @ R.T + rng.normal(size=3))
    # closed form for a regular polygon turning by `step` per vertex: sin(step / 2); 1e-12 = rounding only
    assert np.allclose(k, np.sin(step / 2), atol=1e-12)


def test_curvature_straight_line_zero_reversal_one_still_zero():
    x = np.linspace(0, 1, 11)[:, None] * np.array([1.0, 2.0, 3.0])
    assert np.allclose(motion_trail_curvature(x), 0.0, atol=1e-12)   # rounding only
    back = np.concatenate([x, x[-2::-1]])                              # goes out and comes back
    k = motion_trail_curvature(back)
    assert k[10] == pytest.approx(1.0, abs=1e-12) and np.all(k[np.arange(k.size) != 10] < 1e-6)
    assert np.all(motion_trail_curvature(np.ones((5, 3))) == 0.0)


def test_curvature_edge_length_weighting_matches_brute_force(rng):
    x = np.cumsum(rng.normal(size=(40, 3)), axis=0)
    k = motion_trail_curvature(x)
    for i in range(1, 39):
        ep, em = x[i + 1] - x[i], x[i - 1] - x[i]
        n = ep / np.linalg.norm(ep) + em / np.linalg.norm(em)
        n /= np.linalg.norm(n)
        want = (np.dot(n, ep) + np.dot(n, em)) / (np.linalg.norm(ep) + np.linalg.norm(em))
        assert k[i] == pytest.approx(want, abs=1e-12)   # same formula, different evaluation order


def test_laplacian_smoothing_kernel_and_invariants(rng):
    x = rng.normal(size=50)
    one = laplacian_smooth(x, 1, 0.5)
    assert np.allclose(one[1:-1], 0.25 * x[:-2] + 0.5 * x[1:-1] + 0.25 * x[2:], atol=1e-15)  # rounding
    assert np.allclose(laplacian_smooth(np.full(20, 3.0), 7), 3.0, atol=1e-14)   # constants unchanged
    lin = np.arange(30.0)
    assert np.allclose(laplacian_smooth(lin, 3)[4:-4], lin[4:-4], atol=1e-12)    # interior lines unchanged
    assert np.std(laplacian_smooth(x, 20)) < 0.5 * np.std(x)                      # it does smooth
    with pytest.raises(ValueError, match="lam"):
        laplacian_smooth(x, 1, 0.0)


# -- tent filter ----------------------------------------------------------------------------------

@pytest.mark.parametrize("fps", [30.0, 120.0])
def test_tent_filter_merges_peaks_closer_than_its_width(fps):
    ft, width = 1.0 / fps, 0.15
    F = int(3 * fps)
    for gap, expect in [(0.10, 1), (0.14, 1), (0.20, 2), (0.28, 2)]:
        x = np.zeros(F)
        a = F // 3
        x[a] = 1.0
        x[a + int(round(gap * fps))] = 1.0
        peaks = local_maxima(tent_filter(x, ft, width))
        assert peaks.size == expect, (fps, gap, peaks)
    # the kernel is normalised: a constant passes unchanged (rounding only)
    assert np.allclose(tent_filter(np.full(F, 0.3), ft, width), 0.3, atol=1e-14)
    with pytest.raises(ValueError, match="width"):
        tent_filter(x, ft, 0.0)


# -- pose times and refinements -------------------------------------------------------------------

def test_all_joints_reversing_together_give_one_pose_with_zero_refinements():
    m = chain_motion([1.0, 1.0, 1.0, 1.0])
    sm = staggered.extract(m, contacts=[])
    assert np.allclose(sm.pose_times, [0.0, 1.0, 2.0], atol=1e-12)   # frame times, rounding only
    assert np.all(sm.refinements == 0.0) and np.all(sm.root_refinements == 0.0)


@pytest.mark.parametrize("lagger", [1, 2, 3])
def test_a_joint_lagging_by_a_tenth_second_gets_refinement_plus_a_tenth(lagger):
    times = [1.0] * 4
    times[lagger] = 1.1
    m = chain_motion(times)
    sm = staggered.extract(m, contacts=[])
    # one pose near the cluster: the lagging joint's peak pulls the filtered P by at most a frame
    assert sm.num_poses == 3 and abs(sm.pose_times[1] - 1.0) <= 1.0 / 120 + 1e-12
    r = sm.refinements[1]
    # each knot lands on its own joint's reversal: 1.1 s for the lagger, 1.0 s for the rest, so the
    # lagger's refinement is 0.1 s give or take the pose's one-frame pull (1e-12: frame-time rounding)
    knots = sm.pose_times[1] + r
    assert knots[lagger] == pytest.approx(1.1, abs=1e-12)
    assert np.allclose(np.delete(knots, lagger), 1.0, atol=1e-12)
    assert r[lagger] == pytest.approx(0.1, abs=1.0 / 120 + 1e-12)


def test_refinements_respect_window_and_neighbours():
    # one column with maxima at frames 10, 30, 52 and 90; poses at 0, 40, 60, 100 (120 Hz, window 0.25 s = 30)
    F = 101
    ev = np.zeros((F, 1))
    for f in (10, 30, 52, 90):
        ev[f - 1:f + 2, 0] = [0.5, 1.0, 0.5]
    poses = np.array([0, 40, 60, 100])
    r = timing_refinements(ev, poses, 1 / 120.0, 0.25)[:, 0]
    # pose 40: maxima 30 (d=10, closer to 40 than to 0) and 52 (d=12 but closer to 60) -> -10
    # pose 60: 52 (d=8, closer to 60 than to 40) -> -8; ends are 0
    assert r.tolist() == [0, -10, -8, 0]
    r = timing_refinements(ev, poses, 1 / 120.0, 0.05)[:, 0]   # window 6 frames: nothing qualifies
    assert r.tolist() == [0, 0, 0, 0]


def test_static_motion_has_only_endpoint_poses():
    m = chain_motion([1.0, 1.0, 1.0], amplitude=0.0)
    sm = staggered.extract(m, contacts=[])
    assert np.allclose(sm.pose_times, [0.0, 2.0], atol=1e-12)
    assert np.all(sm.refinements == 0.0)


def test_local_evidence_weights_are_limb_length_times_arc_length():
    m = chain_motion([1.0, 1.0, 1.0], amplitude=0.5)
    p, w = local_evidence(m)
    # each joint swings its unit limb through an arc of 2 * 0.5 rad (up and back): w = 1 * 1.0;
    # the chord sum underestimates the arc by O(step^2): 1e-4 relative covers 240 steps of <= 0.01 rad
    assert np.allclose(w[:3], 1.0, rtol=1e-4)
    assert w[3] == 0.0                           # the root does not translate
    assert p.shape == (m.num_frames, 4) and np.all((p >= 0) & (p <= 1))


# -- priorities and culling -----------------------------------------------------------------------

def test_priorities_closed_form():
    t = np.array([0.0, 0.5, 0.7, 2.0])
    P = np.array([0.1, 0.4, 0.9, 0.2])
    w = pose_priorities(t, P)
    assert np.isinf(w[0]) and np.isinf(w[-1])
    assert w[1:3] == pytest.approx([0.4 * 0.7, 0.9 * 1.5], abs=1e-15)   # rounding only


@pytest.fixture(scope="module")
def walk_sm():
    from conftest import shared_clip_path

    from stagger_nb import read_bvh
    return staggered.extract(read_bvh(shared_clip_path("cmu_131_01_walk_startstop.bvh")))


def test_cull_keeps_highest_priorities_and_endpoints(walk_sm):
    sm = walk_sm
    K = sm.num_poses
    prio = pose_priorities(sm.pose_times, sm.pose_probability)
    for n in (2, 3, 7, K - 1):
        out = staggered.cull(sm, count=n)
        want = {0, K - 1} | set(np.argsort(-prio[1:-1], kind="stable")[: n - 2] + 1)
        assert np.allclose(out.pose_times, np.sort(sm.pose_times[sorted(want)]), atol=0)
    out = staggered.cull(sm, percent=50)
    assert out.num_poses == int(np.ceil(K / 2))
    lo, hi = sm.pose_times[3], sm.pose_times[8]
    out = staggered.cull(sm, interval=(lo, hi))
    inside = (sm.pose_times >= lo) & (sm.pose_times <= hi)
    assert out.num_poses == inside.sum() + 2
    with pytest.raises(ValueError, match="count"):
        staggered.cull(sm, count=1)
    with pytest.raises(ValueError, match="percent"):
        staggered.cull(sm, percent=0)


def test_cull_preserves_the_motion(walk_sm):
    sm = walk_sm
    out = staggered.cull(sm, percent=30)
    a, b = staggered.evaluate(sm), staggered.evaluate(out)
    # both reproduce the same frames through their displacement maps: rounding-level differences only
    assert quat_angle(a.local_quats, b.local_quats).max() < 1e-9
    assert np.abs(a.root_positions - b.root_positions).max() < 1e-9
    assert set(out.refinements.reshape(-1)) <= set(sm.refinements.reshape(-1))


def test_candidate_poses_include_ends_and_every_prominent_maximum():
    x = np.linspace(0, 6 * np.pi, 200)
    P = 1.0 + np.sin(x)
    k = candidate_poses(P)
    assert k[0] == 0 and k[-1] == 199
    brute = [i for i in range(1, 199) if P[i] > P[i - 1] and P[i] >= P[i + 1]]
    assert k[1:-1].tolist() == brute


def test_locate_poses_uses_contact_events_as_evidence():
    m = chain_motion([1.0, 1.0, 1.0], amplitude=0.0)       # static: no local evidence at all
    loc = locate_poses(m, contacts=[("J2", 60, 150)], contact_weight=1.0)
    # with zero local weight the contact weight is 0 too (a fraction of it): P stays 0, ends only
    assert loc.frames.tolist() == [0, m.num_frames - 1]
    m = chain_motion([1.0, 1.0, 1.0])
    loc = locate_poses(m, contacts=[("J2", 60, 180)], contact_weight=2.0)
    assert {60, 120, 180} <= set(loc.frames.tolist())


@pytest.mark.parametrize("fps,seed", [(30.0, 0), (120.0, 1), (60.0, 2)])
def test_random_smooth_motion_round_trips(fps, seed):
    rng = np.random.default_rng(seed)
    m = chain_motion([1.0] * 5, duration=3.0, fps=fps)
    F = m.num_frames
    # random smooth rotations (cumulative noise, smoothed) and a wandering root
    rv = np.cumsum(rng.normal(scale=0.05, size=(F, 5, 3)), axis=0)
    rv = laplacian_smooth(rv, 20)
    root = np.cumsum(rng.normal(scale=0.02, size=(F, 3)), axis=0)
    m = m.replace(local_quats=rotvec_to_quat(rv), root_positions=root)
    sm = staggered.extract(m)
    out = staggered.evaluate(sm)
    assert quat_angle(out.local_quats, m.local_quats).max() <= 1e-9      # exact up to rounding
    assert np.abs(out.root_positions - m.root_positions).max() <= 1e-9
    assert np.abs(sm.refinements).max() <= 0.25 + 1e-12 and np.abs(sm.root_refinements).max() <= 0.25 + 1e-12
    assert np.all(np.diff(sm.knot_times(), axis=0) > 0)
    half = staggered.cull(sm, 50)
    out2 = staggered.evaluate(half)
    assert quat_angle(out2.local_quats, m.local_quats).max() <= 1e-9


def test_cull_after_retiming_and_crossing_knots(walk_sm):
    import dataclasses
    sm = walk_sm
    rng = np.random.default_rng(3)
    K, J = sm.num_poses, sm.num_joints
    r = np.array(sm.refinements)
    r[1:-1] += rng.uniform(-0.03, 0.03, size=(K - 2, J))           # off the frame grid
    r[1:-1, 5] += 0.6                                               # joint 5's knots pushed past neighbours
    edited = dataclasses.replace(sm, refinements=r)
    before = staggered.evaluate(edited)
    out = staggered.cull(edited, percent=40)
    after = staggered.evaluate(out)
    assert np.all(np.diff(out.knot_times(), axis=0) > 0)
    # merged displacement maps are resampled off the frame grid (4 samples per frame): the retimed motion
    # has velocity kinks at its old knots, so linear interpolation leaves ~1e-3 rad; 1e-2 rad (0.6 deg)
    # bounds it. Joints whose source jumps by ~1-3 rad between frames (CMU 131_01's RightWrist/RThumb
    # glitches) are excluded: any off-grid resampling of them is arbitrary.
    err = quat_angle(before.local_quats, after.local_quats)
    glitch = quat_angle(before.local_quats[1:], before.local_quats[:-1]).max(axis=0) > 0.5
    assert glitch.sum() <= 2
    assert err[:, ~glitch].max() < 1e-2
    assert np.abs(before.root_positions - after.root_positions).max() < 1e-9
