"""sn.quality.compare: the figures of an edit (issue "Edits an animator would keep", item 3).

Hand-built motions with a known slide / drop / pop / out-of-order knot must give exactly those figures;
compare(m, m) is all zero; the figures do not change when a clip is scaled uniformly."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from quality_figures import FEET, FT, NAMES, OFFSETS, PARENTS, F, standing

import stagger_nb as sn
from stagger_nb import data, quality, staggered
from stagger_nb.core.motion import Motion
from stagger_nb.core.rotations import quat_exp, quat_mul
from stagger_nb.core.skeleton import Skeleton


def rot_x(deg):
    return quat_exp(np.array([np.radians(deg) / 2, 0.0, 0.0]))


# -- exact figures on the hand-built figure ---------------------------------------------------------------

def test_the_figure_is_170_cm_and_its_contacts_are_both_feet():
    m = standing()
    assert quality.body_height(m) == pytest.approx(170.0, abs=1e-12)
    r = quality.compare(m, m, contacts=FEET)
    assert r.scale == pytest.approx(1.0, abs=1e-12)
    assert [c.joint for c in r.contacts] == ["LeftFoot", "RightFoot"]


def test_a_known_slide_is_the_foot_travel():
    """The root slides 5 cm along x over frames 10..30 (a linear ramp), then stays: both planted feet
    travel exactly 5 cm from where their contact started, their height does not change."""
    rp = np.tile([0.0, 90.0, 0.0], (F, 1))
    ramp = np.clip((np.arange(F) - 10) / 20.0, 0.0, 1.0) * 5.0
    rp[:, 0] += ramp
    r = quality.compare(standing(), standing(root=rp), contacts=FEET)
    assert r.foot_travel == pytest.approx(5.0, abs=1e-9)
    assert r.foot_travel_raw == pytest.approx(5.0, abs=1e-9)
    assert r.foot_path == pytest.approx(5.0, abs=1e-9)
    assert r.foot_height == pytest.approx(0.0, abs=1e-9)
    assert r.pelvis == pytest.approx(0.0, abs=1e-9) and r.floor == 0.0
    assert r.moved == pytest.approx(5.0, abs=1e-9)
    assert r.added_jump == pytest.approx(5.0 / 20, abs=1e-9)          # one ramp step per frame
    assert r.added_pop == 0.0 and r.rotated == 0.0
    # the source's intervals shrunk by 0.1 s (3 frames at 30 Hz) still hold the whole ramp
    assert r.foot_travel_source == pytest.approx(5.0, abs=1e-9)
    assert not r.ok and any(f.startswith("foot travel 5.00 cm > 1 cm") for f in r.failures)
    assert r.summary == "left foot slides 5.0 cm · pelvis ±0.0 cm · no pops"


def test_a_known_drop_is_the_pelvis_the_floor_and_the_foot_height_but_no_travel():
    """Everything 4 cm lower on every frame: pelvis, floor and foot height are 4 cm; the feet do not travel
    inside their contacts (a constant offset), nothing pops."""
    rp = np.tile([0.0, 86.0, 0.0], (F, 1))
    r = quality.compare(standing(), standing(root=rp), contacts=FEET)
    assert r.pelvis == pytest.approx(4.0, abs=1e-9) and r.pelvis_drop == pytest.approx(4.0, abs=1e-9)
    assert r.floor == pytest.approx(4.0, abs=1e-9)
    assert r.foot_height == pytest.approx(4.0, abs=1e-9)
    assert r.foot_travel == pytest.approx(0.0, abs=1e-9)
    assert r.added_pop == 0.0 and r.added_jump == pytest.approx(0.0, abs=1e-9)
    # a rise is no floor penetration, and is no drop
    up = quality.compare(standing(), standing(root=np.tile([0.0, 93.0, 0.0], (F, 1))), contacts=FEET)
    assert up.floor == 0.0 and up.pelvis_drop == 0.0 and up.pelvis == pytest.approx(3.0, abs=1e-9)


def test_pelvis_against_a_baseline_is_the_layer_own_change():
    lowered = standing(root=np.tile([0.0, 88.0, 0.0], (F, 1)))          # "the edit without the layer"
    layer = standing(root=np.tile([0.0, 87.5, 0.0], (F, 1)))            # "the layer lowers 0.5 cm more"
    r = quality.compare(standing(), layer, contacts=FEET, baseline=lowered)
    assert r.pelvis == pytest.approx(2.5, abs=1e-9)
    assert r.pelvis_vs_baseline == pytest.approx(0.5, abs=1e-9)
    # the mild bound (3 cm) is checked against the baseline; the feet are 2.5 cm below their plants
    assert r.failures == ("foot height vs plant 2.50 cm > 1.5 cm", "floor penetration 2.50 cm > 1.5 cm")
    assert r.with_bounds({"pelvis": 0.4, "height": 3, "floor": 3}).failures == ("pelvis vs no layer 0.50 cm > 0.4 cm",)


def test_a_known_pop_is_the_added_pop():
    """The left knee turns 30° at frame 20 (a step): the added pop is 30° there and the foot's jump is the
    chord of a 45 cm shin turned by 30°."""
    q = np.tile([0.0, 0.0, 0.0, 1.0], (F, len(NAMES), 1))
    q[20:, NAMES.index("LeftLeg")] = rot_x(30.0)
    r = quality.compare(standing(), standing(quats=q), contacts=FEET)
    assert r.added_pop == pytest.approx(30.0, abs=1e-9)
    assert r.added_pop_joint == "LeftLeg"
    assert r.pop_added[NAMES.index("LeftLeg")] == pytest.approx(30.0, abs=1e-9)
    assert sum(p > 0 for p in r.pop_added) == 1
    assert r.added_jump == pytest.approx(2 * 45 * np.sin(np.radians(15)), abs=1e-9)
    assert r.added_jump_joint == "LeftFoot"
    assert r.rotated == pytest.approx(30.0, abs=1e-9)
    # the turned shin swings the planted foot by the chord (23.3 cm) and lifts it by 45 (1 - cos 30°) = 6.0 cm
    assert r.foot_height == pytest.approx(45 * (1 - np.cos(np.radians(30))), abs=1e-9)
    assert r.summary == "left foot slides 23 cm · left foot 6.0 cm off its plant · pelvis ±0.0 cm · left leg pops 30°"
    # a pop the source already has is not added
    again = quality.compare(standing(quats=q), standing(quats=q), contacts=FEET)
    assert again.added_pop == 0.0


def test_pops_are_compared_per_source_frame_when_the_frame_rates_differ():
    """A motion turning 2°/frame at 30 Hz, resampled to 60 Hz (1°/frame): no pop is added."""
    q = np.tile([0.0, 0.0, 0.0, 1.0], (F, len(NAMES), 1))
    q[:, NAMES.index("Spine")] = quat_exp(np.outer(np.radians(2.0 * np.arange(F)) / 2, [0, 1, 0]))
    m = standing(quats=q)
    r = quality.compare(m, m.resample(FT / 2), contacts=FEET)
    assert r.added_pop == pytest.approx(0.0, abs=1e-6)
    assert r.moved == pytest.approx(0.0, abs=1e-9)


def test_detail_is_one_for_the_same_curves_and_falls_when_smoothed():
    m = data.load("walk")
    assert quality.compare(m, m).detail == 1.0
    # a 6 Hz wiggle of 4° on every joint raises the detail energy, smoothing it away lowers it
    q = np.array(m.local_quats)
    wiggle = np.radians(4.0) * np.sin(2 * np.pi * 6.0 * m.times)[:, None, None] * np.array([0.5, 0.0, 0.0])
    noisy = quat_mul(q, quat_exp(np.broadcast_to(wiggle, q.shape[:2] + (3,))))
    assert quality.compare(m, m.replace(local_quats=noisy)).detail > 2.0
    from scipy.ndimage import gaussian_filter1d
    smooth = gaussian_filter1d(q, 6.0, axis=0, mode="nearest")
    smooth /= np.linalg.norm(smooth, axis=-1, keepdims=True)
    r = quality.compare(m, m.replace(local_quats=smooth))
    assert r.detail < 0.5
    assert any(f.startswith("detail ratio") for f in r.failures)


# -- knot order ------------------------------------------------------------------------------------------

def test_an_out_of_order_knot_is_named():
    m = data.load("walk")
    sm = staggered.extract(m)
    assert quality.compare(m, sm).knots_out_of_order == ()          # extraction keeps every knot in order
    j = sm.skeleton.index("LeftForeArm")
    r = np.array(sm.refinements)
    k = 3
    r[k, j] = sm.pose_times[k + 1] - sm.pose_times[k] + 0.01                  # past the next pose's knot
    bad = dataclasses.replace(sm, refinements=r)
    rep = quality.compare(m, bad)
    assert rep.knots_out_of_order == ("LeftForeArm",)
    assert rep.summary.endswith(" · poses out of order in left arm")
    assert any("knots out of order" in f for f in rep.failures)
    # its evaluation knows the StaggeredMotion it came from (Motion.staggered) and is judged the same way ...
    ev = staggered.evaluate(bad)
    assert ev.staggered is bad and quality.compare(m, ev).knots_out_of_order == ("LeftForeArm",)
    # ... while a Motion without one (any new Motion: here the same arrays) has nothing to check
    plain = ev.replace()
    assert plain.staggered is None and quality.compare(m, plain).knots_out_of_order is None


def test_root_translation_knots_are_checked_too():
    m = data.load("walk")
    sm = staggered.extract(m)
    rr = np.array(sm.root_refinements)
    rr[2] = sm.pose_times[3] - sm.pose_times[2] + 0.01
    rep = quality.compare(m, dataclasses.replace(sm, root_refinements=rr))
    assert rep.knots_out_of_order == ("<root translation>",)


# -- identity, carrying, invariance -----------------------------------------------------------------------

@pytest.mark.parametrize("clip", ["walk", "cmu_01_01"])
def test_compare_m_m_is_all_zero(clip):
    m = data.load(clip)
    r = quality.compare(m, m)
    assert r.contacts, "the clips plant their feet"
    for name in ("foot_travel", "foot_height", "foot_travel_source", "floor", "pelvis", "pelvis_drop",
                 "added_pop", "added_jump", "moved", "rotated"):
        assert getattr(r, name) == 0.0, name
    assert r.detail == 1.0 and r.ok and r.knots_out_of_order is None
    assert r.summary == "feet held · pelvis ±0.0 cm · no pops"
    # the raw travel is the source's own drift inside its contacts (detection allows 2 % of the height)
    assert 0 < r.foot_travel_raw <= 0.02 * 170 * 1.2


def test_an_unedited_extraction_is_near_zero():
    m = data.load("walk")
    r = quality.compare(m, staggered.extract(m))
    assert r.foot_travel < 1e-6 and r.moved < 1e-6 and r.added_pop < 1e-6 and r.knots_out_of_order == ()


def test_a_uniform_slow_down_keeps_the_feet_in_their_carried_contacts():
    """Every knot twice as late (pose times and refinements doubled, the source knot times recorded as
    ``source_knot_times`` reads them): the motion is the source at half speed, every joint's time warp is
    t -> 2 t. Carried through it, each contact starts at twice its source frame and each foot moves inside
    it as the source's did (to the difference between evaluating the staggered curves between frames and
    interpolating the source's positions linearly: sub-millimetre), while at the same time the motion is far
    from the source's."""
    m = data.load("walk")
    sm = staggered.extract(m)
    src = staggered.source_knot_times(sm)
    slow = dataclasses.replace(sm, pose_times=2 * sm.pose_times, refinements=2 * sm.refinements,
                               root_refinements=2 * sm.root_refinements,
                               metadata={"source_knots": src, "source_knots_pose_times": 2 * sm.pose_times})
    assert np.allclose(staggered.warp_times(slow, [0.3, 1.7], "LeftFoot"), [0.6, 3.4], atol=1e-12)
    r = quality.compare(m, slow)
    assert len(r.contacts) == len(staggered.detect_contacts(m))
    for c in r.contacts:
        assert c.frames[0] == 2 * c.source_frames[0]                            # carried, not left in place
    # the even frames are the source's exactly; the odd ones fall between the source's frames, where the
    # staggered curves (spline + displacement) differ from the slerp of the source's legs by up to 1°
    e = staggered.evaluate(slow)
    assert np.allclose(e.local_quats[::2], m.local_quats[: e.local_quats[::2].shape[0]], atol=1e-9)
    assert r.foot_travel < 1.5 and r.foot_height < 1.0
    assert 0.9 <= r.detail <= 1.1                  # read in each joint's own (warped) time: the detail is kept
    assert r.moved > 10.0                                                      # not the source at the same time
    # the same contacts left on their source frames do slide
    assert quality.compare(m, staggered.evaluate(slow)).foot_travel > 10.0


