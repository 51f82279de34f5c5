"""The contact layer keeps each held knee on one IK branch and each fade on one way round
(``staggered.plants_ik``, ``plants_hold``, issue 20): an edit that bends a knee backwards past the source's own
hyperextension (an exaggerated straight leg) or folds it past 180° (an exaggerated deep bend) is held on the
forward branch, and a plant whose first frame is the edited foot itself does not start on the backward branch and
switch a frame later. Before, either made the held knee flip between neighbouring frames (one-frame turns of
10-140°), and the pop cap, ramping the flip out, slid the foot (14 cm on the procedural run at 50 % cull with
every pose exaggerated). A fade between an edited foot and its plant ~180° apart no longer flips the way round.

Measured with ``sn.quality.compare`` (cm of a 170 cm body), the edit = cull, exaggerate every pose, then the
issue's moderate timing edit (succession from the pelvis s = 0.03, l = 2; random_timing τ = 0.1, seed 0).
"""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data, quality, read_bvh, staggered
from stagger_nb.core.body import pelvis_joint
from stagger_nb.core.rotations import quat_angle, quat_conj, quat_mul
from tests.conftest import shared_clip_path


def _edited(m, percent, w_r):
    sm = staggered.extract(m)
    if percent < 100:
        sm = staggered.cull(sm, percent=percent)
    if w_r:
        sm = staggered.exaggerate(sm, list(range(sm.num_poses)), w_r=w_r)
    root = m.skeleton.names[pelvis_joint(m.skeleton)]
    return staggered.random_timing(staggered.succession(sm, root=root, s=0.03, l=2.0), tau=0.1, seed=0)


def _largest_step(motion, joints):
    """Largest frame-to-frame turn (degrees) of the local rotations of ``joints`` (names)."""
    idx = [motion.skeleton.index(j) for j in joints]
    q = motion.local_quats[:, idx]
    return float(np.degrees(quat_angle(quat_mul(quat_conj(q[:-1]), q[1:]))).max())


def _legs(skeleton):
    return [n for n in skeleton.names if any(k in n.lower() for k in ("upleg", "leg", "knee", "hip", "thigh", "calf"))
            and "spine" not in n.lower()]


@pytest.mark.parametrize("name, percent", [("run", 50), ("walk", 90), ("jump", 90)])
def test_exaggerated_poses_are_held_without_sliding_or_flipping_a_knee(name, percent):
    m = quality.scaled(data.load(name), height=170.0)
    sm = _edited(m, percent, 0.5)
    baseline = staggered.evaluate(sm)
    held = staggered.keep_contacts(sm, m)
    r = quality.compare(m, held, staggered=sm, baseline=baseline, bounds="moderate")
    assert r.foot_travel <= 2.0, r.summary
    assert r.foot_height <= 2.0, r.summary
    legs = _legs(m.skeleton)
    # the layer adds no knee flip: its legs turn no faster from frame to frame than the edit's own legs + 5°
    assert _largest_step(held, legs) <= _largest_step(baseline, legs) + 5.0, r.summary


@pytest.mark.parametrize("clip", ["walk", "xia_neutral_walk.bvh"])
def test_the_unedited_layer_keeps_the_sources_own_hyperextended_knees(clip):
    # xia_neutral_walk's knees bend up to 3.5° / 7.1° backwards in the source: kept on the backward branch
    m = data.load(clip) if not clip.endswith(".bvh") else read_bvh(shared_clip_path(clip))
    m = quality.scaled(m, height=170.0)
    sm = staggered.extract(m)
    held = staggered.keep_contacts(sm, m)
    np.testing.assert_allclose(held.local_quats, staggered.evaluate(sm).local_quats, atol=1e-9)


@pytest.mark.parametrize("clip, percent, w_r", [("xia_neutral_walk.bvh", 50, 0.0),
                                                ("cmu_131_01_walk_startstop.bvh", 50, 0.5),
                                                ("xia_sexy_walk.bvh", 100, 0.5)])
def test_real_clips_culled_or_exaggerated_keep_their_feet(clip, percent, w_r):
    m = quality.scaled(read_bvh(shared_clip_path(clip)), height=170.0)
    sm = _edited(m, percent, w_r)
    baseline = staggered.evaluate(sm)
    held = staggered.keep_contacts(sm, m)
    r = quality.compare(m, held, staggered=sm, baseline=baseline, bounds="moderate")
    assert r.foot_travel <= 2.0 and r.foot_height <= 2.0, r.summary
    legs = _legs(m.skeleton)
    assert _largest_step(held, legs) <= _largest_step(baseline, legs) + 5.0, r.summary


def test_a_fade_whose_turn_crosses_half_a_revolution_turns_the_foot_no_faster_than_the_edit():
    # bandai_kick, every pose exaggerated by 0.5: between two plants the fade turns the right foot from the
    # edit's orientation to the plant's, ~175° apart; the short way round flipped sides on one frame (34.7°
    # there against the edit's own fastest 30.4°, 100-115° before the pop cap)
    m = quality.scaled(read_bvh(shared_clip_path("bandai_kick.bvh")), height=170.0)
    sm = _edited(m, 100, 0.5)
    baseline = staggered.evaluate(sm)
    held = staggered.keep_contacts(sm, m)
    assert _largest_step(held, ["Foot_R"]) <= _largest_step(baseline, ["Foot_R"])
