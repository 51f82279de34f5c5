"""Edit propagation, Eqs. 4-5 of Dean et al. 2018."""
import numpy as np
import pytest
from wand_motions import cyclic_motion

from stagger_nb import wand
from stagger_nb.core.rotations import quat_conj, quat_exp, quat_hemisphere, quat_log, quat_mul, rotvec_to_quat
from stagger_nb.wand import mean_rotations


def _same_rotation(a, b):
    """|<a, b>| per quaternion (1 = the same rotation)."""
    return np.abs(np.sum(a * b, axis=-1))


@pytest.fixture(scope="module")
def setup():
    m = cyclic_motion(F=90, period=30, J=4, noise=0.02, seed=11)
    basis = wand.greens_basis(m)
    return m, basis


def _edited(m, f, rotvec):
    """Pose of frame f with every joint turned further by ``rotvec`` (J, 3) radians."""
    return quat_mul(m.local_quats[f], rotvec_to_quat(rotvec))


def test_zero_edit_is_the_identity(setup):
    m, basis = setup
    out = wand.propagate(m, 12, m.local_quats[12], basis=basis)
    # log then exp of every pose: a few ulps
    assert np.all(_same_rotation(out.local_quats, m.local_quats) > 1 - 1e-13)
    assert np.array_equal(out.root_positions, m.root_positions)


def test_single_edit_follows_equation_5(setup, rng):
    m, basis = setup
    f = 12
    new = _edited(m, f, 0.3 * rng.normal(size=(4, 3)))
    out = wand.propagate(m, f, -new, basis=basis)   # the sign of the edited quaternions is irrelevant
    assert np.all(_same_rotation(out.local_quats[f], new) > 1 - 1e-12)  # the edited frame gets its pose
    # every other frame: p'_j = r exp(log(r^-1 p_j) + w_j delta), written out with core rotations only
    r = mean_rotations(m.local_quats)
    lg = lambda q: quat_log(quat_hemisphere(quat_mul(quat_conj(r), q)))  # noqa: E731
    delta = lg(new) - lg(m.local_quats[f])
    w = wand.greens_falloff(basis, f)
    want = quat_mul(r, quat_exp(lg(m.local_quats) + w[:, None, None] * delta))
    assert np.all(_same_rotation(out.local_quats, want) > 1 - 1e-12)
    # far frames (weight 0) are untouched, weighted ones moved
    assert np.all(_same_rotation(out.local_quats[w == 0], m.local_quats[w == 0]) > 1 - 1e-13)
    moved = np.flatnonzero(w > 0.5)
    assert np.all(_same_rotation(out.local_quats[moved], m.local_quats[moved]).min(axis=1) < 1 - 1e-6)


def test_frame_range_limits_the_edit(setup, rng):
    m, basis = setup
    new = _edited(m, 40, 0.2 * rng.normal(size=(4, 3)))
    out = wand.propagate(m, 40, new, basis=basis, frame_range=(30, 55))
    outside = np.r_[0:30, 55:90]
    assert np.all(_same_rotation(out.local_quats[outside], m.local_quats[outside]) > 1 - 1e-13)
    assert np.all(_same_rotation(out.local_quats[40], new) > 1 - 1e-12)


def test_several_edits_combine(setup, rng):
    m, basis = setup
    frames = [10, 14, 50]   # 10 and 14 overlap strongly; 50 is the same phase as 20, a cycle away
    new = np.stack([_edited(m, f, 0.25 * rng.normal(size=(4, 3))) for f in frames])
    out = wand.propagate(m, frames, new, basis=basis)
    # "interpolate": every edited frame gets exactly its edited pose despite the overlap
    for k, f in enumerate(frames):
        assert np.all(_same_rotation(out.local_quats[f], new[k]) > 1 - 1e-10)  # an E x E solve, cond ~ 10
    # "sum": the propagated deltas add in the log map
    r = mean_rotations(m.local_quats)
    lg = lambda q: quat_log(quat_hemisphere(quat_mul(quat_conj(r), q)))  # noqa: E731
    base = lg(m.local_quats)
    acc = base.copy()
    for k, f in enumerate(frames):
        acc += wand.greens_falloff(basis, f)[:, None, None] * (lg(new[k]) - base[f])
    out_sum = wand.propagate(m, frames, new, basis=basis, combine="sum")
    assert np.all(_same_rotation(out_sum.local_quats, quat_mul(r, quat_exp(acc))) > 1 - 1e-12)
    # overlapping edits summed overshoot at frame 10, which is why interpolation is the default
    assert np.min(_same_rotation(out_sum.local_quats[10], new[0])) < 1 - 1e-6
    # one edit given as a list equals the single-edit call
    one = wand.propagate(m, [frames[0]], new[:1], basis=basis)
    assert np.array_equal(one.local_quats, wand.propagate(m, frames[0], new[0], basis=basis).local_quats)


def test_propagate_rejects_bad_input(setup):
    m, basis = setup
    with pytest.raises(ValueError, match="edited_local_quats"):
        wand.propagate(m, 3, np.zeros((3, 4)), basis=basis)
    with pytest.raises(ValueError, match="edited_local_quats"):
        wand.propagate(m, 3, np.zeros((4, 4)), basis=basis)
    with pytest.raises(ValueError, match="frame"):
        wand.propagate(m, [3, 3], np.stack([m.local_quats[3]] * 2), basis=basis)
    with pytest.raises(ValueError, match="frame"):
        wand.propagate(m, 90, m.local_quats[0], basis=basis)
    with pytest.raises(ValueError, match="combine"):
        wand.propagate(m, [3, 5], m.local_quats[[3, 5]], basis=basis, combine="max")


def test_public_one_call_form():
    m = cyclic_motion(F=50, period=25, seed=12)
    new = quat_mul(m.local_quats[5], rotvec_to_quat(np.full((4, 3), 0.1)))
    out = wand.propagate(m, 5, new)   # DESIGN.md: propagate(m, frame, edited_local_quats, sigma, frame_range)
    assert out.num_frames == 50
    assert np.all(_same_rotation(out.local_quats[5], new) > 1 - 1e-12)
