"""keep_contacts: source contacts carried through staggered timing edits (carry_contacts, warp_times), then held
by the constraint layer (Coleman et al. 2008, §3 constraint displacement, §5.2 temporal edits; issue 11 item 6).
The layer's own figures (quality.compare on every clip) are in test_staggered_plants.py."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data, staggered
from stagger_nb.core.body import pelvis_joint
from stagger_nb.core.kinematics import forward_kinematics

# Units -> cm. Bandai clips and the procedural clips are in centimetres; the Xia and CMU clips use CMU's
# ASF length unit, 1/0.45 inch = 2.54 / 0.45 = 5.644 cm (a CMU skeleton is ~25 units tall at rest).
CLIPS = [("xia_neutral_walk.bvh", 2.54 / 0.45), ("bandai_walk.bvh", 1.0),
         ("cmu_131_01_walk_startstop.bvh", 2.54 / 0.45)]
SHRINK_S = 0.1     # seconds cut from each end of a contact before measuring (the measure)
GOAL_CM = 1.0


def horizontal_travel_cm(motion, contacts, cm_per_unit, shrink_s=SHRINK_S):
    """Largest horizontal path length (x/z, Y up) of a contact joint inside its contact interval shrunk by
    ``shrink_s`` at each end, in cm; intervals shorter than 2 frames after shrinking are skipped."""
    p = forward_kinematics(motion)[0]
    n = int(round(shrink_s / motion.frame_time))
    worst = 0.0
    for name, a, b in contacts:
        j = motion.skeleton.index(name)
        if b - a - 2 * n < 2:
            continue
        seg = p[a + n:b - n, j][:, [0, 2]]
        worst = max(worst, float(np.linalg.norm(np.diff(seg, axis=0), axis=-1).sum()))
    return worst * cm_per_unit


def stagger(sm):
    root = "Hips" if "Hips" in sm.skeleton.names else sm.skeleton.names[0]
    return staggered.random_timing(staggered.succession(sm, root=root, s=0.02, l=1.0), tau=0.05, seed=0)


def foot_rise_cm(out, m, contacts, carried, cm_per_unit, shrink_s=SHRINK_S):
    """Largest height of a contact joint above its source plant (the contact's mean source height) inside
    its carried contact interval shrunk by ``shrink_s`` at each end, cm."""
    p_out, p_src = forward_kinematics(out)[0], forward_kinematics(m)[0]
    n = int(round(shrink_s / out.frame_time))
    worst = 0.0
    for (name, a, b), (_, sa, sb) in zip(carried, [c for c in contacts
                                                   if staggered.carry_contacts(out, [c], m.frame_time)]):
        j = m.skeleton.index(name)
        if b - a - 2 * n >= 1:
            worst = max(worst, float((p_out[a + n:b - n, j, 1] - p_src[sa:sb, j, 1].mean()).max()))
    return worst * cm_per_unit


def pelvis_drop_cm(plain, out, cm_per_unit):
    """Largest change of the pelvis' world height (the joint named Hips, else joint 0) between the edit
    without and with keep_contacts, cm."""
    names = plain.skeleton.names
    j = names.index("Hips") if "Hips" in names else 0
    y0, y1 = (forward_kinematics(x)[0][:, j, 1] for x in (plain, out))
    return float(np.abs(y1 - y0).max()) * cm_per_unit


@pytest.fixture(scope="module")
def walk():
    m = data.load("walk")
    return m, staggered.extract(m)


def test_carry_contacts_identity_without_timing_edits(walk):
    m, sm = walk
    assert staggered.carry_contacts(sm, sm.contacts, m.frame_time) == list(sm.contacts)
    assert staggered.carry_contacts(m, sm.contacts, m.frame_time) == list(sm.contacts)
    # a geometric edit changes no timing
    geo = staggered.edit_pose(sm, 3, deltas={"LeftArm": [0.0, 0.0, 0.3]})
    assert staggered.carry_contacts(geo, sm.contacts, m.frame_time) == list(sm.contacts)


def test_carry_contacts_move_with_the_pelvis_timing(walk):
    """The default carry (carry_by="pelvis"): shift only the pelvis's knots by 3 frames and every leg contact
    (away from the anchored clip ends) moves by exactly 3 frames; shift only the left toes' and none moves (the
    feet hang from the pelvis: its timing decides where a held foot can be)."""
    m, sm = walk
    dt = 3 * m.frame_time
    assert m.skeleton.names[pelvis_joint(m.skeleton)] == "Hips"
    pelvis = staggered.succession(sm, root="LowerBack", s=dt, l=1.0, joints=["Hips"], limit=None)   # d = 1
    toes = staggered.succession(sm, root="LeftFoot", s=dt, l=1.0, joints=["LeftToeBase"], limit=None)
    T0 = sm.pose_times
    inner = [c for c in sm.contacts if T0[1] + dt <= c[1] * m.frame_time and (c[2] - 1) * m.frame_time <= T0[-2]]
    assert inner
    assert staggered.carry_contacts(toes, inner, m.frame_time) == inner
    assert staggered.carry_contacts(pelvis, inner, m.frame_time) == [(n, a + 3, b + 3) for n, a, b in inner]


def test_carry_contacts_move_with_the_foot_own_timing(walk):
    """carry_by="joint": shift only the left foot's knots by 3 frames: its contacts (away from the anchored clip
    ends) move by exactly 3 frames, every other contact stays (a pure shift of interior knots is a shift of the
    warp)."""
    m, sm = walk
    dt = 3 * m.frame_time
    shifted = staggered.succession(sm, root="LeftFoot", s=dt, l=1.0, joints=["LeftToeBase"], limit=None)  # d = 1
    carried = staggered.carry_contacts(shifted, sm.contacts, m.frame_time, carry_by="joint")
    T0 = sm.pose_times
    for (n0, a0, b0), (n1, a1, b1) in zip(sm.contacts, carried):
        assert n0 == n1
        inside = T0[1] + dt <= a0 * m.frame_time and (b0 - 1) * m.frame_time <= T0[-2]
        if n0 == "LeftToeBase" and inside:
            assert (a1, b1) == (a0 + 3, b0 + 3)
        elif n0 != "LeftToeBase":
            assert (a1, b1) == (a0, b0)
    assert any(c[0] == "LeftToeBase" for c in carried)


def test_warp_times_closed_form_and_survives_insert_delete(walk):
    m, sm = walk
    k = 5
    moved = staggered.retime(sm, {k: sm.pose_times[k] + 0.1})
    # a retimed pose stretches the segment before it and compresses the one after: piecewise linear
    j = sm.skeleton.index("LeftArm")
    S = staggered.source_knot_times(moved)[:, j]
    T = moved.knot_times()[:, j]
    x = np.linspace(S[k - 1], S[k + 1], 7)
    assert np.allclose(staggered.warp_times(moved, x, "LeftArm"), np.interp(x, S, T))
    assert np.allclose(staggered.warp_times(moved, staggered.warp_times(moved, x, j), j, inverse=True), x)
    # inserting a pose does not change the motion, so neither the warp
    edited = stagger(sm)
    t_new = 0.5 * (edited.pose_times[6] + edited.pose_times[7])
    ins = staggered.insert_pose(edited, t_new)
    x = np.linspace(0.5, 5.5, 23)
    for c in ("LeftFoot", "RightToeBase", "<root translation>"):
        assert np.allclose(staggered.warp_times(ins, x, c), staggered.warp_times(edited, x, c), atol=1e-9)
        dele = staggered.delete_pose(ins, 7)
        assert np.allclose(staggered.warp_times(dele, x, c), staggered.warp_times(edited, x, c), atol=1e-9)


def test_keep_contacts_without_lowering_keeps_the_root(walk):
    """lower_root=False: the root translation is the edit's, bit for bit; the feet are still held."""
    m, sm = walk
    edited = stagger(sm)
    plain = staggered.evaluate(edited)
    out = staggered.keep_contacts(edited, m, lower_root=False, blend=0.1)
    assert np.array_equal(out.root_positions, plain.root_positions)
    assert np.abs(out.local_quats - plain.local_quats).max() > 1e-3


