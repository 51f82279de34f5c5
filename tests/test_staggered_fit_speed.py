"""The fit's speed-ups give the fit of the straightforward code they replaced (issue 13, long takes).

- The start of :func:`fit_rotation_tangents` stops shrinking a pair's polygon once the cost stops falling
  (long fits), or tries every factor in one batched call (small fits): both compared with trying every
  factor of ``_SHRINK`` on every pair (brute force with the public :func:`rotation_residuals`).
- Small C1 fits take their six finite differences in one call: compared with one call each.
- The refit of a StaggeredMotion makes its samples sign-continuous per joint without sorting: compared with
  the sorted version.
- :func:`fit_staggered` leaves the pairs' end samples (the knot values) and static joints out of the spline
  fit: compared with the fit to every selected sample. Tolerance 1e-6 rad: the two differ only through the
  finite-difference Jacobian's rounding (end samples add Jacobian entries of ~1e-10), which two
  Levenberg-Marquardt steps carry to measured worst 2e-8 rad over the shared clips.
"""
from __future__ import annotations

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import staggered as st
from stagger_nb.core.rotations import quat_angle, quat_conj, quat_exp, quat_log, quat_mul
from stagger_nb.staggered import fitting, rotation_fit, rotation_fit_c1, sampling, translation_fit
from stagger_nb.staggered.displacement import displacement_rotvecs
from stagger_nb.staggered.rotation_fit import fit_rotation_tangents, rotation_residuals
from stagger_nb.staggered.sampling import sample_segments


@pytest.fixture(scope="module", params=["walk", "run"])
def samples(request):
    m = sn.data.load(request.param)
    sm = st.extract(m)
    J = m.num_joints
    knots = sm.pose_times[:, None] + sm.refinements
    pair, mm, counts, tn, frames = sample_segments(knots, m.frame_time)
    q = m.local_quats[np.rint(frames).astype(int), pair % J]
    P = counts.size
    v0, v3 = sm.values[:-1].reshape(P, 4), sm.values[1:].reshape(P, 4)
    q = np.where((np.sum(q * v0[pair], axis=1) < 0)[:, None], -q, q)      # the hemisphere of each pair's start
    return tn, q, pair, v0, v3, P


def _brute_start(tn, q, pair, v0, v3, P):
    """Every shrink factor on every pair; the legal polygon of least cost (the replaced loop)."""
    x = quat_log(quat_mul(quat_conj(v0[pair]), q))
    b3 = quat_log(quat_mul(quat_conj(v0), v3))
    inner = translation_fit._fit_inner_controls(tn, x, pair, np.zeros_like(b3), b3, P)
    chord = np.stack([b3 / 3.0, 2.0 * b3 / 3.0], axis=1)
    best = np.full(P, np.inf)
    for alpha in rotation_fit._SHRINK:
        e = quat_exp(chord + alpha * (inner - chord))
        legal = ((e[:, 0, 3] > 0) & (np.sum(e[:, 0] * e[:, 1], axis=1) > 0)
                 & (np.sum(e[:, 1] * quat_exp(b3), axis=1) > 0)) | (alpha == 0.0)
        c1, c2 = quat_mul(v0, e[:, 0]), quat_mul(v0, e[:, 1])
        r = rotation_residuals(v0[pair], c1[pair], c2[pair], v3[pair], tn, q)
        cost = np.where(legal, np.bincount(pair, np.sum(r * r, axis=1), P), np.inf)
        best = np.minimum(best, cost)
    return best


