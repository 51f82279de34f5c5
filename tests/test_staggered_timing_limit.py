"""Timing edits that stay in order at every slider position (issue "Edits an animator would keep", item 2).

succession / random_timing saturate their offsets (``limit``, default ``TIMING_LIMIT``): at any value the
editor's sliders allow (s in [-0.1, 0.1], l in [0.25, 4], tau in [0, 0.15], any root) every joint's refined
knots stay strictly increasing, no segment plays more than ``limit`` times faster than in the source, and
the timing edit alone adds no pop (sn.quality.compare); ``limit=None`` is the paper's formula."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from stagger_nb import data, quality, staggered
from stagger_nb.core.body import pelvis_joint, subtree

S_GRID = (-0.1, -0.05, -0.02, 0.02, 0.05, 0.1)
L_GRID = (0.25, 1.0, 2.0, 4.0)
TAU_GRID = (0.0, 0.05, 0.1, 0.15)


def _roots(sk):
    shoulder = next(n for n in sk.names if "shoulder" in n.lower() and "left" in n.lower())
    return sk.names[pelvis_joint(sk)], shoulder


def _all_knots(sm):
    return np.concatenate([sm.knot_times(), (sm.pose_times + sm.root_refinements)[:, None]], axis=1)


@pytest.fixture(scope="module", params=["walk", "xia_neutral_walk.bvh"])
def clip(request, shared_motion):
    m = data.load(request.param) if request.param == "walk" else shared_motion(request.param)
    return m, staggered.extract(m)


def test_every_slider_position_keeps_the_knots_in_order_and_the_speed_up_bounded(clip):
    """Brute force over the slider grid (6 s x 4 l x 4 tau x 2 roots = 192 edits): every column's knots
    strictly increasing, every segment longer than 1 / limit of its source length. The raw formula crosses
    knots on the same grid (else the check would prove nothing)."""
    m, sm = clip
    S = np.diff(_all_knots(sm), axis=0)
    crossed_raw = 0
    for root, s, l, tau in itertools.product(_roots(sm.skeleton), S_GRID, L_GRID, TAU_GRID):
        e = staggered.random_timing(staggered.succession(sm, root=root, s=s, l=l), tau=tau, seed=1)
        D = np.diff(_all_knots(e), axis=0)
        assert np.all(D > 0), (root, s, l, tau)
        assert np.all(D > S / staggered.TIMING_LIMIT - 1e-12), (root, s, l, tau)
        raw = staggered.random_timing(staggered.succession(sm, root=root, s=s, l=l, limit=None), tau=tau, seed=1,
                                      limit=None)
        crossed_raw += not np.all(np.diff(_all_knots(raw), axis=0) > 0)
    assert crossed_raw > 100


@pytest.mark.parametrize("preset, s, l, tau", [("mild", 0.02, 1.0, 0.05), ("moderate", 0.03, 2.0, 0.1),
                                              ("strong", 0.05, 3.0, 0.1)])
def test_the_issue_edits_add_no_pop_and_keep_the_knots_in_order(clip, preset, s, l, tau):
    """The timing edit alone (no contact layer), root = the pelvis: no joint's knots out of order and the
    added pop within the preset's bound (5° / 5° / 10°); measured by sn.quality.compare."""
    m, sm = clip
    e = staggered.random_timing(staggered.succession(sm, root=_roots(sm.skeleton)[0], s=s, l=l), tau=tau)
    r = quality.compare(m, e, bounds=preset)
    assert r.knots_out_of_order == ()
    assert r.added_pop <= quality.PRESETS[preset].pop, r.summary


def test_the_slider_extremes_add_at_most_the_strong_pop(clip):
    """s = ±0.1 with l = 4 and tau = 0.15, from the pelvis and from the left shoulder: the added pop stays
    within the strong edit's bound (10°); the raw formula adds more on some of them."""
    m, sm = clip
    worst, worst_raw = 0.0, 0.0
    for root, s in itertools.product(_roots(sm.skeleton), (-0.1, 0.1)):
        e = staggered.random_timing(staggered.succession(sm, root=root, s=s, l=4.0), tau=0.15)
        worst = max(worst, quality.compare(m, e).added_pop)
        raw = staggered.random_timing(staggered.succession(sm, root=root, s=s, l=4.0, limit=None), tau=0.15,
                                      limit=None)
        worst_raw = max(worst_raw, quality.compare(m, raw).added_pop)
    assert worst <= quality.PRESETS["strong"].pop
    assert worst_raw > worst


