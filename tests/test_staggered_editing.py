"""Editing tools on staggered poses (§5.1 geometric, §5.2 temporal, insertion/deletion, partial poses)."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter1d

from stagger_nb import Motion, Skeleton, staggered
from stagger_nb.core.rotations import quat_angle, quat_conj, quat_hemisphere, quat_log, quat_mul, rotvec_to_quat
from stagger_nb.staggered import timing_report
from stagger_nb.staggered.evaluation import evaluate, evaluate_arrays
from stagger_nb.staggered.fitting import fit_staggered
from stagger_nb.staggered.representation import default_times, knot_times

FT = 1 / 30
NAMES = ["Hips", "Spine", "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand", "RightShoulder", "RightArm",
         "LeftUpLeg", "LeftLeg"]
PARENTS = [-1, 0, 1, 2, 3, 4, 1, 6, 0, 8]
POSE_FRAMES = [0, 15, 30, 45, 60]


def small_motion(seed=0, F=61) -> Motion:
    """Smooth rotations (sines, < 0.6 rad) plus seeded high-frequency jitter, on a 10-joint branched tree."""
    rng = np.random.default_rng(seed)
    J = len(NAMES)
    t = np.arange(F)[:, None, None] * FT
    amp = rng.uniform(0.1, 0.4, size=(1, J, 3))
    freq = rng.uniform(0.3, 1.2, size=(1, J, 3))
    phase = rng.uniform(0, 2 * np.pi, size=(1, J, 3))
    rv = amp * np.sin(2 * np.pi * freq * t + phase) + 0.01 * rng.normal(size=(F, J, 3))
    offsets = rng.normal(size=(J, 3))
    rp = np.stack([np.linspace(0, 3, F), 10 + 0.2 * np.sin(6 * t[:, 0, 0]), np.zeros(F)], axis=1)
    return Motion(Skeleton(NAMES, PARENTS, offsets), FT, rp, rotvec_to_quat(rv))


def small_sm(seed=0, refine=True):
    """A staggered motion fitted to :func:`small_motion` with poses every 0.5 s and refinements of up to
    3 frames (on frames, so evaluation at the source frames is exact)."""
    m = small_motion(seed)
    rng = np.random.default_rng(seed + 100)
    K, J = len(POSE_FRAMES), m.num_joints
    r = rng.integers(-3, 4, size=(K, J)) * FT if refine else np.zeros((K, J))
    r[0] = r[-1] = 0
    rr = np.zeros(K)
    rr[1:-1] = rng.integers(-2, 3, size=K - 2) * FT if refine else 0
    return m, fit_staggered(m, np.array(POSE_FRAMES) * FT, r, rr)


def max_change(a: Motion, b: Motion):
    """Per-frame max rotation change (rad) over joints and root translation change."""
    return (quat_angle(a.local_quats, b.local_quats).max(axis=1),
            np.abs(a.root_positions - b.root_positions).max(axis=1))


@pytest.fixture(scope="module")
def fixture():
    return small_sm()


def test_fixture_reproduces_source(fixture):
    m, sm = fixture
    a, b = max_change(evaluate(sm), m)
    assert a.max() < 1e-9 and b.max() < 1e-9  # B's fit is exact on frames; the premise of the tests below


# --- identity at zero parameters -------------------------------------------------------------------------

@pytest.mark.parametrize("op", [
    {"op": "succession", "root": "LeftShoulder", "s": 0.0, "l": 2.0},
    {"op": "succession", "root": "Hips", "s": 0.0, "l": 1.0},
    {"op": "random_timing", "joints": None, "tau": 0.0, "seed": 3},
    {"op": "exaggerate", "k": 2, "w_r": 0.0, "reference": "mean"},
    {"op": "exaggerate", "k": [1, 3], "w_r": 0.0, "reference": "previous", "mode": "unstaggered"},
    {"op": "edit_pose", "k": 2, "deltas": {"LeftArm": [0.0, 0.0, 0.0], "Hips": [0, 0, 0, 1]}},
    {"op": "edit_pose", "k": 1, "deltas": {"Spine": [0.0, 0.0, 0.0]}, "root_offset": [0, 0, 0]},
    {"op": "retime", "pose_times": {"2": 1.0}},
])
def test_zero_parameter_is_identity(fixture, op):
    _, sm = fixture
    op = json.loads(json.dumps(op))  # the parameters are JSON-serialisable and replay from JSON
    name = op.pop("op")
    out = getattr(staggered, name)(sm, **op)
    a, b = max_change(evaluate(out), evaluate(sm))
    assert a.max() < 1e-9 and b.max() < 1e-9  # the identity bound
    assert np.allclose(out.refinements, sm.refinements, atol=0, rtol=0)


def test_target_equal_to_current_pose_is_identity(fixture):
    _, sm = fixture
    k = 2
    for mode, vals in (("staggered", sm.editing_knots), ("unstaggered", sm.values)):
        target = {n: vals[k, j].tolist() for j, n in enumerate(NAMES)}
        out = staggered.edit_pose(sm, k, target=target, mode=mode)
        a, b = max_change(evaluate(out), evaluate(sm))
        assert a.max() < 1e-9 and b.max() < 1e-9  # delta = identity up to round-off (< 1e-15 rad)


# --- geometric editing: formulas and locality ---------------------------------------------------------------

def _outside_mask(sm, k, times):
    """(N, J) True where time is outside the two segments around pose k for that joint."""
    T = knot_times(sm)
    lo = T[max(k - 1, 0)]
    hi = T[min(k + 1, sm.num_poses - 1)]
    return (times[:, None] <= lo[None, :]) | (times[:, None] >= hi[None, :])


@pytest.mark.parametrize("mode", ["staggered", "unstaggered"])
def test_edit_pose_moves_both_knots_by_delta_and_is_local(fixture, mode):
    _, sm = fixture
    k = 2
    deltas = {"LeftArm": [0.0, 0.0, 0.5], "LeftUpLeg": [0.3, -0.1, 0.0], "Spine": [0.0, 0.2, 0.0]}
    out = staggered.edit_pose(sm, k, deltas, mode=mode, root_offset=[0.0, -0.3, 0.1])
    before, after = evaluate(sm), evaluate(out)
    for n, rv in deltas.items():
        j = NAMES.index(n)
        d = rotvec_to_quat(np.array(rv))
        # extreme knot v̂ = v ⊕ δ, editing knot v̂⁰ = v⁰ ⊕ δ (§5.1, Figure 6a/b)
        assert quat_angle(out.values[k, j], quat_mul(sm.values[k, j], d)) < 1e-12  # one product, round-off
        assert quat_angle(out.editing_knots[k, j], quat_mul(sm.editing_knots[k, j], d)) < 1e-9
        # ... and the evaluated motion passes through both: at t_k and at t_k + r_k,i
        at_tk = evaluate(out, [sm.pose_times[k]]).local_quats[0, j]
        at_T = evaluate(out, [knot_times(sm)[k, j]]).local_quats[0, j]
        assert quat_angle(at_tk, quat_mul(sm.editing_knots[k, j], d)) < 1e-9  # exact on the grid points
        assert quat_angle(at_T, quat_mul(sm.values[k, j], d)) < 1e-9
    # locality: frames outside (T[k-1, i], T[k+1, i]) unchanged for every joint
    times = before.times + sm.pose_times[0]
    outside = _outside_mask(sm, k, times)
    change = quat_angle(after.local_quats, before.local_quats)
    assert change[outside].max() < 1e-9  # the locality bound
    assert change[:, NAMES.index("LeftArm")].max() > 0.4  # the edit did happen (0.5 rad at the knot)
    unedited = [j for j, n in enumerate(NAMES) if n not in deltas]
    assert change[:, unedited].max() < 1e-9  # partial pose: other joints untouched
    rk = sm.pose_times + sm.root_refinements
    rout = (times <= rk[k - 1]) | (times >= rk[k + 1])
    assert np.abs(after.root_positions - before.root_positions)[rout].max() < 1e-9
    rin = np.abs(after.root_positions - before.root_positions).max(axis=1)
    assert rin.max() == pytest.approx(0.3, abs=1e-9)  # plateau: the full offset between t_k and its knot


def test_edit_pose_target_modes(fixture):
    _, sm = fixture
    k, j = 3, NAMES.index("RightArm")
    tq = rotvec_to_quat(np.array([0.2, 0.4, -0.1]))
    s_out = staggered.edit_pose(sm, k, target={"RightArm": tq.tolist()}, mode="staggered")
    got = evaluate(s_out, [sm.pose_times[k]]).local_quats[0, j]
    assert quat_angle(got, tq) < 1e-9  # the true pose at t_k becomes the target
    u_out = staggered.edit_pose(sm, k, target={"RightArm": tq.tolist()}, mode="unstaggered")
    assert quat_angle(u_out.values[k, j], tq) < 1e-12  # the extreme value becomes the target
    # the other knot follows by the same change in both modes
    d = quat_mul(quat_conj(sm.values[k, j]), tq)
    assert quat_angle(u_out.editing_knots[k, j], quat_mul(sm.editing_knots[k, j], d)) < 1e-9


def test_edit_pose_joints_subset_filters_deltas(fixture):
    _, sm = fixture
    out = staggered.edit_pose(sm, 1, {"LeftArm": [0, 0, 0.3], "RightArm": [0, 0.3, 0]}, joints=["RightArm"])
    ch = quat_angle(evaluate(out).local_quats, evaluate(sm).local_quats)
    assert ch[:, NAMES.index("LeftArm")].max() < 1e-9 and ch[:, NAMES.index("RightArm")].max() > 0.2


@pytest.mark.parametrize("reference", ["previous", "next", "mean", 0, "explicit"])
@pytest.mark.parametrize("mode", ["staggered", "unstaggered"])
def test_exaggerate_w1_doubles_offset_from_reference(fixture, reference, mode):
    _, sm = fixture
    k = 2
    vals = sm.editing_knots if mode == "staggered" else sm.values
    if reference == "explicit":
        ref = rotvec_to_quat(np.tile([0.1, 0.0, -0.2], (len(NAMES), 1)))
        arg = {n: ref[j].tolist() for j, n in enumerate(NAMES)}
    else:
        arg = reference
        ref = {"previous": vals[k - 1], "next": vals[k + 1], 0: vals[0]}.get(reference)
        if reference == "mean":
            ref = staggered.mean_pose(vals)  # checked against brute force in test_mean_pose_maximises_alignment
    out = staggered.exaggerate(sm, k, 1.0, reference=arg, mode=mode)
    new = out.editing_knots if mode == "staggered" else out.values
    off0 = 2 * quat_log(quat_hemisphere(quat_mul(quat_conj(ref), vals[k])))
    off1 = 2 * quat_log(quat_hemisphere(quat_mul(quat_conj(ref), new[k])))
    assert np.max(np.abs(np.linalg.norm(off0, axis=-1))) < np.pi / 2  # doubling stays below pi: comparable
    tol = 1e-9  # rotation scaling exp(2 log q) = q^2: exact up to round-off
    assert np.allclose(off1, 2 * off0, atol=tol)
    # w_r = -1 collapses onto the reference
    flat = staggered.exaggerate(sm, k, -1.0, reference=arg, mode=mode)
    newf = flat.editing_knots if mode == "staggered" else flat.values
    assert np.max(quat_angle(newf[k], ref)) < tol


def test_mean_pose_maximises_alignment():
    rng = np.random.default_rng(4)
    q = rotvec_to_quat(rng.normal(scale=0.6, size=(7, 3, 3)))
    q[::2] *= -1  # sign must not matter
    m = staggered.mean_pose(q)
    cand = rng.normal(size=(20000, 3, 4))
    cand /= np.linalg.norm(cand, axis=-1, keepdims=True)
    def score(x):  # sum_k (q_k . x)^2 per joint
        return np.sum(np.einsum("kja,...ja->...kj", q, x) ** 2, axis=-2)
    assert np.all(score(m[None])[0] >= score(cand).max(axis=0) - 1e-12)  # the eigenvector is the maximiser


def test_exaggerate_several_poses_and_partial(fixture):
    _, sm = fixture
    out = staggered.exaggerate(sm, [1, 3], 0.5, reference="mean", joints=["LeftArm", "LeftForeArm"])
    ch = quat_angle(evaluate(out).local_quats, evaluate(sm).local_quats)
    others = [j for j, n in enumerate(NAMES) if n not in ("LeftArm", "LeftForeArm")]
    assert ch[:, others].max() < 1e-9
    assert ch[:, NAMES.index("LeftArm")].max() > 1e-3
    assert np.allclose(out.values[[0, 2, 4]], sm.values[[0, 2, 4]], atol=1e-15)  # other poses untouched


@pytest.mark.parametrize("w_r, reference", [(0.5, "previous"), (-0.8, "mean"), (1.5, "next")])
def test_exaggerate_with_a_basis_equals_without(fixture, w_r, reference):
    """pose_offset_basis(sm) is the offset-independent half of the re-measuring: the same StaggeredMotion to
    rounding, for any w_r / reference, after timing edits too (off-frame knots, oversampled grids)."""
    _, sm = fixture
    for base in (sm, staggered.random_timing(staggered.succession(sm, root="Hips", s=0.02, l=1.0), tau=0.03, seed=1)):
        basis = staggered.pose_offset_basis(base)
        ks = list(range(base.num_poses))
        a = staggered.exaggerate(base, ks, w_r, reference=reference)
        b = staggered.exaggerate(base, ks, w_r, reference=reference, basis=basis)
        assert quat_angle(evaluate(a).local_quats, evaluate(b).local_quats).max() < 1e-12   # rounding only
        assert np.allclose(a.displacements, b.displacements, atol=1e-12)
        assert np.array_equal(a.values, b.values) and np.array_equal(a.editing_knots, b.editing_knots)
        # an edit moving under half of the pairs (pose 0: 1 segment of 4) ignores the basis: bit-identical
        assert np.array_equal(staggered.exaggerate(base, [0], w_r, basis=basis).displacements,
                              staggered.exaggerate(base, [0], w_r).displacements)


def test_exaggerate_refuses_a_basis_of_another_motion(fixture):
    _, sm = fixture
    other = staggered.succession(sm, root="Hips", s=0.02, l=1.0)
    with pytest.raises(ValueError, match="basis"):
        staggered.exaggerate(other, [1], 0.5, basis=staggered.pose_offset_basis(sm))
    with pytest.raises(ValueError, match="basis"):
        staggered.exaggerate(sm, [1], 0.5, basis="cached")


# --- temporal editing ---------------------------------------------------------------------------------------

def tree_depth_below(parents, root, j):
    """Brute force: bones from j up to root (None if root is not an ancestor)."""
    d = 0
    while j != root:
        if j < 0:
            return None
        j = parents[j]
        d += 1
    return d


@pytest.mark.parametrize("root, s, l", [("LeftShoulder", 0.03, 2.0), ("LeftShoulder", 0.02, 1.0),
                                        ("Hips", -0.01, 1.5), ("Spine", 0.015, 3.0)])
def test_succession_offsets_are_s_d_to_the_l(fixture, root, s, l):
    _, sm = fixture
    out = staggered.succession(sm, root=root, s=s, l=l, limit=None)        # the paper's raw form
    dr = out.refinements - sm.refinements
    r = NAMES.index(root)
    for j in range(len(NAMES)):
        d = tree_depth_below(PARENTS, r, j)
        expect = 0.0 if d is None else s * d ** l
        assert np.all(dr[1:-1, j] == expect) or np.allclose(dr[1:-1, j], expect, rtol=0, atol=1e-15)  # one add
        assert np.all(dr[[0, -1], j] == 0)  # the end poses anchor the clip
    # the root translation follows the root rotation's timing (0 here since d(root) = 0 or not selected)
    assert np.allclose(out.root_refinements, sm.root_refinements + dr[:, 0], atol=1e-15)


def test_succession_joints_and_poses_subset(fixture):
    _, sm = fixture
    out = staggered.succession(sm, root="Hips", s=0.01, l=1.0, joints=["Hips", "LeftLeg", "RightArm"], poses=[2])
    dr = out.refinements - sm.refinements
    expect = np.zeros_like(dr)
    expect[2, NAMES.index("LeftLeg")] = 0.02
    expect[2, NAMES.index("RightArm")] = 0.03
    assert np.allclose(dr, expect, atol=1e-15)


def test_random_timing_bounds_seed_and_subset(fixture):
    _, sm = fixture
    tau = 0.04
    a = staggered.random_timing(sm, joints=None, tau=tau, seed=5)
    b = staggered.random_timing(sm, joints=None, tau=tau, seed=5)
    c = staggered.random_timing(sm, joints=None, tau=tau, seed=6)
    da, dc = a.refinements - sm.refinements, c.refinements - sm.refinements
    assert np.array_equal(a.refinements, b.refinements)  # same seed, same offsets
    assert not np.allclose(da, dc)  # another seed, other offsets
    assert np.all(np.abs(da) <= tau) and np.abs(da[1:-1]).max() > tau / 2  # bounded and really used
    assert np.all(da[[0, -1]] == 0)
    # offsets are uniform: 10 x 3 interior draws have a mean near 0 (|mean| < 4 sigma = 4 tau / sqrt(3 * 30))
    assert abs(da[1:-1].mean()) < 4 * tau / np.sqrt(3 * da[1:-1].size)
    sub = staggered.random_timing(sm, joints=["LeftArm", "RightArm"], tau=tau, seed=5)
    ds = sub.refinements - sm.refinements
    cols = [NAMES.index("LeftArm"), NAMES.index("RightArm")]
    assert np.array_equal(ds[:, cols], da[:, cols])  # same per-(pose, joint) draw whatever the subset
    others = [j for j in range(len(NAMES)) if j not in cols]
    assert np.all(ds[:, others] == 0)
    assert np.array_equal(sub.root_refinements, sm.root_refinements)  # root not selected: unchanged
    assert np.allclose(a.root_refinements - sm.root_refinements, da[:, 0], atol=1e-15)


def test_combined_timing_keeps_editing_knot_invariant_and_is_local(fixture):
    _, sm = fixture
    out = staggered.random_timing(staggered.succession(sm, "LeftShoulder", 0.02, 2.0, poses=[2]),
                                  joints=["LeftArm"], tau=0.03, seed=1, poses=[2])
    # editing knots re-created at t_k by evaluation (Figure 6c)
    q = evaluate(out, out.pose_times).local_quats
    has = out.refinements != 0
    assert np.max(quat_angle(out.editing_knots[has], q[has])) < 1e-12  # same evaluation, round-off
    # only pose 2's segments change
    before, after = evaluate(sm), evaluate(out)
    times = before.times
    change = quat_angle(after.local_quats, before.local_quats)
    T_old, T_new = knot_times(sm), knot_times(out)
    lo = np.minimum(T_old[1], T_new[1])
    hi = np.maximum(T_old[3], T_new[3])
    outside = (times[:, None] <= lo) | (times[:, None] >= hi)
    assert change[outside].max() < 1e-9
    assert change[:, NAMES.index("LeftHand")].max() > 1e-3  # the hand (d = 3) was retimed by 0.18 s


def test_retime_single_pose_is_local_and_moves_the_pose(fixture):
    _, sm = fixture
    out = staggered.retime(sm, {2: sm.pose_times[2] + 0.1})
    assert out.pose_times[2] == pytest.approx(sm.pose_times[2] + 0.1, abs=1e-15)
    # the extreme value is now reached 0.1 s later
    j = NAMES.index("LeftArm")
    at = evaluate(out, [knot_times(sm)[2, j] + 0.1]).local_quats[0, j]
    assert quat_angle(at, sm.values[2, j]) < 1e-9  # knot values are interpolated exactly
    before, after = evaluate(sm), evaluate(out)
    times = before.times
    T = knot_times(sm)
    outside = (times[:, None] <= T[1]) | (times[:, None] >= T[3])
    assert quat_angle(after.local_quats, before.local_quats)[outside].max() < 1e-9
    # same list form
    t = sm.pose_times.copy()
    t[2] += 0.1
    assert np.array_equal(staggered.retime(sm, t.tolist()).pose_times, out.pose_times)


def test_retime_recreates_editing_knots_fig6c(fixture):
    """Fig. 6c: after a timing change the editing knot is re-created at t_k by evaluation (a new value where
    the joint has a refinement); the extreme values are untouched and move with the pose."""
    _, sm = fixture
    k = 2
    refined = sm.refinements[k] != 0
    assert refined.any() and (~refined).any()
    out = staggered.retime(sm, {k: sm.pose_times[k] + 0.07})
    at_tk = evaluate(out, [out.pose_times[k]]).local_quats[0]
    assert quat_angle(out.editing_knots[k], at_tk)[refined].max() < 1e-9
    assert np.array_equal(out.values, sm.values)
    moved = quat_angle(out.editing_knots[k], sm.editing_knots[k])[refined]
    assert moved.max() > 1e-3             # re-created, not copied: the pose at t_k is another instant now
    # joints without a refinement keep editing knot == extreme value, reached at the new t_k
    assert np.array_equal(out.editing_knots[k][~refined], sm.values[k][~refined])
    assert quat_angle(at_tk[~refined], sm.values[k][~refined]).max() < 1e-9
    # and a geometric edit after the retime still lands on the new t_k (the editing knots are current)
    d = {"LeftArm": [0.0, 0.3, 0.0]}
    j = NAMES.index("LeftArm")
    ed = staggered.edit_pose(out, k, deltas=d, mode="staggered")
    got = evaluate(ed, [out.pose_times[k]]).local_quats[0, j]
    # 1e-3 rad, not round-off: t_k moved 2.1 frames, off the re-measured displacement grid, whose linear
    # interpolation between samples then misses the plateau value by ~2e-4 rad (exact on grid points)
    assert quat_angle(got, quat_mul(out.editing_knots[k, j], rotvec_to_quat(np.array(d["LeftArm"])))) < 1e-3


def _brute_force_warnings(sm, min_angle):
    """§5.2 rule written out knot by knot: the refined time is closer (by more than a frame) to the
    neighbouring pose's knot of the same joint than to its own pose time, or the knots cross; only joints
    whose knots of poses k-1..k+1 span >= min_angle degrees."""
    t, K = sm.pose_times, sm.num_poses
    names = list(sm.skeleton.names) + ["<root translation>"]
    r = np.concatenate([sm.refinements, sm.root_refinements[:, None]], axis=1)
    T = t[:, None] + r
    out = set()
    for k in range(K):
        for c, n in enumerate(names):
            for nb in (k - 1, k + 1):
                if not 0 <= nb < K:
                    continue
                crossed = T[nb, c] <= T[k, c] if nb > k else T[nb, c] >= T[k, c]
                if abs(T[k, c] - T[nb, c]) + sm.frame_time < abs(r[k, c]) or crossed:
                    if c < sm.num_joints:
                        ks = range(max(k - 1, 0), min(k + 1, K - 1) + 1)
                        v = [sm.values[x, c] for x in ks] + [sm.editing_knots[x, c] for x in ks]
                        span = max(np.degrees(quat_angle(p, q)) for p in v for q in v)
                        if span < min_angle:
                            continue
                    out.add((k, n))
    return out


@pytest.mark.parametrize("root, s, l", [("LeftShoulder", 0.03, 2.0), ("Hips", 0.05, 2.0), ("Hips", -0.06, 1.0)])
def test_timing_warnings_match_brute_force(fixture, root, s, l):
    _, sm = fixture
    out = staggered.succession(sm, root=root, s=s, l=l, limit=None)        # raw: knots may cross
    out = staggered.random_timing(out, tau=0.1, seed=3, limit=None)
    warns = out.metadata["warnings"]
    assert warns == staggered.timing_warnings(out)
    for min_angle in (0.0, 5.0):
        got = {(w.pose, w.joint) for w in staggered.timing_warnings(out, min_angle=min_angle)}
        assert got == _brute_force_warnings(out, min_angle)
    assert warns, "the fixture must produce warnings"
    json.dumps([w.to_dict() for w in warns])  # UI-ready
    assert staggered.timing_warnings(sm) == ()  # the fitted source has none


def test_uniform_shift_is_not_a_warning_but_crossing_is(fixture):
    """A succession moves every interior knot of a joint together: no nonlinear warp, no warning while the
    knots keep their order and spacing (§5.2's concern is sudden acceleration); pushing a knot past the
    anchored last pose (a collapsed segment) is."""
    _, sm = fixture        # poses every 0.5 s, refinements up to 0.1 s
    j = sm.skeleton.index("LeftForeArm")
    small = staggered.succession(sm, root="LeftForeArm", s=0.2, l=1.0, joints=["LeftForeArm", "LeftHand"],
                                 limit=None)
    # the hand is shifted 0.2 s (d = 1): closer to t_{k+1} than to t_k in places, yet no knot reaches another
    assert all(w.joint != "LeftHand" for w in staggered.timing_warnings(small))
    big = staggered.succession(sm, root="LeftForeArm", s=0.6, l=1.0, joints=["LeftForeArm", "LeftHand"],
                               limit=None)
    T = big.knot_times()[:, sm.skeleton.index("LeftHand")]
    assert T[-2] >= T[-1]                     # pose K-2's knot is past the anchored last pose
    assert (sm.num_poses - 2, "LeftHand") in {(w.pose, w.joint) for w in staggered.timing_warnings(big)}
    del j


def test_still_joints_do_not_warn():
    """A joint that does not rotate has no acceleration to introduce: retiming it is invisible."""
    m, sm = small_sm()
    q = np.array(m.local_quats)
    h = m.skeleton.index("LeftHand")
    q[:, h] = [0.0, 0.0, 0.0, 1.0]
    still = fit_staggered(m.replace(local_quats=q), sm.pose_times, sm.refinements, sm.root_refinements)
    out = staggered.succession(still, root="LeftForeArm", s=0.6, l=1.0, joints=["LeftHand"])
    assert staggered.timing_warnings(out) == ()
    assert {w.joint for w in staggered.timing_warnings(out, min_angle=0.0)} == {"LeftHand"}


def test_summarize_timing_warnings_is_one_plain_sentence(fixture):
    _, sm = fixture
    assert staggered.summarize_timing_warnings(()) == ""
    assert staggered.summarize_timing_warnings(staggered.timing_warnings(sm)) == ""
    # the paper's raw offsets bring knots next to their neighbours' (the saturated edit keeps them away)
    out = staggered.succession(sm, root="Hips", s=0.05, l=2.0, limit=None)
    warns = staggered.timing_warnings(out)
    text = staggered.summarize_timing_warnings(warns)
    assert text.startswith(f"{len(warns)} refined time") and text.count(".") == 1 and text.endswith(".")
    assert "lower s or l" in text and warns[0].joint in text and "\n" not in text
    # dicts (as stored in a session's JSON) give the same sentence
    assert staggered.summarize_timing_warnings([w.to_dict() for w in warns]) == text


def test_quickstart_edits_give_no_timing_warnings():
    """The notebooks' example edits on the procedural walk: the quickstart's succession from the left
    shoulder (48 warnings under the pose-time reading: 36 on still finger joints, the rest a uniform
    shift) and the Fig. 7 succession down both arms."""
    from stagger_nb import data
    sm = staggered.extract(data.load("walk"))
    for root in ("LeftShoulder", "RightShoulder"):
        assert staggered.timing_warnings(staggered.succession(sm, root=root, s=0.03, l=2.0)) == ()
    both = staggered.succession(staggered.succession(sm, root="LeftShoulder", s=0.03, l=2.0),
                                root="RightShoulder", s=0.03, l=2.0)
    assert both.metadata["warnings"] == ()
    # while an edit that really collapses segments is reported: Hips with l = 2 pushes the fingers 2.4 s
    assert len(staggered.timing_warnings(staggered.succession(sm, root="Hips", s=0.03, l=2.0))) > 20


# --- insertion and deletion -------------------------------------------------------------------------------

def test_insert_and_delete_leave_the_motion_unchanged(fixture):
    m, sm = fixture
    ins = staggered.insert_pose(sm, 38 * FT)
    assert ins.num_poses == sm.num_poses + 1 and ins.pose_times[3] == pytest.approx(38 * FT)
    a, b = max_change(evaluate(ins), m)
    assert a.max() < 1e-9 and b.max() < 1e-9  # re-measured displacement on frame-aligned grids: exact
    back = staggered.delete_pose(ins, 3)
    a, b = max_change(evaluate(back), m)
    assert a.max() < 1e-9 and b.max() < 1e-9
    de = staggered.delete_pose(sm, 2)
    a, b = max_change(evaluate(de), m)
    assert a.max() < 1e-9 and b.max() < 1e-9
    # the inserted pose is then editable like any other, locally
    ed = staggered.edit_pose(ins, 3, {"LeftArm": [0, 0.4, 0]})
    ch = quat_angle(evaluate(ed).local_quats, evaluate(ins).local_quats)
    times = evaluate(ins).times
    T = knot_times(ins)
    assert ch[(times[:, None] <= T[2]) | (times[:, None] >= T[4])].max() < 1e-9


def test_insert_and_delete_after_timing_edits_are_close(fixture):
    _, sm = fixture
    s2 = staggered.random_timing(sm, tau=0.03, seed=2)  # knots now off the frame grid
    m2 = evaluate(s2)
    for out in (staggered.insert_pose(s2, 37 * FT), staggered.delete_pose(s2, 2)):
        a, b = max_change(evaluate(out), m2)
        # exact on the new displacement grids; at frames between them the linear interpolation of the old and
        # new maps differ: bounded by the map's curvature x (h/2)^2, well under a degree on this fixture
        assert a.max() < 5e-3 and b.max() < 5e-3


def test_insert_delete_bad_arguments(fixture):
    _, sm = fixture
    with pytest.raises(ValueError, match="first and last"):
        staggered.delete_pose(sm, 0)
    with pytest.raises(ValueError, match="t must lie"):
        staggered.insert_pose(sm, 30 * FT)  # on an existing pose
    with pytest.raises(ValueError, match="t must lie"):
        staggered.insert_pose(sm, 5.0)
    crossed = staggered.succession(sm, root="LeftShoulder", s=0.3, l=2.0, poses=[1], limit=None)  # LeftHand +2.7 s
    with pytest.raises(ValueError, match="LeftHand"):                # past pose 2's knot: out of order
        staggered.insert_pose(crossed, float(sm.pose_times[1] + 0.15))


def test_insert_pose_where_timing_edits_moved_knots_past_t(fixture):
    """LeftHand's knot of pose 1 is moved 0.27 s later, past t: its new knot goes to the same relative
    place in its own segment (a refinement like its neighbours'), the motion is unchanged, and the new
    pose's editing knots are the pose at t."""
    _, sm = fixture
    late = staggered.succession(sm, root="LeftShoulder", s=0.03, l=2.0, poses=[1])
    h = NAMES.index("LeftHand")
    t = float(sm.pose_times[1] + 0.15)
    assert knot_times(late)[1, h] > t                       # the hand's knot of pose 1 is past t
    out = staggered.insert_pose(late, t)
    T, T0 = knot_times(out), knot_times(late)
    u = (t - late.pose_times[1]) / (late.pose_times[2] - late.pose_times[1])
    assert T[2, h] == pytest.approx(T0[1, h] + u * (T0[2, h] - T0[1, h]), abs=1e-12)
    assert out.refinements[2, NAMES.index("Spine")] == 0.0     # straddled: the knot sits at t
    assert np.all(np.diff(T, axis=0) > 0)
    a, b = max_change(evaluate(out), evaluate(late))
    assert a.max() < 5e-3 and b.max() < 5e-3                  # as for other inserts after timing edits
    at_t = evaluate(out, [t]).local_quats[0]
    assert quat_angle(out.editing_knots[2], at_t).max() < 5e-3
    assert staggered.delete_pose(out, 2).num_poses == late.num_poses


@pytest.mark.parametrize("call, match", [
    (lambda sm: staggered.succession(sm, root="Nope"), "root"),
    (lambda sm: staggered.succession(sm, l=0), "l must"),
    (lambda sm: staggered.succession(sm, s=float("nan")), "s must"),
    (lambda sm: staggered.random_timing(sm, tau=-1), "tau"),
    (lambda sm: staggered.random_timing(sm, joints=["Nope"]), "joints"),
    (lambda sm: staggered.random_timing(sm, seed=1.5), "seed"),
    (lambda sm: staggered.edit_pose(sm, 9, {"LeftArm": [0, 0, 1]}), "k must"),
    (lambda sm: staggered.edit_pose(sm, 1, {"LeftArm": [0, 1]}), "deltas"),
    (lambda sm: staggered.edit_pose(sm, 1), "deltas= or target="),
    (lambda sm: staggered.edit_pose(sm, 1, {"LeftArm": [0, 0, 1]}, mode="x"), "mode"),
    (lambda sm: staggered.exaggerate(sm, 1, 1.0, reference="far"), "reference"),
    (lambda sm: staggered.retime(sm, {1: 10.0}), "increasing"),
    (lambda sm: staggered.retime(sm, [0, 1]), "pose_times"),
    (lambda sm: staggered.edit_pose(object(), 1, {"LeftArm": [0, 0, 1]}), "StaggeredMotion"),
])
def test_bad_arguments_raise_value_error(fixture, call, match):
    _, sm = fixture
    with pytest.raises(ValueError, match=match):
        call(sm)


# --- detail preservation on a real walk ------------------------------------------------------------------------

def test_detail_preserved_on_real_walk(shared_motion):
    m = shared_motion("xia_neutral_walk.bvh")
    F = m.num_frames
    sm = staggered.extract(m)  # the real pipeline: poses at coordinated extrema (§4)
    assert sm.num_poses >= 4
    k = sm.num_poses // 2
    out = staggered.edit_pose(sm, k, {"LeftArm": [0.0, 0.0, 0.6], "LeftForeArm": [0.4, 0.0, 0.0],
                              "RightUpLeg": [0.3, 0.0, 0.0], "Spine": [0.0, 0.15, 0.0]})
    before, after = evaluate(sm), evaluate(out)

    def residual(motion):
        # high-frequency residual of every joint's local rotation (rotation vector relative to frame 0,
        # small and continuous for a walk) minus its low-pass (Gaussian, sigma = 4 frames = 33 ms)
        rv = 2 * quat_log(quat_hemisphere(quat_mul(quat_conj(motion.local_quats[:1]), motion.local_quats)))
        return rv - gaussian_filter1d(rv, sigma=4, axis=0, mode="nearest")

    ra, rb = residual(before), residual(after)
    T = knot_times(sm)
    lo, hi = int(np.floor(T[k - 1].min() / m.frame_time)), int(np.ceil(T[k + 1].max() / m.frame_time))
    guard = 4 * 4  # the low-pass reaches 4 sigma beyond the edited neighbourhood
    outside = np.r_[0:max(lo - guard, 0), min(hi + guard, F):F]
    inside = np.r_[lo:hi]
    assert np.abs(ra[outside] - rb[outside]).max() < 1e-9  # unchanged outside the neighbourhood
    assert quat_angle(after.local_quats, before.local_quats).max() > 0.5  # a real edit happened
    e0 = np.sum(ra[inside] ** 2)
    e1 = np.sum(rb[inside] ** 2)
    print(f"high-frequency energy inside the edited neighbourhood: {e0:.4e} -> {e1:.4e} ({(e1 / e0 - 1) * 100:+.2f} %)")
    assert abs(e1 / e0 - 1) < 0.05  # the 5 % bound


def test_edit_keeps_displacements_past_half_a_turn_unwrapped(shared_motion):
    # CMU 131_01's RThumb flips by ~180 deg within a frame near frame 242 (capture glitch): the segment's
    # displacement map passes pi. Re-measured after an edit, it was folded back to <= pi, and between grid
    # points the linear interpolation of the rotation vectors swung the thumb by 3.1 rad for a 0.01 edit.
    m = shared_motion("cmu_131_01_walk_startstop.bvh")
    sm = staggered.extract(m)
    j = m.skeleton.index("RThumb")
    k = int(np.searchsorted(knot_times(sm)[:, j], 242 * m.frame_time))
    out = staggered.edit_pose(sm, k, {"RThumb": [0.0, 0.0, 0.01]})
    t = (np.arange(m.num_frames - 1) + 0.5) * m.frame_time                 # between the grid points
    change = quat_angle(evaluate(sm, t).local_quats[:, j], evaluate(out, t).local_quats[:, j])
    # the edit is 0.01 rad at most (faded by the weights); between grid points the rotation vectors, not
    # the rotations, are interpolated linearly, which adds ~4e-6 rad here (1 % margin)
    assert change.max() <= 0.0101


def test_timing_warnings_in_metadata_are_computed_when_read(fixture, monkeypatch):
    """``metadata["warnings"]`` of an edit is computed on its first read (a slider's replay never reads it),
    then kept; every way of reading the dict (item, get, in, iteration, copy, pickling) sees the entry, equal
    to timing_warnings of the edited motion."""
    import copy
    import pickle
    _, sm = fixture
    calls = []
    real = timing_report._timing_warnings
    monkeypatch.setattr(timing_report, "_timing_warnings", lambda *a, **k: calls.append(1) or real(*a, **k))
    out = staggered.random_timing(staggered.succession(sm, root="LeftShoulder", s=0.05, l=2.0, limit=None),
                                  tau=0.1, seed=3, limit=None)
    assert calls == []                                  # two edits, nothing read yet
    want = staggered.timing_warnings(out)
    assert want and len(calls) == 1                     # these edits do cross poses (else the check is empty)
    assert "warnings" in out.metadata and len(calls) == 1
    assert out.metadata["warnings"] == want and len(calls) == 2
    assert out.metadata.get("warnings") == want and len(calls) == 2    # kept after the first read
    for other in (staggered.succession(sm, root="LeftShoulder", s=0.05, l=2.0),):
        assert dict(other.metadata)["warnings"] == staggered.timing_warnings(other)
        assert pickle.loads(pickle.dumps(other.metadata))["warnings"] == staggered.timing_warnings(other)
        assert copy.deepcopy(other.metadata)["warnings"] == staggered.timing_warnings(other)
        assert "warnings" in list(other.metadata) and set(other.metadata) == set(dict(other.metadata))


def test_edits_and_evaluate_equal_the_validating_constructors(fixture):
    """The editing tools build their result without re-validating the arrays they did not change
    (shared, read-only), and evaluate / keep_contacts build their Motion without re-validating: the same
    values bit for bit as ``dataclasses.replace`` and ``Motion(...)``."""
    import dataclasses
    m, sm = fixture
    out = staggered.exaggerate(staggered.succession(sm, root="LeftShoulder", s=0.05, l=2.0),
                               list(range(sm.num_poses)), 0.4)
    for edited in (out, staggered.succession(out, root="Hips", s=-0.03, l=1.0)):
        again = dataclasses.replace(edited)                  # validated copies of every field
        for f in dataclasses.fields(edited):
            a, b = getattr(edited, f.name), getattr(again, f.name)
            if isinstance(a, np.ndarray):
                assert np.array_equal(a, b) and a.dtype == b.dtype and not a.flags.writeable, f.name
    ev = evaluate(out)
    q_, p_ = evaluate_arrays(out, default_times(out))
    want = Motion(ev.skeleton, ev.frame_time, p_, q_)
    assert np.array_equal(ev.local_quats, want.local_quats) and np.array_equal(ev.root_positions, want.root_positions)
    assert not ev.local_quats.flags.writeable and not ev.root_positions.flags.writeable
    q = np.array(want.local_quats)
    q[5:, 2] *= -1.0                                         # a sign flip: the Motion makes it continuous again
    assert np.array_equal(Motion._trusted(ev.skeleton, ev.frame_time, want.root_positions, q).local_quats,
                          want.local_quats)


def test_exaggerate_with_a_basis_keeps_the_maps_it_does_not_move(fixture):
    """With a basis, only the (segment, joint) pairs an offset touches are re-measured (a static joint is not
    even in the basis): the other joints keep their displacement maps exactly, as without a basis."""
    _, sm = fixture
    moved = ["Hips", "Spine", "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand"]   # over half the pairs
    ks = list(range(sm.num_poses))
    a = staggered.exaggerate(sm, ks, 0.7, joints=moved)
    b = staggered.exaggerate(sm, ks, 0.7, joints=moved, basis=staggered.pose_offset_basis(sm))
    rest = [NAMES.index(n) for n in NAMES if n not in moved]
    M = sm.displacements.shape[2]
    assert np.array_equal(b.displacements[:, rest, :M], sm.displacements[:, rest])
    assert np.array_equal(a.displacements[:, rest, :M], sm.displacements[:, rest])
    assert np.allclose(a.displacements, b.displacements, atol=1e-12)                      # rounding only
    mv = [NAMES.index(n) for n in moved]
    assert np.abs(b.displacements[:, mv, :M] - sm.displacements[:, mv]).max() > 1e-6   # they did move


def test_offset_basis_reads_the_reproduced_motion_on_frames(fixture):
    """pose_offset_basis(sm, reproduced=m): while sm's knots sit on frames and sm reproduces m there, the
    rotations on the grid are read from m (checked on a subset): the exaggeration equals the plain basis' to
    rounding (< 1e-12 rad: the extraction reproduces m to ~1e-15 here); after a timing edit (grid off the
    frames) or a geometric edit (sm no longer reproduces m) the basis is the plain one, bit for bit."""
    m, sm = fixture
    ks = list(range(sm.num_poses))
    plain, read = staggered.pose_offset_basis(sm), staggered.pose_offset_basis(sm, reproduced=m)
    assert not np.array_equal(plain.old, read.old)                      # it did read m (else nothing is tested)
    assert quat_angle(plain.old.T, read.old.T).max() < 1e-12
    a = evaluate(staggered.exaggerate(sm, ks, 0.8, basis=plain)).local_quats
    b = evaluate(staggered.exaggerate(sm, ks, 0.8, basis=read)).local_quats
    assert quat_angle(a, b).max() < 1e-12
    for other in (staggered.succession(sm, root="Hips", s=0.02, l=1.0),
                  staggered.edit_pose(sm, 2, {"LeftArm": [0.3, 0.0, 0.0]})):
        assert np.array_equal(staggered.pose_offset_basis(other, reproduced=m).old,
                              staggered.pose_offset_basis(other).old)
