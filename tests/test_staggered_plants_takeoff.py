"""A leg's take-off into the air replayed on its knee's own clock (stagger_nb.staggered.plants_rate._knee_lag):
where a timing edit slows the knee against the hip, the fade out of a plant no longer bends the knee through the
source's whole take-off within a few of the knee's own frames (jitter on its own timing, which
``sn.quality.compare`` reads each joint on).

Figures by ``sn.quality.compare`` on the clip scaled to a 170 cm body; the edit is bench_edit_quality.py's
``s-0.1`` (succession from the pelvis s = -0.1, l = 4, random timing tau = 0.15, seed 0).
"""
from __future__ import annotations

import pytest

from stagger_nb import quality, staggered
from stagger_nb.core.body import pelvis_joint


def _s_minus(m):
    sm = staggered.extract(m)
    root = m.skeleton.names[pelvis_joint(m.skeleton)]
    e = staggered.random_timing(staggered.succession(sm, root=root, s=-0.1, l=4.0), tau=0.15, seed=0)
    return sm, e


def test_xia_walk_slider_end_knee_keeps_its_detail(shared_motion):
    """xia_neutral_walk at s = -0.1: before, the layer's fades made the right knee's detail 8.8 times the
    source's (0.99 without the layer) and the clip's 2.14, outside the strong bounds [0.5, 2]."""
    m = quality.scaled(shared_motion("xia_neutral_walk.bvh"), height=quality.BODY_CM)
    _, e = _s_minus(m)
    off = quality.compare(m, staggered.evaluate(e), staggered=e, bounds="strong")
    r = quality.compare(m, staggered.keep_contacts(e, m), staggered=e, bounds="strong")
    knee = r.joints.index("RightLeg")
    assert off.detail_by_joint[knee] == pytest.approx(1.0, abs=0.05)       # the timing edit alone keeps it
    assert r.detail_by_joint[knee] < 6.0                                     # was 8.8
    assert r.detail <= 2.0                                                   # was 2.14
    assert r.ok, r.failures
    assert r.foot_travel <= 0.1 and r.added_pop <= 3.0                       # the plants still held, no pop


def test_xia_walk_unedited_unchanged(shared_motion):
    """No timing edit: the knee's clock is the hip's, the take-off is replayed frame for frame as before."""
    m = quality.scaled(shared_motion("xia_neutral_walk.bvh"), height=quality.BODY_CM)
    sm, _ = _s_minus(m)
    r = quality.compare(m, staggered.keep_contacts(sm, m), staggered=sm, bounds="unedited")
    assert r.ok, r.failures
    assert r.moved <= 0.05