def test_zero_offsets_are_bit_identical_and_small_ones_exact():
    m = data.load("walk")
    sm = staggered.extract(m)
    assert staggered.succession(sm, root="Hips", s=0.0, l=2.0) is sm
    assert staggered.random_timing(sm, tau=0.0) is sm
    # a tiny delay squeezes no segment below its identity zone: the raw offsets, to rounding
    a = staggered.succession(sm, root="Hips", s=1e-4, l=1.0)
    b = staggered.succession(sm, root="Hips", s=1e-4, l=1.0, limit=None)
    assert np.array_equal(a.refinements, b.refinements)
    assert "timing_limits" not in a.metadata and staggered.timing_summary(a) == ""
    # joints the edit does not touch keep their refinements exactly
    c = staggered.succession(sm, root="LeftShoulder", s=0.1, l=4.0)
    untouched = np.setdiff1d(np.arange(sm.num_joints), subtree(sm.skeleton, sm.skeleton.index("LeftShoulder")))
    assert np.array_equal(c.refinements[:, untouched], sm.refinements[:, untouched])
    assert not np.array_equal(c.refinements, sm.refinements)


def test_raw_mode_is_the_paper_formula_for_random_timing():
    m = data.load("walk")
    sm = staggered.extract(m)
    out = staggered.random_timing(sm, tau=0.1, seed=4, limit=None)
    u = np.random.default_rng(4).uniform(-0.1, 0.1, size=sm.refinements.shape)
    u[[0, -1]] = 0.0
    assert np.allclose(out.refinements, sm.refinements + u, rtol=0, atol=1e-15)


def test_saturated_offsets_grow_monotonically_and_continuously_with_s():
    """The kept delay of a joint is a monotone, continuous function of s (no jump as the slider moves): on
    a fine grid of s its change is never negative and never larger than the raw change."""
    m = data.load("walk")
    sm = staggered.extract(m)
    h = sm.skeleton.index("LeftHand")
    k = sm.num_poses // 2
    ss = np.linspace(0.0, 0.1, 201)
    kept = np.array([staggered.succession(sm, root="Hips", s=s, l=2.0).knot_times()[k, h] for s in ss])
    d = sm.skeleton.tree_distance("Hips")[h] ** 2.0
    step = np.diff(kept)
    assert np.all(step >= -1e-12)
    assert np.all(step <= np.diff(ss) * d + 1e-12)
    assert kept[-1] - kept[0] < 0.5 * 0.1 * d                # it is limited (raw would be 0.1 d^l)


def test_a_pose_delay_is_cut_locally():
    """A delay of one pose is paid back by the segment it stretched: the other knots do not move."""
    m = data.load("walk")
    sm = staggered.extract(m)
    k = 4
    out = staggered.succession(sm, root="LeftShoulder", s=0.1, l=2.0, poses=[k])
    moved = np.abs(out.knot_times() - sm.knot_times()) > 0
    assert moved[k].any() and not moved[np.arange(sm.num_poses) != k].any()


def test_compounded_edits_do_not_compound_the_speed_up():
    """Succession then random timing: the floors refer to the source knots, so the second edit cannot
    squeeze what the first already squeezed below 1 / limit of the source."""
    m = data.load("walk")
    sm = staggered.extract(m)
    S = np.diff(_all_knots(sm), axis=0)
    e = sm
    for i in range(4):
        e = staggered.random_timing(staggered.succession(e, root="Hips", s=0.05, l=2.0), tau=0.15, seed=i)
    assert np.all(np.diff(_all_knots(e), axis=0) > S / staggered.TIMING_LIMIT - 1e-12)


def test_limit_argument_is_checked():
    sm = staggered.extract(data.load("walk"))
    for bad in (1.0, 0.5, True, "x", float("nan")):
        with pytest.raises(ValueError, match="limit"):
            staggered.succession(sm, root="Hips", s=0.02, limit=bad)
        with pytest.raises(ValueError, match="limit"):
            staggered.random_timing(sm, tau=0.02, limit=bad)


# -- the one plain sentence ----------------------------------------------------------------------------------

