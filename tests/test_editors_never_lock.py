"""An editor never locks and leaks nothing (issues "Nothing lost, nothing leaked" and "An editor workspace"):
a value that cannot apply is refused at the model with one plain sentence (no op index, no exception name,
no numpy text), the session stays as it was and the editor follows the next valid change; a change whose
replay would fail is not recorded; closed editors leave no warm-up thread; values are rounded to the
control's step; the limits are the ops' own."""
from __future__ import annotations

import gc
import html
import re
import weakref

import numpy as np
import pytest
import traitlets
from editor_helpers import from_browser, rss_mb, wait_until, warm_threads

import stagger_nb as sn
from stagger_nb.session import Session
from stagger_nb.session import ops as O
from stagger_nb.session import runners as R
from stagger_nb.session.models import plain_message, snap
from stagger_nb.session.replay import ReplayError

RAW = re.compile(r"ops\[\d+\]|[A-Z][a-z]+Error|Exception|zero-size array|got shape|math domain")


@pytest.fixture
def walk():
    return sn.data.load("walk")


def _stagger(m, **kw):
    from stagger_nb.widgets import StaggerEditor
    return StaggerEditor(m, precompute=False, **kw)


def _plain(text: str) -> bool:
    return bool(text) and not RAW.search(text)


def _check_refused(ed, name, value, *words):
    """``model.name = value`` raises a TraitError in plain words, leaves the ops and the model as they were and
    puts the sentence on the message line; the control route (``set_control``) gives the same sentence."""
    s, before, ops0 = ed.session, getattr(ed.model, name), ed.session.ops
    with pytest.raises(traitlets.TraitError) as refused:
        setattr(ed.model, name, value)
    why = str(refused.value)
    assert _plain(why), why
    for w in words:
        assert w in why, (w, why)
    assert s.ops == ops0 and getattr(ed.model, name) == before
    assert ed.model.set_control(name, value) == why and ed.model.notes[name] == why
    # said once: a refused pose time under its field (where it was typed), anything else in the message line
    beside = ed.pose_time_note.value if name == "pose_time" else ""
    assert (ed.message.value + beside).count(html.escape(why)) == 1, (ed.message.value, beside)
    assert html.escape(why) in (beside or ed.message.value)
    return why


@pytest.mark.parametrize("value", [999.0, 1e308, -5.0])
def test_a_pose_time_past_its_neighbours_is_refused_and_the_editor_follows(walk, tmp_path, value):
    from stagger_nb.widgets import export_html
    ed = _stagger(walk)
    try:
        ed.model.pose = 2
        lo, hi = ed.model.pose_times[1], ed.model.pose_times[3]
        why = _check_refused(ed, "pose_time", value, "pose time must lie between", f"{lo:.3f} s", f"{hi:.3f} s")
        ed.model.percent = 50.0                        # the next move applies: ops, motion and plots follow
        assert [o["op"] for o in ed.session.ops][0] == "cull" and not ed.error
        assert why not in ed.message.value and not ed.model.notes
        ed.session.edited()
        export_html(ed, tmp_path / "page.html")        # the page still exports
        assert (tmp_path / "page.html").stat().st_size > 1000
    finally:
        ed.close()


def test_a_typed_pose_time_goes_back_in_the_control(walk):
    """Typed into the control (a browser message), 999 is refused: the control shows the pose's time again,
    the message line says where it may lie, nothing is recorded."""
    ed = _stagger(walk)
    try:
        ed.model.pose = 2
        shown = ed.controls["pose_time"].value
        from_browser(ed.controls["pose_time"], value=999.0)
        assert ed.controls["pose_time"].value == shown == ed.model.pose_time
        assert "pose time must lie between" in ed.pose_time_note.value and ed.session.ops == []
        assert "pose time must" not in ed.message.value            # said once, under the field
        t = (ed.model.pose_times[1] + 2 * ed.model.pose_times[2]) / 3   # inside: applied as typed
        from_browser(ed.controls["pose_time"], value=t)
        assert ed.session.ops[0] == {"op": "retime", "pose": 2, "time": pytest.approx(t, abs=1e-3)}
        assert "pose time must" not in ed.message.value + ed.pose_time_note.value
    finally:
        ed.close()


def test_a_count_beyond_the_extracted_poses_is_refused(walk):
    ed = _stagger(walk)
    try:
        K = len(ed.model.candidate_times)
        ed.model.cull_by = "count"
        _check_refused(ed, "count", 100000, "count", str(K))
        ed.model.count = K - 2
        assert ed.session.ops[0] == {"op": "cull", "count": K - 2}
    finally:
        ed.close()