def test_figures_do_not_change_with_a_uniform_scale():
    m = data.load("walk")
    sm = staggered.extract(m)
    e = staggered.random_timing(staggered.succession(sm, root="Hips", s=0.03, l=2.0), tau=0.1)
    out = staggered.keep_contacts(e, m)
    base = staggered.evaluate(e)
    a = quality.compare(m, out, staggered=e, baseline=base).to_dict()
    b = quality.compare(quality.scaled(m, 3.7), quality.scaled(out, 3.7), staggered=e,
                        baseline=quality.scaled(base, 3.7)).to_dict()
    assert b["scale"] == pytest.approx(a["scale"] / 3.7, rel=1e-12)
    assert b["body_height"] == pytest.approx(3.7 * a["body_height"], rel=1e-12)
    for k, v in a.items():
        if isinstance(v, float) and k not in ("scale", "body_height"):
            assert b[k] == pytest.approx(v, rel=1e-7, abs=1e-9), k
    assert a["summary"] == b["summary"] and a["failures"] == b["failures"]
    assert a["foot_travel"] > 0 and a["pelvis_vs_baseline"] > 0      # the check compares something


def test_scaled_to_a_height():
    m = data.load("cmu_01_01")
    s = quality.scaled(m, height=170)
    assert quality.body_height(s) == pytest.approx(170.0, rel=1e-12)
    assert np.array_equal(s.local_quats, m.local_quats)