def test_keep_contacts_bad_input(walk):
    m, sm = walk
    with pytest.raises(ValueError, match="source"):
        staggered.keep_contacts(sm, "walk.bvh")
    with pytest.raises(ValueError, match="contacts"):
        staggered.keep_contacts(sm, m, contacts=[("Nose", 0, 10)])
    with pytest.raises(ValueError, match="edited"):
        staggered.carry_contacts([1, 2], sm.contacts, m.frame_time)
    for bad in (1.5, -0.1, float("nan")):
        with pytest.raises(ValueError, match="lower_root"):
            staggered.keep_contacts(sm, m, lower_root=bad)
    # no contacts: the evaluated motion itself
    assert np.array_equal(staggered.keep_contacts(sm, m, contacts=[]).local_quats, staggered.evaluate(sm).local_quats)


def test_cull_after_timing_edits_keeps_the_warp(walk):
    """cull keeps a subset of the poses at their times: their source knot times stay, so the contacts are
    still carried (and held)."""
    m, sm = walk
    edited = stagger(sm)
    culled = staggered.cull(edited, percent=60)
    assert culled.num_poses < edited.num_poses
    S, S_all = staggered.source_knot_times(culled), staggered.source_knot_times(edited)
    rows = [int(np.flatnonzero(np.isclose(edited.pose_times, t))[0]) for t in culled.pose_times]
    assert np.array_equal(S, S_all[rows])
    carried = staggered.carry_contacts(culled, sm.contacts, m.frame_time)
    assert carried != list(sm.contacts)                       # moved with the feet's timing
    out = staggered.keep_contacts(culled, m)
    before = horizontal_travel_cm(staggered.evaluate(culled), carried, 1.0)
    assert horizontal_travel_cm(out, carried, 1.0) <= 0.1 * before


