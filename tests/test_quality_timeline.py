"""``sn.quality.compare(source, edited)`` with the edited Motion alone (issue 20, the call DESIGN.md names): a Motion
from ``staggered.evaluate``, the contact layer or a Session whose last op is a staggered one knows the staggered
motion it evaluates (``Motion.staggered``), so its contacts are carried through the timing edit and its knots
checked without passing ``staggered=``; the pelvis is judged on its own clock, so a timing edit alone changes no
pelvis height. Before, the Motion alone was measured on the source's frames: 3.7-19 cm of "sliding" feet on
real walks whose plants the layer held, and "pelvis drops 5.5 cm" on a timing edit that lowers nothing."""
from __future__ import annotations

import numpy as np

from stagger_nb import data, quality, staggered
from stagger_nb.core.body import pelvis_joint
from stagger_nb.session import Session


def _timing_ops(m, s=0.03, l=2.0, tau=0.1):
    root = m.skeleton.names[pelvis_joint(m.skeleton)]
    return [{"op": "succession", "root": root, "s": s, "l": l}, {"op": "random_timing", "tau": tau, "seed": 0}]


def test_a_sessions_edited_motion_is_judged_on_its_own_timing():
    m = quality.scaled(data.load("walk"), height=170.0)
    s = Session(m, ops=_timing_ops(m) + [{"op": "keep_contacts"}])
    edited = s.edited()
    assert edited.staggered is not None
    alone = quality.compare(m, edited, bounds="moderate")
    given = quality.compare(m, edited, staggered=s.staggered(), bounds="moderate")
    assert alone.to_dict() == given.to_dict()
    assert alone.foot_travel <= 2.0, alone.summary
    # measured on the source's frames instead (a Motion that does not know its timing), the held feet "slide"
    plain = quality.compare(m, edited.replace(), bounds="moderate")
    assert plain.foot_travel > alone.foot_travel + 1.0, (plain.summary, alone.summary)


def test_a_timing_edit_alone_changes_no_pelvis_height():
    for name in ("walk", "jump"):
        m = quality.scaled(data.load(name), height=170.0)
        sm = staggered.extract(m)
        for op in _timing_ops(m):
            sm = (staggered.succession(sm, root=op["root"], s=op["s"], l=op["l"]) if op["op"] == "succession"
                  else staggered.random_timing(sm, tau=op["tau"], seed=0))
        r = quality.compare(m, staggered.evaluate(sm), bounds="moderate")
        assert r.pelvis <= 0.5, (name, r.summary)
        # the same heights at the same times (no clock): the retiming itself reads as a pelvis change
        same_time = quality.compare(m, staggered.evaluate(sm).replace(), bounds="moderate")
        assert same_time.pelvis > r.pelvis, (name, same_time.pelvis, r.pelvis)


def test_a_warp_before_the_staggered_ops_is_not_the_sources_timeline():
    m = data.load("walk")
    s = Session(m, ops=[{"op": "linear_warp", "duration": 1.5 * m.duration}] + _timing_ops(m))
    edited = s.edited()
    assert edited.staggered is not None
    assert quality.compare(m, edited).knots_out_of_order is None     # its staggered motion is not used
    assert np.isfinite(quality.compare(m, edited).foot_travel)
