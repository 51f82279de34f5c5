"""StaggeredMotion, evaluate() and the spline fit (Coleman et al. 2008, §3, §4.1.1, Appendix A)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import SHARED_CLIPS
from references import evaluate_reference, fit_rotation_tangents_nelder_mead
from scipy.spatial.transform import Rotation

from stagger_nb import staggered
from stagger_nb.core.kinematics import skeleton_height
from stagger_nb.core.rotations import quat_angle, quat_bezier, quat_mul, rotvec_to_quat, slerp
from stagger_nb.staggered.evaluation import bezier_cubic, evaluate_arrays, rotation_spline
from stagger_nb.staggered.fitting import fit_staggered
from stagger_nb.staggered.rotation_fit import fit_rotation_tangents
from stagger_nb.staggered.rotation_fit_c1 import velocity_jumps
from stagger_nb.staggered.translation_fit import fit_translation_tangents

CLIPS = ["bandai_kick.bvh", "bandai_run_cycle.bvh", "bandai_walk.bvh", "cmu_131_01_walk_startstop.bvh",
         "iclone_cmu_02_03_run.bvh", "iclone_cmu_07_01_walk.bvh", "pymo_walk_turnaround.bvh",
         "xia_angry_run.bvh", "xia_depressed_run.bvh", "xia_neutral_walk.bvh", "xia_sexy_walk.bvh"]


@pytest.fixture(scope="module")
def extracted(shared_motion):
    cache = {}

    def get(name):
        if name not in cache:
            m = shared_motion(name)
            cache[name] = (m, staggered.extract(m))
        return cache[name]
    return get


# -- exact reconstruction (the acceptance check) ---------------------------------------------------

@pytest.mark.parametrize("name", CLIPS)
def test_evaluate_extract_reproduces_every_real_clip(extracted, name):
    m, sm = extracted(name)
    out = staggered.evaluate(sm)
    assert out.num_frames == m.num_frames and out.frame_time == m.frame_time
    # displacement maps make this exact by construction; 1e-6 rad / 1e-6 height is the bound
    assert quat_angle(m.local_quats, out.local_quats).max() <= 1e-6
    assert np.abs(out.root_positions - m.root_positions).max() <= 1e-6 * skeleton_height(m)
    if m.local_translations is not None:      # passed through untouched
        assert np.array_equal(out.local_translations, m.local_translations)
    # refinements stay inside the paper's +-0.25 s, and knot times increase down every joint
    assert np.abs(sm.refinements).max() <= 0.25 + 1e-12
    assert np.all(np.diff(sm.knot_times(), axis=0) > 0)
    # explicit times give the same as the default grid (bit-for-bit: same code path)
    again = staggered.evaluate(sm, m.times)
    assert np.array_equal(again.local_quats, out.local_quats)


def test_every_shared_clip_is_covered():
    if not SHARED_CLIPS:
        pytest.skip("../shared/mocap not present")
    assert sorted(CLIPS) == sorted(SHARED_CLIPS)


def test_editing_knots_are_the_pose_at_the_pose_time(extracted):
    m, sm = extracted("xia_neutral_walk.bvh")
    q, _ = evaluate_arrays(sm, sm.pose_times)
    assert quat_angle(q, sm.editing_knots).max() < 1e-9          # rounding only
    assert np.array_equal(sm.has_editing_knot, sm.refinements != 0)


def test_displacement_follows_the_segment_when_time_is_scaled(extracted):
    m, sm = extracted("xia_angry_run.bvh")
    slow = dataclasses.replace(sm, pose_times=2 * sm.pose_times, refinements=2 * sm.refinements,
                               root_refinements=2 * sm.root_refinements, local_translations=None)
    out = staggered.evaluate(slow, 2 * m.times)
    # t' is identical at the doubled times, so the motion is exactly the original (rounding only)
    assert quat_angle(out.local_quats, m.local_quats).max() < 1e-9
    assert np.abs(out.root_positions - m.root_positions).max() < 1e-9


def test_animated_translations_are_retimed_with_the_root(extracted):
    # Bandai clips carry the body's travel (8 m) in the Hips joint's translation, not in root_positions:
    # a time stretch must stretch it too (it was read at the absolute time, so the body ran ahead)
    m, sm = extracted("bandai_walk.bvh")
    hips = m.skeleton.index("Hips")
    assert np.ptp(m.local_translations[:, hips, 2]) > 100.0            # the travel really is there
    slow = staggered.retime(sm, 2 * sm.pose_times)
    slow = dataclasses.replace(slow, refinements=2 * sm.refinements, root_refinements=2 * sm.root_refinements)
    out = staggered.evaluate(slow, 2 * m.times)
    assert quat_angle(out.local_quats, m.local_quats).max() < 1e-9       # t' identical: rounding only
    assert np.abs(out.local_translations - m.local_translations).max() < 1e-9
    # retiming one pose: the translation at the new pose time is the source's at the old one
    k = sm.num_poses // 2
    t_new = 0.5 * (sm.pose_times[k] + sm.pose_times[k + 1])
    one = staggered.retime(sm, {k: t_new})
    rk = sm.pose_times[k] + sm.root_refinements[k]
    got = staggered.evaluate(one, [t_new + sm.root_refinements[k]]).local_translations[0]
    want = staggered.evaluate(sm, [rk]).local_translations[0]
    assert np.allclose(got, want, atol=1e-9)
    # inserting and deleting poses leaves the translations where they were
    T = np.concatenate([sm.knot_times(), (sm.pose_times + sm.root_refinements)[:, None]], axis=1)
    i = int(np.argmax(T[1:].min(axis=1) - T[:-1].max(axis=1)))            # widest gap between poses
    ins = staggered.insert_pose(sm, 0.5 * (T[i].max() + T[i + 1].min()))
    assert np.abs(staggered.evaluate(ins).local_translations - m.local_translations).max() < 1e-9
    dele = staggered.delete_pose(sm, k)
    assert np.abs(staggered.evaluate(dele).local_translations - m.local_translations).max() < 1e-9


def test_retiming_one_joint_changes_only_that_joint(extracted):
    m, sm = extracted("xia_neutral_walk.bvh")
    j = m.skeleton.index("LeftForeArm") if "LeftForeArm" in m.skeleton.names else 5
    r = np.array(sm.refinements)
    r[1:-1, j] += 0.02
    out = staggered.evaluate(dataclasses.replace(sm, refinements=r))
    err = quat_angle(out.local_quats, m.local_quats)
    assert np.delete(err, j, axis=1).max() < 1e-9                # other joints: rounding only
    assert err[:, j].max() > 1e-4                                # the retimed joint really moves


def test_spline_is_continuous_at_segment_joins(extracted):
    m, sm = extracted("cmu_131_01_walk_startstop.bvh")
    v0, v3 = sm.values[:-1], sm.values[1:]
    t = sm.tangents
    end = rotation_spline(v0.reshape(-1, 4), t[:, :, 0].reshape(-1, 4), t[:, :, 1].reshape(-1, 4),
                          v3.reshape(-1, 4), np.ones(v0.size // 4))
    start = rotation_spline(v0.reshape(-1, 4), t[:, :, 0].reshape(-1, 4), t[:, :, 1].reshape(-1, 4),
                            v3.reshape(-1, 4), np.zeros(v0.size // 4))
    # each segment spline interpolates its knots, so consecutive segments meet in value (rounding only)
    assert quat_angle(end, v3.reshape(-1, 4)).max() < 1e-7
    assert quat_angle(start, v0.reshape(-1, 4)).max() < 1e-7
    pe = bezier_cubic(sm.root_values[:-1], sm.root_tangents[:, 0], sm.root_tangents[:, 1],
                      sm.root_values[1:], np.ones(sm.num_poses - 1))
    assert np.allclose(pe, sm.root_values[1:], atol=1e-9)


# -- spline kernels against naive references ------------------------------------------------------

def test_rotation_spline_matches_recursive_slerp_reference(rng):
    c = Rotation.random(4 * 300, random_state=3).as_quat().reshape(4, 300, 4)
    t = rng.uniform(0, 1, 300)
    got = rotation_spline(c[0], c[1], c[2], c[3], t)
    want = quat_bezier(c[0], c[1], c[2], c[3], t)
    assert quat_angle(got, want).max() < 1e-7   # same recursion, different arithmetic: arccos rounding
    ends = rotation_spline(c[0], c[1], c[2], c[3], np.zeros(300))
    assert quat_angle(ends, c[0]).max() < 1e-7


def _random_segments(rng, P, spread=0.6):
    v0 = Rotation.random(P, random_state=7).as_quat()
    steps = [rotvec_to_quat(rng.normal(scale=spread, size=(P, 3))) for _ in range(3)]
    c1 = quat_mul(v0, steps[0])
    c2 = quat_mul(c1, steps[1])
    v3 = quat_mul(c2, steps[2])
    return v0, c1, c2, v3


def test_fit_recovers_a_known_quaternion_bezier(rng):
    P, n = 40, 25
    v0, c1, c2, v3 = _random_segments(rng, P)
    tn = np.tile(np.linspace(0, 1, n), P)
    pair = np.repeat(np.arange(P), n)
    targets = quat_bezier(v0[pair], c1[pair], c2[pair], v3[pair], tn)
    from stagger_nb.core.rotations import quat_continuous
    targets = quat_continuous(targets.reshape(P, n, 4), axis=1).reshape(-1, 4)
    tang, cost = fit_rotation_tangents(tn, targets, pair, targets[::n], targets[n - 1::n], P, iterations=8)
    # data lie exactly on a spline of this family: the fit gets there (1e-12 rad^2 = solver tolerance)
    assert cost.max() < 1e-12
    assert quat_angle(tang[:, 0], c1).max() < 1e-5 and quat_angle(tang[:, 1], c2).max() < 1e-5


def test_fit_start_keeps_a_flexion_and_extension_inside_one_segment():
    # one-axis rotation whose angle is a Euclidean cubic with inner controls +130 deg and -120 deg (a knee
    # flexing and extending inside one segment): the least-squares control polygon has a 250 deg leg, which
    # the short-arc recursive slerp would follow the other way round. The fit must not fall back to the
    # linear spline (it did: cost 4.47 rad^2, 38 deg off); a shrunk polygon fits to 0.40 rad^2 (11 deg).
    n = 22
    tn = np.linspace(0, 1, n)
    u = 1 - tn
    deg = 3 * u * u * tn * 130 + 3 * u * tn * tn * (-120) + tn ** 3 * 15
    q = rotvec_to_quat(np.radians(deg)[:, None] * np.array([1.0, 0.0, 0.0]))
    tang, cost = fit_rotation_tangents(tn, q, np.zeros(n, dtype=int), q[:1], q[-1:], 1)
    lin = quat_bezier(q[0], *slerp(q[0], q[-1], np.array([1 / 3, 2 / 3])), q[-1], tn)
    lin_cost = np.sum(quat_angle(lin, q) ** 2)
    s = quat_bezier(q[0], tang[0, 0], tang[0, 1], q[-1], tn)
    assert np.isclose(cost[0], np.sum(quat_angle(s, q) ** 2), rtol=1e-9)   # reported cost is the true one
    assert cost[0] < 0.25 * lin_cost                                      # measured ratio 0.09


def test_c1_fit_never_swings_the_long_way_on_the_procedural_run():
    # procedural run (60 Hz): knees and hips hold a full flexion and extension between two knots. The C1
    # fit once accepted control-polygon legs past a half turn there (feet 177 deg off before displacement).
    from stagger_nb import data
    from stagger_nb.staggered.rotation_fit_c1 import _legs_within_half_turn
    m = data.load("run")
    sm = staggered.extract(m)
    P = sm.tangents.shape[0] * sm.num_joints
    a = sm.tangents[:, :, 0].reshape(P, 4).T
    b = sm.tangents[:, :, 1].reshape(P, 4).T
    assert _legs_within_half_turn(sm.values, a, b).all()
    bare = staggered.evaluate(dataclasses.replace(sm, displacements=np.zeros_like(sm.displacements)))
    err = np.degrees(quat_angle(bare.local_quats, m.local_quats))
    # measured 55 deg (hip, C1 with ~0.35 s segments over a 0.72 s stride); 177 deg before the fix
    assert err.max() < 90.0
    assert quat_angle(staggered.evaluate(sm).local_quats, m.local_quats).max() <= 1e-6


def test_fit_translation_recovers_control_points(rng):
    P, n = 10, 12
    ctrl = rng.normal(size=(4, P, 3))
    tn = np.tile(np.linspace(0, 1, n), P)
    pair = np.repeat(np.arange(P), n)
    y = bezier_cubic(ctrl[0][pair], ctrl[1][pair], ctrl[2][pair], ctrl[3][pair], tn)
    got = fit_translation_tangents(tn, y, pair, ctrl[0], ctrl[3], P)
    assert np.allclose(got[:, 0], ctrl[1], atol=1e-6) and np.allclose(got[:, 1], ctrl[2], atol=1e-6)  # ridge 1e-9


def test_fit_is_at_least_as_accurate_as_nelder_mead_port(rng):
    P, n = 2, 12      # the port costs seconds per segment: two segments keep the test short
    v0, c1, c2, v3 = _random_segments(rng, P, spread=0.4)
    tn1 = np.linspace(0, 1, n)
    noise = rotvec_to_quat(rng.normal(scale=0.02, size=(P, n, 3)))
    data = quat_mul(quat_bezier(v0[:, None], c1[:, None], c2[:, None], v3[:, None], tn1), noise)
    from stagger_nb.core.rotations import quat_continuous
    data = quat_continuous(data, axis=1)
    pair = np.repeat(np.arange(P), n)
    tang, cost = fit_rotation_tangents(np.tile(tn1, P), data.reshape(-1, 4), pair, data[:, 0], data[:, -1], P)
    for p in range(P):
        nm = fit_rotation_tangents_nelder_mead(tn1, data[p], data[p, 0], data[p, -1])
        s = quat_bezier(data[p, 0], nm[0], nm[1], data[p, -1], tn1)
        nm_cost = np.sum(quat_angle(s, data[p]) ** 2)
        assert cost[p] <= nm_cost * (1 + 1e-6) + 1e-12      # never worse than the paper's optimiser


# -- the dataclass --------------------------------------------------------------------------------

def test_staggered_motion_validates_and_is_read_only(extracted):
    m, sm = extracted("bandai_run_cycle.bvh")
    with pytest.raises(ValueError, match="refinements"):
        dataclasses.replace(sm, refinements=sm.refinements[:, :3])
    with pytest.raises(ValueError, match="pose_times"):
        dataclasses.replace(sm, pose_times=sm.pose_times[::-1])
    with pytest.raises(ValueError):
        sm.values[0, 0, 0] = 2.0
    with pytest.raises(ValueError, match="sm"):
        staggered.evaluate(m)


def test_evaluate_tolerates_crossing_knots_and_times_outside(extracted):
    m, sm = extracted("xia_angry_run.bvh")
    r = np.array(sm.refinements)
    r[1:-1] += 0.5 * np.sign(np.arange(r.shape[1]) % 2 - 0.5)   # knots pushed past their neighbours
    out = staggered.evaluate(dataclasses.replace(sm, refinements=r), np.linspace(-1.0, sm.duration + 1.0, 50))
    assert np.all(np.isfinite(out.local_quats)) and out.num_frames == 50


def test_fit_staggered_validates_arguments(extracted):
    m, sm = extracted("bandai_run_cycle.bvh")
    with pytest.raises(ValueError, match="pose_times"):
        fit_staggered(m, [0.1], np.zeros((1, m.num_joints)))
    with pytest.raises(ValueError, match="refinements"):
        fit_staggered(m, [0.0, 0.5], np.zeros((2, 3)))
    bad = np.zeros((3, m.num_joints))
    bad[1, 0] = 0.3
    with pytest.raises(ValueError, match="increasing"):
        fit_staggered(m, [0.0, 0.2, 0.4], bad)


# -- C1 continuity --------------------------------------------------------------------------------

def test_default_fit_is_c1_and_c0_is_not(extracted):
    m, sm = extracted("xia_neutral_walk.bvh")
    assert sm.metadata["fit"]["continuity"] == "C1"
    jump, mag = velocity_jumps(sm)
    assert jump.max() < 1e-9 * max(1.0, mag.max())       # equal by construction: rounding only
    c0 = fit_staggered(m, sm.pose_times, sm.refinements, sm.root_refinements, continuity="C0")
    jump0, mag0 = velocity_jumps(c0)
    assert np.median(jump0[mag0 > 0.1] / mag0[mag0 > 0.1]) > 0.1   # independent segments do jump
    # C0 has the smaller residual (it is the unconstrained optimum); both reconstruct exactly
    assert c0.metadata["fit"]["mean_residual_rad"] < sm.metadata["fit"]["mean_residual_rad"]
    out = staggered.evaluate(c0)
    assert quat_angle(out.local_quats, m.local_quats).max() <= 1e-6
    # root translation: matching velocities at interior knots too
    d = np.diff(sm.pose_times + sm.root_refinements)[:, None]
    u_in = 3 * (sm.root_values[1:-1] - sm.root_tangents[:-1, 1]) / d[:-1]
    u_out = 3 * (sm.root_tangents[1:, 0] - sm.root_values[1:-1]) / d[1:]
    assert np.allclose(u_in, u_out, atol=1e-9 * np.abs(u_in).max())  # rounding only


def test_c1_fit_recovers_a_known_c1_spline(rng):
    from stagger_nb.core.rotations import quat_continuous
    from stagger_nb.staggered.rotation_fit_c1 import _tangents_from_velocities, fit_rotation_tangents_c1
    from stagger_nb.staggered.sampling import sample_segments
    K, C, ft = 6, 3, 0.01
    knots = np.cumsum(rng.uniform(0.2, 0.4, size=(K, C)), axis=0)
    knots = np.round(knots / ft) * ft
    values = quat_continuous(rotvec_to_quat(np.cumsum(rng.normal(scale=0.5, size=(K, C, 3)), axis=0)), axis=0)
    omega = rng.normal(scale=1.0, size=(K, C, 3))
    a, b = _tangents_from_velocities(values, omega, np.diff(knots, axis=0))
    pair, mm, counts, tn, frames = sample_segments(knots, ft, 0.0)
    P = counts.size
    v0 = values[:-1].reshape(P, 4)
    v3 = values[1:].reshape(P, 4)
    targets = quat_bezier(v0[pair], a.T[pair], b.T[pair], v3[pair], tn)
    # sign-continuous within each pair, starting on v0's sign
    targets *= np.sign(np.sum(targets * v0[pair], axis=1))[:, None]
    om, tang, cost = fit_rotation_tangents_c1(tn, targets, pair, values, knots, np.zeros_like(omega), 8)
    # data lie on a C1 spline of this family: the fit reaches it (1e-12 rad^2: solver tolerance)
    assert cost.max() < 1e-12
    assert np.allclose(om, omega, atol=1e-5)


def test_reconstruction_on_cmu_01_01():
    from pathlib import Path

    from stagger_nb import read_bvh
    p = Path(__file__).resolve().parents[1] / "data" / "cmu_01_01.bvh"
    if not p.is_file():
        pytest.skip("data/cmu_01_01.bvh not prepared (python -m stagger_nb.data.prepare writes it)")
    m = read_bvh(p)
    sm = staggered.extract(m)
    out = staggered.evaluate(sm)
    assert quat_angle(m.local_quats, out.local_quats).max() <= 1e-6            # the bound
    assert np.abs(out.root_positions - m.root_positions).max() <= 1e-6 * skeleton_height(m)
    assert np.abs(sm.refinements).max() <= 0.25 + 1e-12


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_evaluate_matches_naive_reference_after_random_edits(extracted, seed):
    m, sm = extracted("xia_angry_run.bvh")
    rng = np.random.default_rng(seed)
    K, J = sm.num_poses, sm.num_joints
    r = np.array(sm.refinements)
    r[1:-1] += rng.uniform(-0.02, 0.02, size=(K - 2, J))          # off the frame grid
    dv = rotvec_to_quat(rng.normal(scale=0.2, size=(K, J, 3)))
    edited = dataclasses.replace(sm, refinements=r, values=quat_mul(sm.values, dv),
                                 pose_times=sm.pose_times * rng.uniform(0.8, 1.2))
    times = np.sort(rng.uniform(-0.05, edited.pose_times[-1] + 0.05, 300))
    got = staggered.evaluate(edited, times).local_quats
    want = evaluate_reference(edited, times)
    # same formulas, different arithmetic (polynomial sine, component-first slerp): 1e-9 rad is far
    # below anything visible and far above the ~1e-15 rounding seen in practice
    assert quat_angle(got, want).max() < 1e-9


def test_displacement_rotvecs_unwrap_past_half_turn():
    from stagger_nb.staggered.displacement import displacement_rotvecs
    ang = np.linspace(0, 1.6 * np.pi, 50)                     # one pair whose residual passes pi
    targets = rotvec_to_quat(ang[:, None] * np.array([0.0, 0.0, 1.0]))
    from stagger_nb.core.rotations import quat_continuous
    targets = quat_continuous(targets)
    d = displacement_rotvecs(np.tile([0.0, 0.0, 0.0, 1.0], (50, 1)), targets, np.zeros(50, dtype=int))
    # continuous angles 0 .. 1.6 pi about +z, not folded back below pi (rounding only)
    assert np.allclose(d[:, 2], ang, atol=1e-12) and np.allclose(d[:, :2], 0.0, atol=1e-12)
    from stagger_nb.staggered import _kernels as K
    back = K.qexp(np.ascontiguousarray(0.5 * d.T)).T
    assert quat_angle(back, targets).max() < 1e-12


def test_evaluate_samples_equals_evaluate_at_scattered_pairs(extracted, rng):
    """evaluate_samples (one lexicographic search over all joints) against evaluate_arrays' per-joint
    segments: scattered (time, joint) pairs, including times exactly on knots (the usual refit case: knots
    on source frames), before the first and after the last knot, and crossing knots. The segments equal a
    per-joint searchsorted exactly; values agree to 1e-12 (not bit for bit: evaluate_arrays computes t' with
    a reciprocal, and sin_poly's degree adapts to each batch's largest arc)."""
    from stagger_nb.staggered.evaluation import evaluate_samples
    from stagger_nb.staggered.representation import knot_times
    from stagger_nb.staggered.segments import _segments_of_pairs
    _, sm = extracted("xia_angry_run.bvh")
    r = np.array(sm.refinements)
    r[1:-1] += 0.3 * np.sign(np.arange(r.shape[1]) % 2 - 0.5)     # some knots pushed past their neighbours
    for s in (sm, dataclasses.replace(sm, refinements=r)):
        J = s.num_joints
        on_knots = knot_times(s).reshape(-1)
        times = np.concatenate([on_knots, rng.uniform(-0.5, s.duration + 0.5, 400), [-1.0, s.duration + 1.0]])
        joints = np.concatenate([np.tile(np.arange(J), s.num_poses), rng.integers(0, J, 402)])
        perm = rng.permutation(times.size)
        times, joints = times[perm], joints[perm]
        T = np.maximum.accumulate(knot_times(s), axis=0)
        brute = np.array([np.searchsorted(T[:, j], t, side="right") - 1 for t, j in zip(times, joints)])
        np.testing.assert_array_equal(_segments_of_pairs(T, times, joints), brute)
        got = evaluate_samples(s, times, joints)
        want = np.stack([evaluate_arrays(s, [t])[0][0, j] for t, j in zip(times, joints)])
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_static_joints_evaluate_to_their_quaternion_exactly(extracted):
    """Joints with one quaternion throughout (8 of cmu_131_01's 31) skip the spline in evaluate: they are the
    source's quaternion bit for bit; every joint agrees with the straightforward evaluate_reference (1e-12:
    the component-first kernels round differently)."""
    from stagger_nb.staggered.evaluation import static_rotations
    m, sm = extracted("cmu_131_01_walk_startstop.bvh")
    static, c = static_rotations(sm)
    want = np.all(m.local_quats == m.local_quats[:1], axis=(0, 2))
    assert static.sum() >= 1 and np.array_equal(static, want)
    out = staggered.evaluate(sm)
    src = np.where(np.sum(m.local_quats * out.local_quats, -1, keepdims=True) < 0, -m.local_quats, m.local_quats)
    np.testing.assert_array_equal(out.local_quats[:, static], src[:, static])
    ref = evaluate_reference(sm, out.times)
    ref = np.where(np.sum(ref * out.local_quats, -1, keepdims=True) < 0, -ref, ref)
    np.testing.assert_allclose(out.local_quats, ref, rtol=0, atol=1e-12)


def test_displacement_at_given_rows_equals_the_row_copy():
    """``displacement_at(table, counts, t, rows=seg)`` gathers the two entries each sample reads: bit for bit
    what interpolating the copied rows ``table[seg]`` gives (the form root_positions_at used before)."""
    from stagger_nb.staggered.evaluation import displacement_at
    rng = np.random.default_rng(3)
    table = rng.normal(size=(7, 40, 3))
    counts_of_row = rng.integers(2, 41, size=7)
    seg = rng.integers(0, 7, size=500)
    t = np.concatenate([rng.uniform(0, 1, 497), [0.0, 1.0, 1.0 - 1e-17]])
    want = displacement_at(table[seg], counts_of_row[seg], t)
    got = displacement_at(table, counts_of_row[seg], t, rows=seg)
    assert np.array_equal(got, want)