# -- the report ------------------------------------------------------------------------------------------

def test_report_is_frozen_and_json_safe():
    m = data.load("walk")
    sm = staggered.extract(m)
    e = staggered.succession(sm, root="Hips", s=0.02, l=1.0)
    r = quality.compare(m, staggered.keep_contacts(e, m), staggered=e, baseline=e, bounds="moderate")
    with pytest.raises(dataclasses.FrozenInstanceError):
        r.foot_travel = 0.0
    d = json.loads(json.dumps(r.to_dict()))
    assert d["summary"] == r.summary and d["ok"] == r.ok and d["failures"] == list(r.failures)
    assert len(d["contacts"]) == len(r.contacts) and len(d["pop_added"]) == m.num_joints
    assert d["bounds"]["travel"] == quality.PRESETS["moderate"].travel
    assert r.baseline_foot_travel is not None and r.pelvis_vs_baseline is not None


def test_presets_are_the_issue_goals():
    p = quality.PRESETS
    assert (p["mild"].travel, p["mild"].height, p["mild"].pelvis, p["mild"].pop) == (1.0, 1.5, 3.0, 5.0)
    assert (p["moderate"].travel, p["moderate"].height, p["moderate"].pelvis, p["moderate"].pop) == (2, 2, 5, 5)
    assert (p["strong"].travel, p["strong"].height, p["strong"].pelvis, p["strong"].pop) == (2, 3, 8, 10)
    assert p["strong"].no_worse_than_baseline and p["unedited"].moved == 2.0


