"""Constraint layer (staggered poses §3): two-bone IK displacement holding contacts, attenuated windows."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import Motion, Skeleton, forward_kinematics
from stagger_nb.core.rotations import quat_angle, quat_normalize, rotvec_to_quat
from stagger_nb.staggered.ik import two_bone_ik
from stagger_nb.staggered.plants import (
    apply_contact_constraints,
    attenuation_weights,
    contact_errors,
    contact_positions,
    foot_skate,
)


def leg_skeleton() -> Skeleton:
    """root - pelvis - hip - knee - ankle - toe, a leg hanging down -Y with a slight knee bend."""
    names = ["Root", "Pelvis", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase"]
    parents = [-1, 0, 1, 2, 3, 4]
    offsets = [[0, 0, 0], [0, 0, 0], [1.0, -0.2, 0], [0, -4.0, 0.2], [0, -3.5, -0.1], [0, -0.5, 1.2]]
    return Skeleton(names, parents, offsets)


def random_leg_motion(F=40, seed=0) -> Motion:
    sk = leg_skeleton()
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, F)[:, None, None]
    base = rng.normal(scale=0.3, size=(1, 6, 3))
    vel = rng.normal(scale=0.4, size=(1, 6, 3))
    q = rotvec_to_quat(base + vel * t)  # smooth rotations
    rp = np.stack([np.linspace(0, 2, F), np.full(F, 8.0), np.zeros(F)], axis=1)
    return Motion(sk, 1 / 30, rp, q)


# --- the analytic solver ----------------------------------------------------------------------------------

def test_two_bone_ik_reaches_reachable_targets_and_clamps_unreachable():
    m = random_leg_motion(F=200, seed=1)
    pos, wq = forward_kinematics(m)
    rng = np.random.default_rng(7)
    up, mid, eff = 2, 3, 4
    l1 = np.linalg.norm(pos[:, mid] - pos[:, up], axis=-1)
    l2 = np.linalg.norm(pos[:, eff] - pos[:, mid], axis=-1)
    d = rng.normal(size=(200, 3))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    # first half reachable (strictly inside the annulus), second half 20 % too far
    r = np.where(np.arange(200) < 100, rng.uniform(np.abs(l1 - l2) + 0.3, l1 + l2 - 0.3), 1.2 * (l1 + l2))
    target = pos[:, up] + d * r[:, None]
    a_new, b_new, _ = two_bone_ik(pos[:, up], pos[:, mid], pos[:, eff], target, wq[:, up], wq[:, mid],
                                  m.local_quats[:, up])
    q = np.array(m.local_quats)
    q[:, up], q[:, mid] = a_new, b_new
    p2, _ = forward_kinematics(m.replace(local_quats=q))
    err = np.linalg.norm(p2[:, eff] - target, axis=-1)
    assert err[:100].max() < 1e-9  # closed-form solution: only round-off remains
    # unreachable: fully stretched (up to the 1e-6 safety margin) and pointing at the target
    reach = np.linalg.norm(p2[100:, eff] - pos[100:, up], axis=-1)
    assert np.allclose(reach, (l1 + l2)[100:], atol=1e-5)  # 1e-6 margin, well above round-off
    aim = (p2[100:, eff] - pos[100:, up]) / reach[:, None]
    assert np.allclose(aim, d[100:], atol=1e-6)  # direction exact up to round-off of the margin
    # the joints above the chain did not move and the bone lengths are kept (FK invariants)
    assert np.allclose(p2[:, :up + 1], pos[:, :up + 1], atol=1e-12)  # untouched joints: exact


def test_two_bone_ik_straight_leg_uses_fallback_axis():
    sk = Skeleton(["R", "P", "H", "K", "A"], [-1, 0, 1, 2, 3],
                  [[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, -4, 0], [0, -4, 0]])
    m = Motion(sk, 1 / 30, np.zeros((1, 3)), quat_normalize(np.tile([0, 0, 0, 1.0], (1, 5, 1))))
    pos, wq = forward_kinematics(m)
    target = np.array([[0.0, -7.0, 0.0]])  # 1 unit closer: the knee must bend
    a_new, b_new, _ = two_bone_ik(pos[:, 2], pos[:, 3], pos[:, 4], target, wq[:, 2], wq[:, 3], m.local_quats[:, 2])
    q = np.array(m.local_quats)
    q[:, 2], q[:, 3] = a_new, b_new
    p2, _ = forward_kinematics(m.replace(local_quats=q))
    assert np.linalg.norm(p2[0, 4] - target[0]) < 1e-9  # exact by construction
    # the bend happens about the fallback x axis: the knee leaves the x = 0 line only in y/z
    assert abs(p2[0, 3, 0]) < 1e-12 and abs(p2[0, 3, 2]) > 0.5  # a real bend of a few units


# --- attenuation window -------------------------------------------------------------------------------

def test_attenuation_weights_closed_form():
    act = np.zeros(30, bool)
    act[10:15] = True
    w, left, right = attenuation_weights(act, 4)
    assert np.all(w[10:15] == 1.0)
    for d in range(1, 5):
        expect = 0.5 * (1 + np.cos(np.pi * d / 5))
        assert w[15 + d - 1] == pytest.approx(expect, abs=1e-15)  # same formula evaluated twice
        assert w[10 - d] == pytest.approx(expect, abs=1e-15)
    assert np.all(w[:6] == 0) and np.all(w[19:] == 0)
    assert left[12] == 12 and left[20] == 14 and left[3] == -1
    assert right[3] == 10 and right[20] == -1


# --- the layer on a hand-built leg ---------------------------------------------------------------------

def test_no_contacts_and_self_reference_track_are_identity():
    m = random_leg_motion()
    assert apply_contact_constraints(m, []) is m
    contacts = [("LeftFoot", 5, 20), ("LeftToeBase", 18, 30)]
    out = apply_contact_constraints(m, contacts, reference=m, mode="track")
    assert np.max(quat_angle(out.local_quats, m.local_quats)) < 1e-7  # IK to the current pose: round-off only


def test_edit_is_local_and_meets_targets():
    m = random_leg_motion(F=60)
    rp = np.array(m.root_positions)
    rp[:, 1] -= 0.5
    edited = m.replace(root_positions=rp)
    contacts = [("LeftFoot", 20, 30)]
    out = apply_contact_constraints(edited, contacts, reference=m, blend=0.1, mode="mean")
    nb = 4 * round(0.1 * 30)
    # outside [start - nb, stop + nb) nothing changes (the fade is blend long, up to 4 x where the displacement
    # is large, so it turns no joint faster than 90 degrees a second on top of the edit)
    outside = np.r_[0:20 - nb, 30 + nb:60]
    assert np.max(quat_angle(out.local_quats[outside], edited.local_quats[outside])) < 1e-9  # untouched
    # only the chain joints change inside
    others = [0, 1, 5]
    assert np.max(quat_angle(out.local_quats[:, others], edited.local_quats[:, others])) < 1e-9
    target = contact_positions(m, contacts, mode="mean")[0]
    assert contact_errors(out, contacts, reference=m, mode="mean").max() < 1e-9  # exact IK on active frames
    p = forward_kinematics(out)[0]
    assert np.allclose(p[20:30, 4], target, atol=1e-9)
    assert foot_skate(out, contacts)[0] < 1e-8  # planted: no horizontal travel beyond round-off


def test_toe_contact_goes_through_the_ankle():
    m = random_leg_motion(F=50, seed=3)
    rp = np.array(m.root_positions)
    rp[:, 1] -= 0.4
    rp[:, 0] += 0.3
    edited = m.replace(root_positions=rp)
    contacts = [("LeftToeBase", 10, 25)]
    out = apply_contact_constraints(edited, contacts, reference=m)  # track mode by default with a reference
    assert contact_errors(out, contacts, reference=m, mode="track").max() < 1e-9  # exact IK
    # the toe joint's own local rotation is not the one bent
    assert np.max(quat_angle(out.local_quats[:, 5], edited.local_quats[:, 5])) < 1e-9


def test_zero_length_bones_are_skipped_in_the_chain():
    """CMU-style arm: Collar - Shoulder - Elbow(0 offset 'ElbowRoll') - Wrist - hand (0 offset)."""
    names = ["Hips", "Collar", "Shoulder", "Elbow", "ElbowRoll", "Wrist", "hand"]
    offsets = [[0, 0, 0], [1, 0, 0], [1, 0, 0], [3, 0, 0.3], [0, 0, 0], [3, 0, -0.2], [0, 0, 0]]
    sk = Skeleton(names, [-1, 0, 1, 2, 3, 4, 5], offsets)
    rng = np.random.default_rng(2)
    q = rotvec_to_quat(rng.normal(scale=0.3, size=(20, 7, 3)))
    m = Motion(sk, 1 / 30, np.zeros((20, 3)), q)
    rp = np.zeros((20, 3))
    rp[:, 0], rp[:, 1] = 0.8, -0.3  # towards the hand (the arm points along +x): the target stays reachable
    edited = m.replace(root_positions=rp)
    contacts = [("hand", 5, 15)]
    out = apply_contact_constraints(edited, contacts, reference=m)
    assert contact_errors(out, contacts, reference=m, mode="track").max() < 1e-9  # exact IK
    changed = np.flatnonzero(quat_angle(out.local_quats, edited.local_quats).max(axis=0) > 1e-12)
    # Shoulder (upper), Elbow (middle: ElbowRoll, co-located and named like a roll bone, is a helper), Wrist
    assert changed.tolist() == [2, 3, 5]


@pytest.mark.parametrize("bad, match", [
    ([("Nope", 0, 5)], "Nope"), ([("LeftFoot", 5, 5)], r"\[5, 5\)"), ([("LeftFoot", 0, 99)], "outside"),
    ([("LeftFoot", 0)], "joint_name"), ([("Pelvis", 0, 4)], "two-bone chain"),
])
def test_bad_contacts_raise(bad, match):
    m = random_leg_motion()
    with pytest.raises(ValueError, match=match):
        apply_contact_constraints(m, bad)


def test_bad_blend_and_mode_raise():
    m = random_leg_motion()
    with pytest.raises(ValueError, match="blend"):
        apply_contact_constraints(m, [("LeftFoot", 0, 4)], blend=-1)
    with pytest.raises(ValueError, match="mode"):
        apply_contact_constraints(m, [("LeftFoot", 0, 4)], mode="pin")


# --- real walk: hips 5 cm down ---------------------------------------------------------------------------

def simple_contacts(m: Motion, names, speed_cm_s: float, cm_per_unit: float, min_seconds=0.1):
    """Independent, transparent contact labels for the test: slow and in the lowest 30 % of its height range."""
    p = forward_kinematics(m)[0]
    out = []
    for n in names:
        j = m.skeleton.index(n)
        v = np.linalg.norm(np.gradient(p[:, j], axis=0), axis=-1) / m.frame_time * cm_per_unit
        y = p[:, j, 1]
        on = (v < speed_cm_s) & (y < y.min() + 0.3 * (y.max() - y.min()))
        edges = np.flatnonzero(np.diff(np.r_[0, on.astype(int), 0]))
        for s, e in zip(edges[::2], edges[1::2]):
            if (e - s) * m.frame_time >= min_seconds:
                out.append((n, int(s), int(e)))
    return out


@pytest.mark.parametrize("clip, feet, cm_per_unit", [
    # Bandai data is in centimetres (hips ~ 90 above the floor at y = 0)
    ("bandai_walk.bvh", ["Foot_L", "Foot_R", "Toes_L", "Toes_R"], 1.0),
    # Xia/CMU units: CMU's ASF length unit is 1/0.45 inch = 5.644 cm
    ("xia_neutral_walk.bvh", ["LeftFoot", "RightFoot", "LeftToeBase", "RightToeBase"], 2.54 / 0.45),
])
def test_real_walk_hips_down_5cm_feet_stay_planted(shared_motion, clip, feet, cm_per_unit):
    m = shared_motion(clip)
    contacts = simple_contacts(m, feet, speed_cm_s=20.0, cm_per_unit=cm_per_unit)
    assert len(contacts) >= 6  # a walk has several steps per foot
    down = 5.0 / cm_per_unit
    if m.local_translations is not None:   # Bandai: the Hips joint (1) carries the translation
        lt = np.array(m.local_translations)
        lt[:, 1, 1] -= down
        edited = m.replace(local_translations=lt)
    else:
        rp = np.array(m.root_positions)
        rp[:, 1] -= down
        edited = m.replace(root_positions=rp)
    before = contact_errors(edited, contacts, reference=m, mode="track") * cm_per_unit
    assert before.min() > 4.9  # the edit really moves the feet by ~5 cm
    out = apply_contact_constraints(edited, contacts, reference=m)
    err_cm = contact_errors(out, contacts, reference=m, mode="track") * cm_per_unit
    assert err_cm.max() < 1.0  # the bound; the analytic IK gives ~1e-10
    skate_orig = foot_skate(m, contacts) * cm_per_unit
    skate_out = foot_skate(out, contacts) * cm_per_unit
    print(f"{clip}: max contact error {err_cm.max():.2e} cm; foot skate (cm, summed over contacts) "
          f"original {skate_orig.sum():.2f}, after hips-down + constraints {skate_out.sum():.2f}")
    assert abs(skate_out.sum() - skate_orig.sum()) < 0.01 * skate_orig.sum() + 1e-6  # tracks the original feet

    # no velocity spike at the window borders: feet accelerations stay within the original's range,
    # while a hard switch (blend = 0) jumps 5 cm in one frame and does produce a spike
    js = [m.skeleton.index(n) for n in feet]

    def max_acc(motion):
        p = forward_kinematics(motion)[0][:, js]
        return np.linalg.norm(np.diff(p, 2, axis=0), axis=-1).max() * cm_per_unit / m.frame_time ** 2

    a_orig, a_out = max_acc(m), max_acc(out)
    a_hard = max_acc(apply_contact_constraints(edited, contacts, reference=m, blend=0.0))
    print(f"{clip}: max foot acceleration (cm/s^2) original {a_orig:.0f}, constrained {a_out:.0f}, "
          f"hard switch {a_hard:.0f}")
    # smooth fades: within 50 % of the original's own peak (the layer fades the boundary IK solution out in
    # joint space, Coleman et al. §3: a 5 cm correction faded over 0.15-0.6 s adds ~1600 cm/s^2 at 120 Hz on
    # xia; bandai 1.0x), while a hard switch is 20x
    assert a_out < 1.5 * a_orig
    # the metric does see a spike when there is one: a 5 cm jump in one frame adds 5 / dt^2 cm/s^2
    # (4500 at 30 Hz, 72000 at 120 Hz) on top of the walk's own acceleration
    assert a_hard > 1.3 * a_orig


def test_mean_mode_removes_own_skate(shared_motion):
    m = shared_motion("xia_neutral_walk.bvh")
    contacts = simple_contacts(m, ["LeftFoot", "RightFoot"], speed_cm_s=20.0, cm_per_unit=2.54 / 0.45)
    out = apply_contact_constraints(m, contacts)  # reference = itself, planted at the mean
    assert foot_skate(m, contacts).sum() > 0.1  # the capture does slide a little (file units)
    before, after = foot_skate(m, contacts), foot_skate(out, contacts)
    # not exactly zero: at heel strike the straight leg cannot reach the mean point (the IK clamps)
    assert after.sum() < 0.5 * before.sum()


def test_pipeline_contacts_from_detect_contacts(shared_motion):
    """The same check with the package's own detector (Appendix B) instead of the test's simple labels."""
    from stagger_nb.staggered import detect_contacts

    m = shared_motion("xia_neutral_walk.bvh")
    feet = ("LeftFoot", "RightFoot", "LeftToeBase", "RightToeBase")
    contacts = [c for c in detect_contacts(m) if c[0] in feet]
    assert len(contacts) >= 4  # both feet plant at least twice in 2.7 s of walking
    cm_per_unit = 2.54 / 0.45
    rp = np.array(m.root_positions)
    rp[:, 1] -= 5.0 / cm_per_unit
    out = apply_contact_constraints(m.replace(root_positions=rp), contacts, reference=m)
    assert contact_errors(out, contacts, reference=m, mode="track").max() * cm_per_unit < 1.0  # issue's bound