def _delayed(sm, m, parent, joint):
    """``sm`` with only ``joint``'s knots of poses 2-10 delayed by exactly 3 frames (succession from ``parent``,
    d = 1, the raw offsets: the saturation would ease the delay where it squeezes a fast segment), and the
    source's LeftToeBase contacts inside those poses (away from the anchored knots)."""
    dt = 3 * m.frame_time
    T0 = sm.pose_times
    inner = [c for c in sm.contacts if c[0] == "LeftToeBase" and T0[2] + dt <= c[1] * m.frame_time
             and (c[2] - 1) * m.frame_time <= T0[10]]
    assert inner
    return staggered.succession(sm, root=parent, s=dt, l=1.0, joints=[joint], poses=range(2, 11), limit=None), inner


def test_carry_by_limb_uses_the_hip_timing(walk):
    """carry_by="limb": a contact moves with its limb's upper joint (hip); shifting only the hips' knots
    moves the feet's contacts, shifting only the toes' does not (and the other way round for "joint")."""
    m, sm = walk
    hips, inner = _delayed(sm, m, "LHipJoint", "LeftUpLeg")
    toes, _ = _delayed(sm, m, "LeftFoot", "LeftToeBase")
    cases = ((hips, "limb", True), (toes, "limb", False), (hips, "joint", False), (toes, "joint", True))
    for edited, by, moves in cases:
        got = staggered.carry_contacts(edited, inner, m.frame_time, carry_by=by)
        assert got == [(n, a + 3 * moves, b + 3 * moves) for n, a, b in inner], (by, moves)
    out = staggered.keep_contacts(stagger(sm), m, carry_by="limb")
    carried = staggered.carry_contacts(stagger(sm), sm.contacts, m.frame_time, carry_by="limb")
    before = horizontal_travel_cm(staggered.evaluate(stagger(sm)), carried, 1.0)
    assert horizontal_travel_cm(out, carried, 1.0) <= 0.1 * before
    with pytest.raises(ValueError, match="carry_by"):
        staggered.carry_contacts(sm, sm.contacts, m.frame_time, carry_by="knee")


def test_keep_contacts_on_hops_removes_most_of_the_sliding():
    """Notebook 01's check on the real hops (both feet land together): after a rough timing edit, the feet's
    sliding over the source's own contacts falls to 12 % (1176 -> 139 cm summed: the plants are carried on the
    pelvis's timing, so a source contact's first frames can still be in the air where the edit moved it), with
    the pelvis lowered by at most the layer's budget (2.8 % of a leg)."""
    try:
        cmu = data.load("cmu_01_01")
    except FileNotFoundError as e:
        pytest.skip(f"cmu_01_01 not prepared: {e}")
    hops = cmu.resample(1 / 30).slice(0, int(8.5 * 30))
    sm = staggered.extract(hops)
    contacts = staggered.detect_contacts(hops)
    rough = staggered.random_timing(staggered.succession(sm, root="Hips", s=0.02, l=1.0), tau=0.05, seed=1)
    slid, held = staggered.evaluate(rough), staggered.keep_contacts(rough, hops)
    skate = [float(staggered.foot_skate(x, contacts).sum()) for x in (slid, held)]
    drop = float(np.abs(slid.root_positions - held.root_positions)[:, 1].max())
    print(f"hops: sliding {skate[0]:.1f} -> {skate[1]:.1f} cm, pelvis lowered up to {drop:.2f} cm")
    assert skate[1] < 0.3 * skate[0]
    assert drop < 3.0


