"""The slider paths' speed-ups give the results of the straightforward code they replaced (old vs new).

- ``keep_contacts`` / ``apply_contact_constraints`` run forward kinematics only on the contact chains
  (and their ancestors): compared bit for bit with the same call on full forward kinematics.
- ``exaggerate`` / ``edit_pose`` re-measure displacement maps with ``evaluate``'s per-pair kernel (control
  arcs once per (segment, joint) pair) and component-first quaternion kernels: compared with the
  per-sample ``rotation_spline`` / ``core.rotations`` formulas they replaced. Tolerance 1e-8: the two
  differ only in rounding (a polynomial sine exact to ~3e-16 instead of libm's, arcs computed per pair
  instead of per sample), which a slerp on a near-zero arc amplifies by 1/sin(arc); measured worst 6e-10
  over the bundled clips with w_r = 1.5 applied twice.
"""
from __future__ import annotations

import numpy as np
import pytest
from references import plateau_weights_reference

import stagger_nb as sn
from stagger_nb import staggered as st
from stagger_nb.core.body import pelvis_joint
from stagger_nb.core.kinematics import forward_kinematics
from stagger_nb.core.rotations import quat_bezier, quat_exp, quat_mul
from stagger_nb.staggered import _kernels, geometry, limbs, plants
from stagger_nb.staggered.evaluation import displacement_at, rotation_spline


@pytest.fixture(scope="module")
def edited():
    m = sn.data.load("walk")
    m = m.slice(0, min(m.num_frames, 240))
    cu = st.cull(st.extract(m), percent=50.0)
    ed = st.random_timing(st.succession(cu, root=m.skeleton.names[0], s=0.03, l=1.5), tau=0.03, seed=2)
    return m, ed


def _full_fk(motion, joints, local_quats=None, root_positions=None):
    """The replaced code: a new Motion with the changed arrays, forward kinematics of every joint."""
    change = {k: v for k, v in (("local_quats", local_quats), ("root_positions", root_positions)) if v is not None}
    return forward_kinematics(motion.replace(**change) if change else motion)


def test_chain_fk_equals_full_fk_on_the_chains(edited):
    m, _ = edited
    sk = m.skeleton
    feet = [j for j, n in enumerate(sk.names) if "foot" in n.lower() or "toe" in n.lower()]
    pos, wq = limbs._fk_joints(m, feet)
    P, W = forward_kinematics(m)
    done = ~np.isnan(pos[0, :, 0])
    assert done[feet].all() and done[0] and not done.all()      # the feet, their ancestors, not the arms
    for j in np.flatnonzero(done):
        assert sk.parents[j] < 0 or done[sk.parents[j]]
    np.testing.assert_array_equal(pos[:, done], P[:, done])
    np.testing.assert_array_equal(wq[:, done], W[:, done])


@pytest.mark.parametrize("opts", [{}, {"carry_by": "limb"}, {"carry_by": "span"}, {"lower_root": False}])
def test_keep_contacts_equals_full_fk_version(edited, monkeypatch, opts):
    m, ed = edited
    new = st.keep_contacts(ed, m, **opts)
    monkeypatch.setattr(plants, "_fk_joints", _full_fk)
    plants._SOURCE_CACHE.clear()
    old = st.keep_contacts(ed, m, **opts)
    np.testing.assert_array_equal(new.local_quats, old.local_quats)
    np.testing.assert_array_equal(new.root_positions, old.root_positions)


@pytest.mark.parametrize("carry_by", ["joint", "pelvis"])
def test_carried_contacts_equal_per_contact_warp_times(edited, carry_by):
    """carry_contacts against one warp_times call per contact (the replaced code), through the contact joint's
    own warp ("joint") or the pelvis's (the default: every contact here is a foot's)."""
    m, ed = edited
    assert ed.contacts
    want = []
    pel = m.skeleton.names[pelvis_joint(m.skeleton)]
    for name, a, b in ed.contacts:
        t = st.warp_times(ed, np.array([a, b - 1]) * m.frame_time, name if carry_by == "joint" else pel)
        start = max(int(np.ceil((t[0] - ed.pose_times[0]) / ed.frame_time - 1e-6)), 0)
        stop = min(int(np.floor((t[1] - ed.pose_times[0]) / ed.frame_time + 1e-6)) + 1, st.evaluate(ed).num_frames)
        if stop > start:
            want.append((name, start, stop))
    assert st.carry_contacts(ed, ed.contacts, m.frame_time, carry_by=carry_by) == want


def _per_sample_spline(c0, c1, c2, c3, pair, t, out):
    """The replaced code: one Bézier per sample, control arcs per sample."""
    out[...] = rotation_spline(c0.T[pair], c1.T[pair], c2.T[pair], c3.T[pair], t).T
    return out


def _old_target_pieces(monkeypatch):
    monkeypatch.setattr(_kernels, "spline_into", _per_sample_spline)

    def pair_weights(knots, tk, k, col, side, t, pair):
        return plateau_weights_reference(knots, tk, k[pair], col[pair], t, np.full(pair.size, side))

    def rotations_at(ch, idx, tn):                 # per sample, core quaternion helpers
        seg, col = np.divmod(idx, ch.num_columns)
        tg = ch.tangents[seg, col]
        s = quat_bezier(ch.values[seg, col], tg[:, 0], tg[:, 1], ch.values[seg + 1, col], tn)
        d = displacement_at(ch.displacements, ch.counts[seg, col], tn, (seg, col))
        return quat_mul(s, quat_exp(0.5 * d)).T

    monkeypatch.setattr(geometry, "_pair_plateau_weights", pair_weights)
    monkeypatch.setattr(geometry, "_rotations_at", rotations_at)
    monkeypatch.setattr(_kernels, "qexp", lambda v: quat_exp(v.T).T)
    monkeypatch.setattr(_kernels, "qmul", lambda a, b: quat_mul(a.T, b.T).T)


@pytest.mark.parametrize("w_r, reference", [(0.4, "previous"), (1.5, "mean"), (-0.5, "next")])
def test_exaggerate_equals_per_sample_version(edited, monkeypatch, w_r, reference):
    _, ed = edited
    poses = list(range(ed.num_poses))
    new = st.exaggerate(ed, poses, w_r, reference=reference)
    with monkeypatch.context() as mp:
        _old_target_pieces(mp)
        old = st.exaggerate(ed, poses, w_r, reference=reference)
    np.testing.assert_allclose(new.displacements, old.displacements, rtol=0, atol=1e-8)
    np.testing.assert_allclose(st.evaluate(new).local_quats, st.evaluate(old).local_quats, rtol=0, atol=1e-8)


def test_edit_pose_equals_per_sample_version(edited, monkeypatch):
    m, ed = edited
    deltas = {m.skeleton.names[2]: [0.4, -0.2, 0.1], m.skeleton.names[0]: [0.0, 0.3, 0.0]}
    new = st.edit_pose(ed, 2, deltas)
    with monkeypatch.context() as mp:
        _old_target_pieces(mp)
        old = st.edit_pose(ed, 2, deltas)
    np.testing.assert_allclose(st.evaluate(new).local_quats, st.evaluate(old).local_quats, rtol=0, atol=1e-8)