@pytest.mark.parametrize("batch", [0, 1 << 30])    # 0: the lazy loop of long takes; 2^30: one batched call
def test_start_stops_shrinking_where_the_brute_force_would(samples, monkeypatch, batch):
    tn, q, pair, v0, v3, P = samples
    monkeypatch.setattr(rotation_fit, "_START_BATCH", batch)
    _, cost = fit_rotation_tangents(tn, q, pair, v0, v3, P, iterations=0)
    want = _brute_start(tn, q, pair, v0, v3, P)
    # rounding only: the kernel's polynomial sine vs libm in rotation_residuals
    np.testing.assert_allclose(cost, want, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("continuity", ["C1", "C0"])
def test_fit_without_end_samples_and_static_joints_equals_the_full_fit(monkeypatch, continuity):
    m = sn.data.load("walk")
    q = m.local_quats.copy()
    q[:, 3] = [0.0, 0.0, 0.0, 1.0]                        # a static joint
    m = m.replace(local_quats=q)
    new = st.extract(m, continuity=continuity)
    with monkeypatch.context() as mp:
        mp.setattr(fitting, "_fit_mask", lambda sub, *a: sub)
        old = st.extract(m, continuity=continuity)
    assert quat_angle(new.tangents, old.tangents).max() < 1e-6
    # a static joint: its controls are its quaternion bit for bit, its displacement map zero, and so it
    # stays after a cull (which refits from the StaggeredMotion)
    assert np.all(new.tangents[:, 3] == [0.0, 0.0, 0.0, 1.0]) and not np.any(new.displacements[:, 3])
    cu = st.cull(new, 40, continuity=continuity, local=False)
    assert np.all(cu.tangents[:, 3] == [0.0, 0.0, 0.0, 1.0]) and not np.any(cu.displacements[:, 3])
    assert quat_angle(st.evaluate(cu).local_quats, m.local_quats).max() < 1e-9
    assert new.metadata["fit"]["mean_residual_rad"] == pytest.approx(old.metadata["fit"]["mean_residual_rad"],
                                                                      rel=1e-6)
    assert quat_angle(st.evaluate(new).local_quats, m.local_quats).max() < 1e-9


@pytest.mark.parametrize("name", ["walk", "run"])
def test_local_evidence_equals_the_trail_by_trail_version(name):
    """local_evidence works on limb-major component arrays; the reference rotates each axis with
    quat_rotate (public motion_trails) and takes curvature and arc length trail by trail."""
    from stagger_nb.staggered.features import laplacian_smooth, local_evidence, motion_trails
    from stagger_nb.staggered.features import motion_trail_curvature as kappa
    m = sn.data.load(name)
    (joint, _, _, _, length), m1, m2 = motion_trails(m)
    p = np.zeros((m.num_frames, m.num_joints + 1))
    w = np.zeros(m.num_joints + 1)
    for i, j in enumerate(joint):
        p[:, j] = np.maximum(p[:, j], np.maximum(kappa(m1[:, i]), kappa(m2[:, i])))
        w[j] += length[i] * np.linalg.norm(np.diff(m1[:, i], axis=0), axis=1).sum()
    p[:, -1] = kappa(m.root_positions)
    w[-1] = np.linalg.norm(np.diff(m.root_positions, axis=0), axis=1).sum()
    got_p, got_w = local_evidence(m, smoothing_iterations=3)
    # rounding only (two rotation formulas, summation order)
    np.testing.assert_allclose(got_p, laplacian_smooth(p, 3), rtol=0, atol=1e-12)
    np.testing.assert_allclose(got_w, w, rtol=1e-12)


@pytest.mark.parametrize("continuity", ["C1", "C0"])
def test_batched_finite_differences_and_unsorted_continuity_equal_the_plain_versions(monkeypatch, continuity):
    m = sn.data.load("walk")
    sm = st.extract(m, continuity=continuity)
    new = st.cull(sm, 40, continuity=continuity, local=False)
    with monkeypatch.context() as mp:
        mp.setattr(rotation_fit_c1, "_FD_BATCH", 0)                        # one kernel call per perturbation
        mp.setattr(sampling, "_segment_major", lambda *a: False)   # the sorted continuity pass
        old = st.cull(sm, 40, continuity=continuity, local=False)
    # the batched call evaluates the same per-sample formulas: bit for bit up to the polynomial sine's
    # degree, which adapts to the largest arc of a call (1e-12 covers it)
    assert quat_angle(new.tangents, old.tangents).max() < 1e-12
    np.testing.assert_allclose(new.displacements, old.displacements, rtol=0, atol=1e-12)


def test_displacement_rotvecs_equals_the_core_rotations_version(rng):
    """Component-first displacement_rotvecs against the (N, 4) formulas it replaced: s^-1 v with
    quat_mul/quat_conj, the first sample of each pair on w >= 0, sign continuity, 2 quat_log."""
    N = 3000
    q = rng.normal(size=(N, 4))
    s = rng.normal(size=(N, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    s /= np.linalg.norm(s, axis=1, keepdims=True)
    s[:40] = q[:40]                                     # zero displacements: the Taylor branch
    pair = np.sort(rng.integers(0, 200, N))
    first = np.concatenate([[True], pair[1:] != pair[:-1]])
    e = quat_mul(quat_conj(s), q)
    e[first] = np.where(e[first, 3:] < 0, -e[first], e[first])
    cont = e.copy()
    for i in range(1, N):                               # sequential sign continuity inside each pair
        if not first[i] and np.dot(cont[i], cont[i - 1]) < 0:
            cont[i] = -cont[i]
    want = 2.0 * quat_log(cont)
    np.testing.assert_allclose(displacement_rotvecs(s, q, pair), want, rtol=0, atol=1e-14)  # rounding