def test_the_sentence_names_body_parts_and_the_kept_delay():
    m = data.load("walk")
    sm = staggered.extract(m)
    e = staggered.succession(sm, root="Hips", s=0.1, l=4.0)
    text = staggered.timing_summary(e)
    assert text.startswith("To keep each joint's poses in order, the delay was limited for the ")
    assert text.count(".") <= 1 + text.count(" s") and "fingers" in text and text.endswith(".")
    rec = e.metadata["timing_limits"]
    assert all(r["op"] == "succession" and r["asked"] > r["applied"] > 0 for r in rec)
    lead = staggered.timing_summary(staggered.succession(sm, root="Hips", s=-0.1, l=4.0))
    assert "the lead was limited" in lead
    rnd = staggered.timing_summary(staggered.random_timing(sm, tau=0.15))
    assert "random offsets were limited" in rnd and "±" in rnd
    # the raw formula: knots cross, the sentence says so and how to fix it
    raw = staggered.timing_summary(staggered.succession(sm, root="Hips", s=0.1, l=4.0, limit=None))
    assert "now play out of order" in raw and "timing limit" in raw
    # nothing to say about a mild edit, nor about the extraction
    assert staggered.timing_summary(staggered.succession(sm, root="Hips", s=0.002, l=1.0)) == ""
    assert staggered.timing_summary(sm) == ""


@pytest.mark.parametrize("name, words", [
    ("LeftHandIndex1", "the left fingers"), ("CC_Base_R_Thigh", "the right leg"), ("Foot_L", "the left foot"),
    ("mixamorig:RightForeArm", "the right arm"), ("lhand", "the left hand"), ("Hips", "the hips"),
    ("LHipJoint", "the left leg"), ("LeftHip", "the left leg"), ("CC_Base_L_BigToe1", "the left toes"),
    ("Spine1", "the spine"), ("Neck1", "the head"), ("CC_Base_Hip", "the hips"), ("RightToeBase", "the right toes"),
    ("CC_Base_L_Mid2", "the left fingers"), ("UpperArm_R", "the right arm"), ("Widget", "Widget"),
])
def test_body_parts_in_plain_words(name, words):
    assert staggered.body_part(name) == words


def _largest_steps(motion) -> np.ndarray:
    """Per joint, the largest frame-to-frame rotation angle (degrees) of the local rotations, computed directly."""
    q = np.asarray(motion.local_quats)
    dots = np.clip(np.abs(np.sum(q[:-1] * q[1:], axis=-1)), 0.0, 1.0)
    return np.degrees(2.0 * np.arccos(dots)).max(axis=0)


def test_a_long_segment_holding_the_peak_is_not_squeezed_into_a_pop(shared_motion):
    """bandai_run_cycle: 24 frames, 4 poses, so the lower leg's segment between frames 5 and 17 holds its
    fastest swing (16.4°/frame) yet is slow on average (it also holds a pause). The mean-speed floor let the
    moderate edit (pelvis, s=0.03, l=2, tau=0.1) squeeze it to 0.68 of its length: a 23.3° step (1.42 times
    the source's largest), an added pop of 6.9° > 5°. The floor from the segment's peak speed keeps every
    joint's largest step within 1.3 times the source's (1 / 0.8 = 1.25 in continuous time, plus frame
    sampling) and the pop within the bound."""
    m = shared_motion("bandai_run_cycle.bvh")
    sm = staggered.extract(m)
    base = _largest_steps(staggered.evaluate(sm))
    moving = base > 1.0
    root = sm.skeleton.names[pelvis_joint(sm.skeleton)]
    worst_ratio = 0.0
    for s, l, tau in ((0.03, 2.0, 0.1), (0.05, 3.0, 0.1), (0.1, 4.0, 0.15), (-0.1, 4.0, 0.15)):
        e = staggered.random_timing(staggered.succession(sm, root=root, s=s, l=l), tau=tau)
        worst_ratio = max(worst_ratio, float((_largest_steps(staggered.evaluate(e))[moving] / base[moving]).max()))
        if (s, l) == (0.03, 2.0):
            r = quality.compare(m, e, bounds="moderate")
            assert r.added_pop <= 5.0, r.summary
            assert r.knots_out_of_order == ()
    assert worst_ratio <= 1.3
    # the paper's raw offsets (limit=None) stay reachable and do squeeze the swing
    raw = staggered.random_timing(staggered.succession(sm, root=root, s=0.03, l=2.0, limit=None), tau=0.1,
                                  limit=None)
    assert float((_largest_steps(staggered.evaluate(raw))[moving] / base[moving]).max()) > 2.0
