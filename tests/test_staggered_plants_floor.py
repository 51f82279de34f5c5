"""The contact layer's floor and up axis (issue 20): the legs are kept above the source's floor where no contact
holds them, even on a clip where no contact was found (a run whose stance is shorter than the detector's 0.25 s:
Bandai's 24-frame run cycle, 9-10 cm below the floor after a moderate edit without it), and a Z-up clip is
held as its +Y-up twin is (the layer used to lower the root along +Y there: 56 cm off the plant).

Figures by ``sn.quality.compare`` in cm of a 170 cm body; edits as tests/test_staggered_plants.py.
"""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data, quality, staggered
from stagger_nb.core.body import pelvis_joint
from stagger_nb.core.kinematics import forward_kinematics
from stagger_nb.core.rotations import quat_mul, quat_rotate
from stagger_nb.staggered import plants

EDITS = {"moderate": (0.03, 2.0, 0.1), "strong": (0.05, 3.0, 0.1), "s+0.1": (0.1, 4.0, 0.15),
         "s-0.1": (-0.1, 4.0, 0.15)}
GOAL = {"moderate": (2.0, 5.0), "strong": (3.0, 10.0), "s+0.1": (3.0, 10.0), "s-0.1": (3.0, 10.0)}   # floor, pop


def _edit(sm, level):
    s, l, tau = EDITS[level]
    root = sm.skeleton.names[pelvis_joint(sm.skeleton)]
    return staggered.random_timing(staggered.succession(sm, root=root, s=s, l=l), tau=tau, seed=0)


@pytest.mark.parametrize("name", ["walk", "run", "jump"])
@pytest.mark.parametrize("level", ["moderate", "s-0.1"])
def test_no_contact_the_legs_stay_above_the_floor(name, level):
    """With no contact at all the layer still keeps every foot joint above the source's floor (the edit alone
    puts it 10-37 cm below), adding no pop beyond the edit's preset."""
    m = data.load(name)
    sm = staggered.extract(m)
    e = _edit(sm, level)
    off = staggered.evaluate(e)
    res = staggered.hold_plants(e, m, contacts=[])
    r0 = quality.compare(m, off, staggered=e, contacts=[])
    r = quality.compare(m, res.motion, staggered=e, contacts=[], baseline=off)
    floor, pop = GOAL[level]
    assert r0.floor > 5.0, "the edit alone goes below the floor: the test has something to catch"
    assert r.floor <= floor and r.added_pop <= pop and res.plants == 0
    assert r.pelvis_vs_baseline == 0.0                         # the legs are lifted, the pelvis is not moved


@pytest.mark.parametrize("name", ["walk", "jump"])
def test_no_contact_unedited_comes_back_bit_for_bit(name):
    m = data.load(name)
    sm = staggered.extract(m)
    ev = staggered.evaluate(sm)
    out = staggered.keep_contacts(sm, m, contacts=[])
    assert np.array_equal(out.local_quats, ev.local_quats) and np.array_equal(out.root_positions, ev.root_positions)


def test_rig_legs():
    sk = data.load("walk").skeleton
    legs = plants.rig_legs(sk)
    assert sorted(sk.names[lim.eff] for lim in legs) == ["LeftFoot", "RightFoot"] and all(lim.leg for lim in legs)


def test_bandai_run_cycle_stays_above_the_floor(shared_motion):
    """24 frames at 30 Hz, a stance of ~0.1 s: no contact is detected, and the moderate / strong edits alone
    go 7-9 cm below the floor; with the layer they meet the goals (floor 2 / 3 cm)."""
    m = quality.scaled(shared_motion("bandai_run_cycle.bvh"), height=quality.BODY_CM)
    sm = staggered.extract(m)
    assert not staggered.detect_contacts(m)
    for level in ("moderate", "strong"):
        e = _edit(sm, level)
        off = staggered.evaluate(e)
        r = quality.compare(m, staggered.keep_contacts(e, m), staggered=e, baseline=off, bounds=level)
        assert quality.compare(m, off, staggered=e).floor > 5.0
        assert r.ok, (level, r.failures)


def _z_up(m):
    """``m`` with the world turned -90 degrees about X (+Y up becomes +Z up)."""
    r = np.array([-np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4)])
    q = np.array(m.local_quats)
    q[:, 0] = quat_mul(np.broadcast_to(r, q[:, 0].shape), q[:, 0])
    rp = quat_rotate(np.broadcast_to(r, m.root_positions.shape[:-1] + (4,)), m.root_positions)
    return m.replace(local_quats=q, root_positions=rp), r


