"""Session.quality(): the quality report of the current edit against the source (sn.quality.compare with the
replay's staggered state and, with keep_contacts, the same edit without it), cached per op list."""
from __future__ import annotations

import pytest

from stagger_nb import data, quality, staggered
from stagger_nb.session import Session

TIMING = [{"op": "succession", "root": "Hips", "s": 0.03, "l": 2.0}, {"op": "random_timing", "tau": 0.1, "seed": 3}]


@pytest.fixture(scope="module")
def walk():
    return data.load("walk")


def test_no_edit_is_the_source_against_itself(walk):
    s = Session(walk)
    r = s.quality()
    assert r.to_dict() == quality.compare(walk, walk).to_dict()
    assert r.summary == "feet held · pelvis ±0.0 cm · no pops" and r.ok
    assert s.quality_summary() == r.summary


def test_the_report_is_compare_with_the_staggered_state_and_the_baseline(walk):
    s = Session(walk, ops=TIMING + [{"op": "keep_contacts"}])
    sm = staggered.random_timing(staggered.succession(staggered.extract(walk), root="Hips", s=0.03, l=2.0),
                                 tau=0.1, seed=3)
    want = quality.compare(walk, staggered.keep_contacts(sm, walk), staggered=sm, baseline=staggered.evaluate(sm))
    got = s.quality()
    assert got.to_dict() == want.to_dict()
    assert got.knots_out_of_order == () and got.pelvis_vs_baseline is not None and got.baseline_foot_travel is not None
    # without the layer: no baseline, the timing edit's own figures
    s.remove(2)
    alone = s.quality()
    assert alone.to_dict() == quality.compare(walk, staggered.evaluate(sm), staggered=sm).to_dict()
    assert alone.pelvis_vs_baseline is None
    assert alone.foot_travel != got.foot_travel          # the two edits differ (the layer moves the feet)


def test_reports_are_cached_per_op_list_and_bounds_only_judge(walk):
    s = Session(walk, ops=TIMING)
    first = s.quality()
    assert s.quality() is first                              # computed once
    s.replace(0, {"op": "succession", "root": "Hips", "s": 0.05, "l": 2.0})
    other = s.quality()
    assert other is not first and other.to_dict() != first.to_dict()
    s.undo()
    assert s.quality() is first                              # back to the same op list: found again
    strong = s.quality("strong")
    assert strong.bounds == quality.PRESETS["strong"] and strong.foot_travel == first.foot_travel
    assert s.quality({"preset": "mild", "pop": 0.0}).bounds.pop == 0.0


def test_a_timeline_change_after_the_staggered_ops_leaves_the_contacts_on_their_frames(walk):
    """A linear warp after the timing edit changes the motion's timeline: the staggered warps no longer map the
    source onto it, so the report has no StaggeredMotion (no knot check, contacts on their frames)."""
    s = Session(walk, ops=TIMING + [{"op": "linear_warp", "duration": 2 * walk.duration}])
    r = s.quality()
    assert r.knots_out_of_order is None
    assert r.to_dict() == quality.compare(walk, s.edited()).to_dict()
    # a frame edit keeps the timeline: the staggered state still carries the contacts
    s = Session(walk, ops=TIMING + [{"op": "edit_frame", "frame": 10, "deltas": {"Spine": [5, 0, 0]}}])
    sm = s.staggered()
    assert s.quality().to_dict() == quality.compare(walk, s.edited(), staggered=sm).to_dict()
    # staggered ops extracted from a warped motion: their warps are not the source's
    s = Session(walk, ops=[{"op": "linear_warp", "duration": 1.5 * walk.duration}] + TIMING)
    assert s.quality().knots_out_of_order is None


def test_a_failing_op_is_named(walk):
    s = Session(walk, ops=[{"op": "edit_frame", "frame": 9999, "deltas": {"Spine": [5, 0, 0]}}])
    with pytest.raises(ValueError, match=r"ops\[0\] \(edit_frame\): frame: 9999 is outside"):
        s.quality()


def test_the_source_figures_are_prepared_once_per_session(walk, monkeypatch):
    calls = []
    real = quality.prepare

    def counting(source, **kw):
        calls.append(source)
        return real(source, **kw)
    monkeypatch.setattr(quality, "prepare", counting)
    s = Session(walk, ops=TIMING)
    for s_value in (0.01, 0.02, 0.04):
        s.replace(0, {"op": "succession", "root": "Hips", "s": s_value, "l": 1.0})
        r = s.quality()
        assert r.to_dict() == quality.compare(walk, s.edited(), staggered=s.staggered(), prepared=real(walk)).to_dict()
    assert calls == [walk]
