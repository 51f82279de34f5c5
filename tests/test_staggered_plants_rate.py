"""The contact layer's turn-rate allowance inside plants (stagger_nb.staggered.plants_rate): a held knee bends,
and a held toe's heel lifts, no faster from one plant frame to the next than the pop cap allows, so the cap no
longer frees a plant's first frames (which let the foot off its plant by 2-6 cm).

Figures by ``sn.quality.compare`` in cm of a 170 cm body; edits as benchmarks/bench_edit_quality.py.
"""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data, quality, staggered
from stagger_nb.core.body import pelvis_joint
from stagger_nb.staggered import detect_contacts
from stagger_nb.staggered.plants_rate import _segments, knee_rate_reach, pivot_rate, rate_envelope

EDITS = {"mild": (0.02, 1.0, 0.05, "pelvis"), "moderate": (0.03, 2.0, 0.1, "pelvis"),
         "strong": (0.05, 3.0, 0.1, "pelvis"), "s+0.1": (0.1, 4.0, 0.15, "pelvis"),
         "shoulder": (0.1, 4.0, 0.15, "shoulder")}


def _edit(sm, level):
    s, l, tau, root = EDITS[level]
    names = sm.skeleton.names
    if root == "pelvis":
        root = names[pelvis_joint(sm.skeleton)]
    else:
        root = next(n for n in names if "leftshoulder" in n.lower())
    return staggered.random_timing(staggered.succession(sm, root=root, s=s, l=l), tau=tau, seed=0)


def _judge(m, level, bounds):
    sm = staggered.extract(m)
    e = _edit(sm, level)
    off = staggered.evaluate(e)
    return quality.compare(m, staggered.keep_contacts(e, m), staggered=e, baseline=off, bounds=bounds)


# -- the envelope, against brute force --------------------------------------------------------------------------

def _brute(x, rate, seg):
    c = np.r_[0.0, np.cumsum(np.broadcast_to(rate, x.shape)[1:])]
    return np.array([max(x[k] - abs(c[i] - c[k]) for k in range(x.size) if seg[k] == seg[i]) for i in range(x.size)])


@pytest.mark.parametrize("seed", range(20))
def test_rate_envelope_is_the_upper_envelope_of_cones(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 40))
    frames = np.sort(rng.choice(80, n, replace=False))
    groups = np.sort(rng.integers(0, 3, n))
    seg = _segments(frames, groups)
    x = rng.random(n) * 3
    for rate in (float(rng.random()), rng.random(n) * 0.5):
        out = rate_envelope(x, rate, seg)
        assert np.allclose(out, _brute(x, rate, seg))
        assert np.all(out >= x)


def test_segments_split_at_gaps_and_plants():
    assert _segments(np.array([3, 4, 5, 9, 10, 11]), np.array([0, 0, 0, 0, 0, 1])).tolist() == [0, 0, 0, 1, 1, 2]


def _bends(hip, target, l1, l2, reach):
    d = np.minimum(np.linalg.norm(target - hip, axis=-1), reach)
    return np.arccos(np.clip((d * d - l1 * l1 - l2 * l2) / (2 * l1 * l2), -1, 1))


def test_knee_rate_reach_limits_the_bend_rate_and_only_lowers_the_reach():
    """A hip coming over the foot of a nearly straight leg: the bend the plant asks for jumps in a frame
    at first (7 degrees here); with the returned reach it grows by at most the rate, and the reach is only ever lowered
    (where the bend is already slow it is the reach given)."""
    n = 30
    l1 = l2 = np.full(n, 45.0)
    t = np.linspace(0.0, 1.0, n)
    hip = np.stack([30.0 * (t - 0.5), 89.9 - 4.0 * t, np.zeros(n)], axis=1)
    target = np.zeros((n, 3))
    reach = np.full(n, 0.9999 * 90.0)
    fr, grp = np.arange(n), np.zeros(n, int)
    rate = np.radians(2.0)
    before = _bends(hip, target, l1, l2, reach)
    assert np.degrees(np.abs(np.diff(before)).max()) > 6.0
    R = knee_rate_reach(hip, target, l1, l2, reach, fr, grp, rate)
    after = _bends(hip, target, l1, l2, R)
    assert np.all(R <= reach)
    assert np.abs(np.diff(after)).max() <= rate + 1e-9
    slow = np.flatnonzero(np.abs(after - before) < 1e-9)
    assert np.array_equal(R[slow], reach[slow])
    # a leg whose bend is slow everywhere keeps its reach
    assert knee_rate_reach(hip, target, l1, l2, reach, fr, grp, np.radians(60.0)) is reach