@pytest.mark.parametrize("level", ["moderate", "s+0.1"])
def test_a_z_up_clip_is_held_as_its_y_up_twin(level):
    """The procedural walk turned Z-up, extracted and edited alike: the held motion is the Y-up one's turned
    (world positions within 1e-6 of the body), and it meets the same goals."""
    m = data.load("walk")
    mz, r = _z_up(m)
    sm, smz = staggered.extract(m), staggered.extract(mz)
    e, ez = _edit(sm, level), _edit(smz, level)
    y, z = staggered.keep_contacts(e, m), staggered.keep_contacts(ez, mz)
    py, pz = forward_kinematics(y)[0], forward_kinematics(z)[0]
    h = quality.body_height(m)
    assert np.abs(quat_rotate(np.broadcast_to(r, py.shape[:-1] + (4,)), py) - pz).max() < 1e-6 * h
    rz = quality.compare(mz, z, staggered=ez, baseline=staggered.evaluate(ez), bounds="strong")
    assert rz.foot_height <= 3.0 and rz.floor <= 3.0


def test_a_z_up_unedited_clip_comes_back_unchanged():
    """As on a +Y-up clip (test_staggered_plants.py): exact up to round-off (the plants are re-solved)."""
    mz, _ = _z_up(data.load("walk"))
    smz = staggered.extract(mz)
    r = quality.compare(mz, staggered.keep_contacts(smz, mz), staggered=smz, bounds="unedited")
    assert r.moved < 0.01 and r.rotated < 0.01


# -- an effector with nothing below it keeps the edit's rotation -------------------------------------------

@pytest.mark.parametrize("level", ["strong", "s+0.1", "s-0.1"])
def test_leaf_effectors_keep_the_edit_and_its_detail(level):
    """mocapbank_get_down (19 joints: the ankles and wrists are leaves): the held ankles and wrists keep the
    edit's local rotation on every frame (their plants are positions), and the layer no longer adds detail
    (it was 2.7x / 4.7x / 5.8x the source's at strong / s+0.1 / s-0.1: the ankle turned up to 122 degrees)."""
    m = quality.scaled(data.load("mocapbank_get_down"), height=quality.BODY_CM)
    sm = staggered.extract(m)
    e = _edit(sm, level)
    off = staggered.evaluate(e)
    on = staggered.keep_contacts(e, m)
    sk = m.skeleton
    leaves = {plants.find_limb(sk, c[0]).eff for c in sm.contacts} - {None}
    assert leaves and all(not plants.find_limb(sk, sk.names[j]).foot for j in leaves)
    for j in leaves:
        assert np.array_equal(on.local_quats[:, j], off.local_quats[:, j]), sk.names[j]
    r = quality.compare(m, on, staggered=e, baseline=off, bounds="strong")
    assert r.ok, r.failures


# -- the root's budget: 2.8 % of a leg, up to 5 % where the feet would otherwise stop visibly short ----------

def _scaled(m):
    return quality.scaled(m, height=quality.BODY_CM)


@pytest.mark.parametrize("level", ["s+0.1", "s-0.1"])
def test_cmu_01_01_slider_extremes_hold_the_feet(level):
    """The hops at the slider extremes: with the root lowered at most 2.8 % of a leg the landing foot stopped
    3.5 cm short of its plant (travel and height 3.5 cm > 2 / 3); now every strong goal is met."""
    m = _scaled(data.load("cmu_01_01"))
    sm = staggered.extract(m)
    e = _edit(sm, level)
    off = staggered.evaluate(e)
    res = staggered.hold_plants(e, m)
    r = quality.compare(m, res.motion, staggered=e, baseline=off, bounds="strong")
    assert r.ok, r.failures
    assert 2.5 < r.pelvis_vs_baseline <= 5.0      # the larger budget was used, within the moderate bound


def test_a_mild_edit_keeps_the_small_budget():
    """The procedural jump at 120 Hz, mild: the 2.8 % budget leaves the feet within 0.02 cm of their plants, so
    the root is not lowered further (a flat 5 % budget lowered it 3.15 cm, past the mild bound of 3)."""
    m = _scaled(data.load("jump"))
    m = m.resample(1 / 120)
    sm = staggered.extract(m)
    s, l, tau = 0.02, 1.0, 0.05
    root = sm.skeleton.names[pelvis_joint(sm.skeleton)]
    e = staggered.random_timing(staggered.succession(sm, root=root, s=s, l=l), tau=tau, seed=0)
    off = staggered.evaluate(e)
    r = quality.compare(m, staggered.keep_contacts(e, m), staggered=e, baseline=off, bounds="mild")
    assert r.ok, r.failures


def test_a_fade_reaches_no_further_than_a_plant():
    """CMU 01_01 at 60 Hz, mild: a fade into a plant the leg could not reach straightened the knee to full
    extension (a plant may use only ``reach`` of it), the plant's first frame bent it back at once and the pop
    cap let the toe go 2 cm below the floor there (> 1.5); the fade now reaches as far as a plant may."""
    m = _scaled(data.load("cmu_01_01")).resample(1 / 60)
    sm = staggered.extract(m)
    root = sm.skeleton.names[pelvis_joint(sm.skeleton)]
    e = staggered.random_timing(staggered.succession(sm, root=root, s=0.02, l=1.0), tau=0.05, seed=0)
    off = staggered.evaluate(e)
    r = quality.compare(m, staggered.keep_contacts(e, m), staggered=e, baseline=off, bounds="mild")
    assert r.ok, r.failures