def test_choosing_picked_or_count_keeps_the_poses_a_retime_refers_to(walk):
    """With a percent cull and a retime of pose 2, choosing "picked" (or "by count") starts from the poses kept
    now: the retime still means the same pose and the motion does not change."""
    ed = _stagger(walk)
    try:
        ed.model.percent = 50.0
        ed.model.pose = 2
        t = 0.5 * (ed.model.pose_times[1] + ed.model.pose_times[2])
        ed.model.pose_time = t
        t = ed.model.pose_time                       # as the model rounded it
        before = list(ed.session.staggered().pose_times)
        for mode in ("keep", "count"):
            ed.model.cull_by = mode
            assert not ed.error and not ed.model.message, (mode, ed.error, ed.model.message)
            assert [o["op"] for o in ed.session.ops][0] == "cull" and ed.session.ops[0].get(mode) is not None
            assert list(ed.session.staggered().pose_times) == before   # the same poses, the retime included
            assert [o for o in ed.session.ops if o["op"] == "retime"] == [{"op": "retime", "pose": 2, "time": t}]
        ed.session.edited()
    finally:
        ed.close()


def test_a_cull_that_would_break_an_edit_is_refused_naming_the_edit(walk):
    ed = _stagger(Session(walk, ops=[{"op": "edit_pose", "pose": 12, "deltas": {"LeftArm": [0.0, 0.0, 20.0]}}]))
    try:
        why = _check_refused(ed, "percent", 10.0, "the edit of pose 12", "would be lost", "keep 13 poses or more")
        ed.model.s = 0.02
        assert [o["op"] for o in ed.session.ops] == ["edit_pose", "succession"]
        assert why not in ed.message.value
    finally:
        ed.close()


@pytest.mark.parametrize("editor", ["stagger", "wand"])
def test_a_huge_rotation_is_refused_in_degrees(walk, editor):
    from stagger_nb.widgets import WandEditor
    ed = _stagger(walk) if editor == "stagger" else WandEditor(walk, precompute=False)
    try:
        why = _check_refused(ed, "rx", 1e308, "must lie between -360° and 360°")
        assert ("nudge x" if editor == "stagger" else "rotate x") in why
        ed.model.rx = 12.0                                  # the next one applies
        assert ed.session.ops and not ed.error
    finally:
        ed.close()


def test_limits_are_the_ops_own(walk):
    """The model refuses exactly where the op would: each bound read from the op's dataclass (one definition)."""
    from stagger_nb.widgets import StaggerEditor, WarpEditor
    ed = StaggerEditor(walk, precompute=False)
    w = WarpEditor(walk)
    try:
        for model, trait, (op, field) in [(ed.model, "tau", ("random_timing", "tau")),
                                          (ed.model, "s", ("succession", "s")),
                                          (ed.model, "w_r", ("exaggerate", "w_r")),
                                          (ed.model, "l", ("succession", "l")),
                                          (w.model, "skip", ("guided_warp", "skip"))]:
            lo, hi, _ = O.limits(op, field)
            with pytest.raises(traitlets.TraitError, match=trait):
                setattr(model, trait, hi + (1 if trait == "skip" else 0.01))
            setattr(model, trait, hi if trait != "skip" else 16)   # the bound itself is accepted (a slider's max
            assert not model.message                                 # for skip)
    finally:
        ed.close()
        w.close()


def test_values_are_rounded_to_the_controls_step(walk):
    """A slider's min + n * step (0.3500000000000001) is saved as 0.35 (the readout shows 0.35) and not written
    back to the control (a write-back is a kernel update the browser applies over the user's next step); a value
    rounded by more than float noise is written back; the pose time is shown to one decimal finer than its step,
    a frame (11.916666661899999 s at 120 Hz -> 11.9167)."""
    ed = _stagger(walk)
    try:
        from_browser(ed.controls["w_r"], value=0.3500000000000001)
        assert ed.model.w_r == 0.35 and ed.controls["w_r"].value == 0.3500000000000001
        assert [o["w_r"] for o in ed.session.ops if o["op"] == "exaggerate"] == [0.35]
        from_browser(ed.controls["w_r"], value=0.41234)   # typed between steps: 3 decimals (step 0.05)
        assert ed.model.w_r == 0.412 and ed.controls["w_r"].value == 0.412
        ed.model.pose = 3
        assert ed.model.pose_time == round(ed.model.pose_times[3], 3) != ed.model.pose_times[3]   # 60 Hz: 3
        assert snap(11.916666661899999, 1 / 120) == 11.9167
        assert ed.model.step("w_r") == ed.controls["w_r"].step == 0.05   # one definition of the step
    finally:
        ed.close()