def test_lower_root_share_splits_the_missing_reach(walk):
    """lower_root=0 keeps the root bit for bit; the pelvis drop grows with the share (0 <= 0.5 <= 1) while the
    held feet stay put horizontally whatever the share."""
    m, sm = walk
    edited = stagger(sm)
    plain = staggered.evaluate(edited)
    carried = staggered.carry_contacts(edited, sm.contacts, m.frame_time)
    drops = []
    for share in (0.0, 0.5, 1.0):
        out = staggered.keep_contacts(edited, m, lower_root=share)
        drops.append(pelvis_drop_cm(plain, out, 1.0))
        assert horizontal_travel_cm(out, carried, 1.0) <= GOAL_CM
    assert np.array_equal(staggered.keep_contacts(edited, m, lower_root=False).root_positions, plain.root_positions)
    assert drops[0] == 0.0 and drops[0] <= drops[1] <= drops[2] and drops[2] > 0


def test_source_positions_given_give_the_same_result(walk):
    """``source_positions`` (what an edit session caches per source) replaces keep_contacts' own forward
    kinematics of the source: the same numbers bit for bit (the same products in the same order); a wrong
    shape is a ValueError naming it."""
    m, sm = walk
    edited = stagger(sm)
    plain = staggered.keep_contacts(edited, m)
    given = staggered.keep_contacts(edited, m, source_positions=forward_kinematics(m)[0])
    assert np.array_equal(plain.local_quats, given.local_quats)
    assert np.array_equal(plain.root_positions, given.root_positions)
    assert np.abs(plain.local_quats - staggered.evaluate(edited).local_quats).max() > 1e-3   # it did hold feet
    with pytest.raises(ValueError, match="source_positions"):
        staggered.keep_contacts(edited, m, source_positions=forward_kinematics(m)[0][:-1])


def test_carry_by_span_is_the_union_of_the_joint_and_knee_timings(walk):
    """carry_by="span": a contact holds from the earlier to the later of the
    intervals carried by its own joint's warp and by its limb's knee's. Delaying only the knee (or only the
    toe) by 3 frames delays a toe contact's stop by 3 frames and keeps its start; "joint" ignores the knee.
    On the real-walk edit, a joint's carried contacts never overlap and each covers its "joint" interval up
    to where the joint's next contact starts; without timing edits every mode is the identity."""
    m, sm = walk
    knee, inner = _delayed(sm, m, "LeftUpLeg", "LeftLeg")
    toes, _ = _delayed(sm, m, "LeftFoot", "LeftToeBase")
    for edited, by, later in ((knee, "span", 3), (toes, "span", 3), (knee, "joint", 0)):
        got = staggered.carry_contacts(edited, inner, m.frame_time, carry_by=by)
        assert got == [(n, a, b + later) for n, a, b in inner], (by, later)
    assert staggered.carry_contacts(sm, sm.contacts, m.frame_time, carry_by="span") == list(sm.contacts)
    edited = stagger(sm)
    span = staggered.carry_contacts(edited, sm.contacts, m.frame_time, carry_by="span")
    own = staggered.carry_contacts(edited, sm.contacts, m.frame_time, carry_by="joint")
    assert len(span) == len(own) and [c[0] for c in span] == [c[0] for c in own]
    for i, ((n, a, b), (_, a0, b0)) in enumerate(zip(span, own)):
        nxt = [s_ for k, (n2, s_, _) in enumerate(span) if n2 == n and k != i and s_ >= a]
        assert a <= a0 and (b >= b0 or (nxt and b == min(nxt))), (n, a, b, a0, b0)
        assert all(b <= s_ for s_ in nxt)