def test_strong_preset_fails_when_the_layer_slides_more_than_no_layer():
    rp = np.tile([0.0, 90.0, 0.0], (F, 1))
    rp[:, 0] += np.linspace(0, 1.5, F)            # the "layer": 1.5 cm of travel
    r = quality.compare(standing(), standing(root=rp), contacts=FEET, baseline=standing(), bounds="strong")
    assert r.baseline_foot_travel == 0.0
    assert r.failures == ("foot travel 1.50 cm > 0.00 cm without the layer",)


# -- bad input --------------------------------------------------------------------------------------------

def test_errors_name_the_parameter():
    m = standing()
    other = Motion(Skeleton(NAMES[:-1] + ("Nose",), PARENTS, np.array(OFFSETS, float)), FT,
                   m.root_positions, m.local_quats)
    with pytest.raises(ValueError, match="source must be a Motion"):
        quality.compare("x", m)
    with pytest.raises(ValueError, match="edited must be a Motion or a StaggeredMotion"):
        quality.compare(m, None)
    with pytest.raises(ValueError, match=r"edited must have the source's skeleton \(joint 10: 'Head' vs 'Nose'\)"):
        quality.compare(m, other)
    with pytest.raises(ValueError, match="baseline must have the source's skeleton"):
        quality.compare(m, m, baseline=other)
    with pytest.raises(ValueError, match="staggered must be a StaggeredMotion"):
        quality.compare(m, m, staggered=m)
    with pytest.raises(ValueError, match=r"contacts\[1\]: unknown joint 'Toe'"):
        quality.compare(m, m, contacts=[("LeftFoot", 0, 5), ("Toe", 0, 5)])
    with pytest.raises(ValueError, match=r"contacts\[0\]: frames \[5, 99\)"):
        quality.compare(m, m, contacts=[("LeftFoot", 5, 99)])
    with pytest.raises(ValueError, match="bounds: unknown preset 'wild'"):
        quality.compare(m, m, bounds="wild")
    with pytest.raises(ValueError, match="bounds: unknown field"):
        quality.compare(m, m, bounds={"slide": 1})
    with pytest.raises(ValueError, match="bounds.pop must be >= 0"):
        quality.Bounds(pop=-1)
    with pytest.raises(ValueError, match="body_height must be > 0"):
        quality.compare(m, m, body_height=0)
    bad = np.array(sn.forward_kinematics(m)[0])
    bad[3, 2, 1] = np.nan
    with pytest.raises(ValueError, match="source_positions must be finite"):
        quality.compare(m, m, source_positions=bad)
    with pytest.raises(ValueError, match="give exactly one of factor= or height="):
        quality.scaled(m)


def test_sn_quality_is_reachable_from_the_package():
    assert sn.quality.compare is quality.compare
