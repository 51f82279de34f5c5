"""The control-variable channel and its two algebras (stagger_nb/staggered/channel.py), and StaggeredMotion holding
one channel of each (Coleman et al. 2008, §3)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from stagger_nb import data, staggered
from stagger_nb.core.rotations import quat_angle, quat_bezier, quat_exp, quat_mul, quat_normalize
from stagger_nb.staggered.channel import ROTATION, TRANSLATION, Channel, bezier_cubic
from stagger_nb.staggered.evaluation import channel_at, channel_at_times

LEGACY = ["values", "tangents", "refinements", "displacements", "displacement_counts", "root_values",
          "root_tangents", "root_refinements", "root_displacements", "root_displacement_counts"]


@pytest.fixture
def sm():
    return staggered.cull(staggered.extract(data.load("walk")), 50)


def _quats(rng, *shape):
    return quat_normalize(rng.normal(size=shape + (4,)))


def test_the_former_fields_are_the_channels_arrays(sm):
    assert sm.rotations.algebra is ROTATION and sm.translation.algebra is TRANSLATION
    assert sm.channels == (sm.rotations, sm.translation)
    assert sm.values is sm.rotations.values and sm.displacement_counts is sm.rotations.counts
    assert np.array_equal(sm.root_values, sm.translation.values[:, 0])
    assert np.array_equal(sm.root_displacements, sm.translation.displacements[:, 0])
    assert np.array_equal(sm.root_refinements, sm.translation.refinements[:, 0])
    for name in LEGACY:                         # every view is read-only
        with pytest.raises(ValueError):
            getattr(sm, name)[...] = 0


def test_the_constructor_and_replace_take_the_former_names(sm):
    again = staggered.StaggeredMotion(sm.skeleton, sm.frame_time, sm.pose_times,
                                      editing_knots=sm.editing_knots, pose_probability=sm.pose_probability,
                                      **{n: getattr(sm, n) for n in LEGACY})
    for name in LEGACY:
        assert np.array_equal(getattr(again, name), getattr(sm, name)), name
    assert np.array_equal(staggered.evaluate(again).local_quats, staggered.evaluate(sm).local_quats)
    bare = dataclasses.replace(sm, displacements=np.zeros_like(sm.displacements),
                               root_displacements=np.zeros_like(sm.root_displacements))
    assert not bare.displacements.any() and not bare.root_displacements.any()
    assert bare.tangents is sm.tangents                       # the arrays not replaced are shared
    with pytest.raises(ValueError, match="root_refinements"):
        dataclasses.replace(sm, root_refinements=sm.root_refinements[:-1])
    with pytest.raises(TypeError, match="unexpected"):
        dataclasses.replace(sm, bogus=1)
    with pytest.raises(ValueError, match="translation"):
        dataclasses.replace(sm, translation=sm.rotations)


def test_with_arrays_shares_what_it_does_not_replace(sm):
    ch = sm.rotations
    new = ch.with_arrays(refinements=ch.refinements + 0.01)
    assert new.values is ch.values and new.displacements is ch.displacements
    assert np.array_equal(new.refinements, ch.refinements + 0.01) and not new.refinements.flags.writeable
    with pytest.raises(ValueError, match="refinements"):
        ch.with_arrays(refinements=ch.refinements[:, :2])


@pytest.mark.parametrize("algebra", [ROTATION, TRANSLATION])
def test_compose_undoes_difference(rng, algebra):
    """s ⊕ (v ⊖ s) = v, with v ⊖ s unwrapped along pairs (rotations: angles past pi stay continuous)."""
    N = 200
    if algebra is ROTATION:
        s, v = _quats(rng, N), _quats(rng, N)
    else:
        s, v = rng.normal(size=(N, 3)), rng.normal(size=(N, 3))
    pair = np.repeat(np.arange(10), 20)
    d = algebra.difference(s, v, pair)
    back = algebra.compose(s, d)
    if algebra is ROTATION:
        assert quat_angle(back, v).max() < 1e-12            # rounding of log and exp
    else:
        np.testing.assert_allclose(back, v, rtol=0, atol=1e-14)


@pytest.mark.parametrize("algebra", [ROTATION, TRANSLATION])
def test_split_halves_trace_the_whole_curve(rng, algebra):
    """de Casteljau: the left part at u' is the curve at u u', the right part at u' is the curve at
    u + (1 - u) u'. Exact for the Euclidean Bézier; on the sphere slerp is not affine, so the split of the
    recursive-slerp Bézier meets the curve exactly at its ends and the split point only, and stays within a
    few mrad inside (insert_pose re-measures the displacement maps for that difference)."""
    C = 6
    if algebra is ROTATION:
        c = [quat_normalize(q) for q in _quats(rng, 4, C)]
        c = [c[0], quat_normalize(c[0] + 0.5 * c[1]), quat_normalize(c[0] + 0.5 * c[2]), quat_normalize(c[0] + c[3])]
    else:
        c = list(rng.normal(size=(4, C, 3)))
    u = rng.uniform(0.1, 0.9, size=C)
    (a, d), (e, f) = algebra.split(*c, u)
    mid = algebra.spline(*c, u)
    for up in (0.0, 0.3, 0.8, 1.0):
        whole_l = algebra.spline(*c, u * up)
        whole_r = algebra.spline(*c, u + (1 - u) * up)
        left = algebra.spline(c[0], a, d, mid, np.full(C, up))
        right = algebra.spline(mid, e, f, c[3], np.full(C, up))
        if algebra is ROTATION:
            tol = 1e-12 if up in (0.0, 1.0) else 5e-3     # ends: rounding; inside: ~1e-3 rad measured here
            assert quat_angle(left, whole_l).max() < tol and quat_angle(right, whole_r).max() < tol
        else:
            np.testing.assert_allclose(left, whole_l, atol=1e-12)
            np.testing.assert_allclose(right, whole_r, atol=1e-12)


def test_channel_at_is_the_hand_formula_for_both_algebras(rng):
    """s(t') ⊕ d(t'): the quaternion Bézier (core.quat_bezier) times exp of the linearly interpolated
    rotation vector; the cubic Bézier plus the linearly interpolated translation."""
    K, C, M = 4, 3, 7
    counts = rng.integers(2, M + 1, size=(K - 1, C))
    disp = rng.normal(scale=0.2, size=(K - 1, C, M, 3))
    rot = Channel(ROTATION, _quats(rng, K, C), _quats(rng, K - 1, C, 2), np.zeros((K, C)), disp, counts)
    tr = Channel(TRANSLATION, rng.normal(size=(K, C, 3)), rng.normal(size=(K - 1, C, 2, 3)), np.zeros((K, C)), disp,
                 counts)
    N = 500
    seg, col, tn = rng.integers(0, K - 1, N), rng.integers(0, C, N), rng.uniform(0, 1, N)
    n = counts[seg, col]
    u = tn * (n - 1)
    m0 = np.minimum(np.floor(u).astype(int), n - 2)
    f = (u - m0)[:, None]
    d = disp[seg, col, m0] * (1 - f) + disp[seg, col, m0 + 1] * f
    for ch in (rot, tr):
        t = ch.tangents[seg, col]
        if ch is rot:
            s = quat_bezier(ch.values[seg, col], t[:, 0], t[:, 1], ch.values[seg + 1, col], tn)
            assert quat_angle(channel_at(ch, seg, col, tn), quat_mul(s, quat_exp(0.5 * d))).max() < 1e-12
        else:
            s = bezier_cubic(ch.values[seg, col], t[:, 0], t[:, 1], ch.values[seg + 1, col], tn)
            np.testing.assert_allclose(channel_at(ch, seg, col, tn), s + d, rtol=0, atol=1e-13)


def test_few_and_many_rotation_samples_agree(sm):
    """The rotation kernel gathers per sample up to a few thousand samples and through per-pair tables above:
    the same values (rounding of the adaptive polynomial degree only)."""
    rng = np.random.default_rng(3)
    times = rng.uniform(sm.pose_times[0], sm.pose_times[-1], 20000)
    joints = rng.integers(0, sm.num_joints, times.size)
    many = channel_at_times(sm.rotations, sm.pose_times, times, joints)
    few = np.concatenate([channel_at_times(sm.rotations, sm.pose_times, times[i:i + 1000], joints[i:i + 1000])
                          for i in range(0, times.size, 1000)])
    assert quat_angle(many, few).max() < 1e-12
    root = staggered.evaluation.root_positions_at(sm, times)
    np.testing.assert_allclose(channel_at_times(sm.translation, sm.pose_times, times, 0), root, rtol=0, atol=1e-9)


def test_pickled_and_copied_motions_keep_their_algebras(sm):
    """The two algebras are module singletons (the evaluator dispatches on ``algebra is ROTATION``): a pickled
    (a batch worker, a cache on disk) or deep-copied motion keeps them and evaluates to the same bits."""
    import copy
    import pickle
    for other in (pickle.loads(pickle.dumps(sm)), copy.deepcopy(sm)):
        assert other.rotations.algebra is ROTATION and other.translation.algebra is TRANSLATION
        a, b = staggered.evaluate(sm), staggered.evaluate(other)
        assert np.array_equal(a.local_quats, b.local_quats) and np.array_equal(a.root_positions, b.root_positions)