@pytest.mark.parametrize("clip, cm_per_unit", CLIPS)
def test_toe_does_not_step_when_its_heel_is_released(shared_motion, clip, cm_per_unit):
    """Where an ankle contact ends inside a toe contact of the same foot (heel-off), the toe is already on its
    plant: its step into the ankle's release frame (the contacts as the layer carries them) is < 0.5 cm (xia
    0.014, bandai 0.498, cmu 0.249; before the heel release of keep_contacts, cmu_131_01 RightToe 821-942 stepped
    1.0 cm there: its plant is 9 % farther from the ankle's than the foot is long, so the toe reached it only after
    the release; bandai stepped 1.1 cm while contacts were carried on each joint's own clock)."""
    m = shared_motion(clip)
    sm = stagger(staggered.extract(m))
    source_contacts = staggered.detect_contacts(m)
    out = staggered.keep_contacts(sm, m, contacts=source_contacts)
    carried = staggered.carry_contacts(sm, source_contacts, m.frame_time)          # the layer's own carry
    p = forward_kinematics(out)[0]
    names = m.skeleton.names
    checked, worst = 0, 0.0
    for toe, s, e in carried:
        j = names.index(toe)
        ankle = names[int(m.skeleton.parents[j])]
        for name, _, stop in carried:
            if name == ankle and s < stop - 1 and stop < e:
                step = float(np.linalg.norm(p[stop, j, [0, 2]] - p[stop - 1, j, [0, 2]])) * cm_per_unit
                worst, checked = max(worst, step), checked + 1
    print(f"{clip}: {checked} heel releases inside a toe contact, toe step there <= {worst:.3f} cm")
    assert checked > 0
    assert worst < 0.5


@pytest.mark.parametrize("clip, rows", [
    ("iclone_cmu_07_01_walk.bvh", [("CC_Base_L_Foot", "CC_Base_L_Calf", "CC_Base_Hip"),
                                   ("CC_Base_L_ToeBase", "CC_Base_L_Foot", "CC_Base_Hip"),
                                   ("CC_Base_L_BigToe1", "CC_Base_L_ToeBase", "CC_Base_Hip")]),
    ("bandai_walk.bvh", [("Foot_L", "LowerLeg_L", "Hips"), ("Toes_L", "Foot_L", "Hips")])])
def test_the_clock_that_carries_a_contact(shared_motion, clip, rows):
    """Known answers on two rigs: position_joint (carry_by="parent") is the joint whose rotation moves the
    contact joint (the knee for an ankle, on the 101-joint CC rig past its twist and share bones); the default
    carry is the pelvis's clock (CC_Base_Hip, Bandai's Hips below its static joint_Root)."""
    from stagger_nb.staggered.plants_carry import carry_clocks, position_joint
    sk = shared_motion(clip).skeleton
    for joint, parent, pelvis in rows:
        assert sk.names[position_joint(sk, joint)] == parent
        assert carry_clocks(sk, [sk.index(joint)], "parent") == [[sk.index(parent)]]
        assert carry_clocks(sk, [sk.index(joint)]) == [[sk.index(pelvis)]]


def test_carry_windows_is_the_union_over_a_contacts_clocks():
    """carry_windows with hand-made warp tables: clock 0 delays by 0.1 s, clock 1 by 0.3 s (a pure shift between
    the end knots): a contact on [0.5, 1.0] s carried by [0] is [0.6, 1.1], by [1] [0.8, 1.3], by both [0.6, 1.3];
    frames (0.1 s, from t0 = 0) inside, half-open; no tables: the identity."""
    from stagger_nb.staggered.plants_carry import carry_windows
    S = np.array([[0.0, 0.0], [0.2, 0.2], [1.8, 1.8], [2.0, 2.0]])
    T = np.array([[0.0, 0.0], [0.3, 0.5], [1.9, 2.1], [2.0, 2.0]])
    ends = np.array([[0.5, 1.0]] * 3)
    e, start, stop = carry_windows((S, T), 0.0, 0.1, 20, ends, [[0], [1], [0, 1]])
    assert np.allclose(e, [[6, 11], [8, 13], [6, 13]])
    assert start.tolist() == [6, 8, 6] and stop.tolist() == [12, 14, 14]
    e, start, stop = carry_windows(None, 0.0, 0.1, 20, ends[:1], [[0]])
    assert np.allclose(e, [[5, 10]]) and (start[0], stop[0]) == (5, 11)