def test_replay_failures_read_as_plain_sentences():
    """Raw technique and numpy texts become the editor's words: the op in words, then why."""
    cull = O.Op.from_json({"op": "cull", "percent": 20.0})
    keep = O.Op.from_json({"op": "keep_contacts"})
    retime = O.Op.from_json({"op": "retime", "pose": 2, "time": 3.2})
    for op, cause in [(cull, "zero-size array to reduction operation minimum which has no identity"),
                      (keep, "targets: each must be 3 finite numbers or (30, 3), got shape (3,)"),
                      (retime, "pose_times must be strictly increasing"),
                      (retime, "ValueError: math domain error")]:
        text = plain_message(ReplayError(4, op, cause))
        assert _plain(text) and "cannot be applied" in text, text
    assert plain_message(ReplayError(2, retime, "pose_times must be strictly increasing")).startswith(
        "moving pose 2 to 3.200 s")
    assert plain_message(ValueError("ops[2].s: expected a number in [-60, 60], got 100")) == \
        "s: expected a number in [-60, 60], got 100"


def test_closed_editors_leave_no_warm_up_thread_and_bounded_memory(walk):
    """12 editors (the three kinds, each warming its heads) opened and closed: at most one warm-up thread is left
    once the items running at close() have finished, and resident memory stays bounded."""
    from stagger_nb.widgets import StaggerEditor, WandEditor, WarpEditor
    m = walk.slice(0, 200)
    StaggerEditor(m).close()                  # imports and first-use allocations before measuring
    assert wait_until(lambda: not warm_threads())
    gc.collect()
    rss0 = rss_mb()
    for i in range(12):
        (StaggerEditor, WandEditor, WarpEditor)[i % 3](m).close()
    assert wait_until(lambda: len(warm_threads()) <= 1), [t.name for t in warm_threads()]
    assert wait_until(lambda: not warm_threads())    # the last one ends too, after its item
    gc.collect()
    assert rss_mb() - rss0 < 200, (rss0, rss_mb())


def test_a_closed_editor_on_a_shared_session_is_collected_and_stops(walk):
    """An editor on the user's own session: close() cancels its warm-ups, and once dropped the editor is
    garbage-collected (the session it watched does not keep it alive); the session keeps working."""
    from stagger_nb.widgets import StaggerEditor
    s = Session(walk.slice(0, 200))
    ed = StaggerEditor(s)
    futures = ed.warm_futures
    assert futures
    ed.close()
    assert all(f.cancelled() or f.done() for f in futures)
    ref = weakref.ref(ed)
    del ed
    assert wait_until(lambda: gc.collect() >= 0 and ref() is None, seconds=30)
    s.add({"op": "succession", "root": "Hips", "s": 0.02})
    assert s.edited().num_frames == 200


def test_many_edit_frame_ops_replay_in_one_pass_with_the_same_values(walk, monkeypatch):
    """A run of edit_frame ops is applied by one batched runner (10^5 of them replay in seconds, not a minute:
    benchmarks/bench_replay_many_ops.py), bit-identical to one op at a time; a change of the last op replays
    that op only."""
    rng = np.random.default_rng(3)
    names = walk.skeleton.names
    ops = [{"op": "edit_frame", "frame": int(rng.integers(0, 15)),
            "deltas": {names[int(j)]: [float(x) for x in rng.normal(0, 30, 3)] for j in rng.integers(1, 31, 2)}}
           for _ in range(300)]
    one_at_a_time = Session(walk, ops).states()[-1]      # every state kept: no batching
    single, batched = [0], [0]
    run, batch = R.RUNNERS[O.EditFrame], R.BATCHED[O.EditFrame]

    def one(st, op, r):
        single[0] += 1
        return run(st, op, r)

    def many(st, o):
        batched[0] += len(o)
        return batch(st, o)
    monkeypatch.setitem(R.RUNNERS, O.EditFrame, one)
    monkeypatch.setitem(R.BATCHED, O.EditFrame, many)
    s = Session(walk, ops)
    got = s.edited()
    assert np.array_equal(got.local_quats, one_at_a_time.local_quats)
    assert batched[0] == 299 and single[0] == 1
    s.replace(-1, dict(ops[-1], deltas={names[3]: [5.0, 0.0, 0.0]}))
    s.edited()
    assert batched[0] == 299 and single[0] == 2