def test_pivot_rate_lifts_at_least_as_needed_and_no_faster_than_the_rate():
    n = 12
    off = np.tile([0.0, 5.0, -15.0], (n, 1))                  # toe -> ankle
    to_hip = np.tile([0.0, 90.0, -20.0], (n, 1))              # toe -> hip
    angle = np.radians(np.r_[38.6, 31.4, 23.5, 16.5, 9.9, 3.6, np.zeros(n - 6)])   # xia_angry_run, s = +0.1
    rate = np.radians(2.5)
    v = pivot_rate(off, to_hip, angle, np.radians(45.0), np.arange(n), np.zeros(n, int), rate)
    got = np.linalg.norm(v, axis=-1)
    assert np.all(got >= angle - 1e-12)
    assert np.abs(np.diff(got)).max() <= rate + 1e-9
    axis = np.cross(off[0], to_hip[0])
    assert np.allclose(np.cross(v, axis), 0.0, atol=1e-12)    # about the toe, towards the hip
    # no lift needed: none made
    assert np.all(pivot_rate(off, to_hip, np.zeros(n), np.radians(45.0), np.arange(n), np.zeros(n, int), rate) == 0)


# -- the layer on clips ---------------------------------------------------------------------------------------

def _from_mid_swing(m):
    """``m`` from the middle of its first foot contact's next swing (benchmarks/derived_clips.py, ``swing``)."""
    cs = [c for c in detect_contacts(m) if any(k in c[0].lower() for k in ("foot", "toe", "ankle", "heel"))]
    j, _, e = cs[0]
    nxt = [c for c in cs if c[0] == j and c[1] > e]
    return m.slice((e + nxt[0][1]) // 2, None)


def test_a_plant_that_finds_the_leg_straight_is_held_from_its_first_frame():
    """CMU 01_01 from mid-swing, mild: a plant's first frame found the landing leg nearly straight and the hip
    coming over the foot, the knee had to bend 9-17 degrees a frame, and the pop cap freed the plant's first
    frames: the toe slid 3.1 cm (> 1). The knee's bend is now rate-limited inside the plant by lowering the
    reach there (the pelvis comes down a few millimetres)."""
    m = _from_mid_swing(quality.scaled(data.load("cmu_01_01"), height=quality.BODY_CM))
    r = _judge(m, "mild", "mild")
    assert r.ok, r.failures
    assert r.foot_travel < 0.5
    assert r.pelvis_vs_baseline < 1.0


@pytest.mark.parametrize("level", ["moderate", "strong"])
def test_a_60_hz_walk_s_plants_are_held_from_their_first_frames(level):
    """CMU 01_01 at 60 Hz: the pop cap freed a plant's first frames where its knee had to bend fast, and the foot
    slid 3.2 cm (> 2); with the knee's bend allowed the whole pop-cap margin inside the plant (what is left over
    for the edit's own turn of the knee then too little) still 2.1 cm; with half of it (KNEE_MARGIN) the plant is
    held and the pelvis comes down by under 2 cm."""
    m = quality.scaled(data.load("cmu_01_01"), height=quality.BODY_CM).resample(1 / 60)
    r = _judge(m, level, level)
    assert r.ok, r.failures
    assert r.foot_travel < 1.0
    assert r.pelvis_vs_baseline < 2.0


@pytest.mark.parametrize("level", ["s+0.1", "shoulder"])
def test_a_toe_plant_s_heel_lift_relaxes_slowly(shared_motion, level):
    """xia_angry_run at the slider extremes: a toe-only plant whose leg could not reach lifted the heel 39
    degrees at its first frame and let it down 7 degrees a frame; the pop cap ramped that by letting the toe
    off its plant (2.35 / 3.17 cm > 2). The lift now relaxes no faster than the pop cap's margin."""
    m = quality.scaled(shared_motion("xia_angry_run.bvh"), height=quality.BODY_CM)
    r = _judge(m, level, "strong")
    assert r.ok, r.failures
    assert r.foot_travel < 0.5


@pytest.mark.parametrize("name", ["walk", "run", "jump", "freebvh_step"])
def test_unedited_clips_come_back_unchanged(name):
    """The allowance never binds on the source's own motion (a knee's bend changes no faster than its local
    rotation, which the allowance exceeds by KNEE_MARGIN): an unedited clip comes back as it was (to
    the IK's rounding), its root not lowered."""
    m = data.load(name)
    res = staggered.hold_plants(m, m)
    assert res.plants > 0
    assert np.abs(res.motion.local_quats - m.local_quats).max() < 1e-9
    assert np.array_equal(res.motion.root_positions, m.root_positions)
    assert not np.any(res.drop)
