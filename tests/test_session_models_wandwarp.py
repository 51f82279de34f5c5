"""Issue 26 at the model layer (no widgets): the wand's edit range always holds every edited frame (so the
propagation can apply and the next change does), a guided warp's skip/duration pair that cannot shorten the
clip is refused at the control in one plain sentence (the session unchanged and still replaying), and the
tables the WarpEditor warms on open are the ones the first changes then use."""
from __future__ import annotations

import math
import re

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb.session import Session
from stagger_nb.session import models as M
from stagger_nb.session.models.views import warp_replays_first_changes, warp_tables_first_changes, warp_view
from stagger_nb.session.motion_runners import warp_table_key

_RAW = re.compile(r"ops\[\d+\]|[A-Z][a-z]+Error|Exception|Traceback")


@pytest.fixture(scope="module")
def walk():
    return sn.data.load("walk")


def _wand(walk):
    s = Session(walk)
    s0 = float(s.wand_graph().default_sigma)      # as the WandEditor opens: the clip's default sigma and its grid
    w = M.WandModel(joint="LeftUpLeg", sigma=s0, default_sigma=s0, frame_time=walk.frame_time)
    M.ModelBinding(w, s)
    return s, w


def test_a_range_that_leaves_out_the_edit_is_widened_said_and_the_next_sigma_applies(walk):
    s, w = _wand(walk)
    F = walk.num_frames
    e = F - 6
    w.propagate = False
    w.edit_frame = e
    w.rx = 20.0
    w.frame_range = [5, F // 2]                   # the case: the range excludes the edited frame
    assert w.frame_range == [5, e + 1]            # widened just enough to hold it
    assert f"{e}" in w.range_note and w.range_note in w.message and not _RAW.search(w.message)
    w.propagate = True                            # the op the issue saw recorded and failing: now it applies
    other = w.sigmas_nearest_first()[1]
    w.sigma = other
    op = s.ops[-1]
    assert op["op"] == "propagate" and op["frame_range"] == [5, e + 1] and op["sigma"] == pytest.approx(other)
    out = s.edited()
    change = np.abs(out.local_quats - walk.local_quats).max(axis=(1, 2))
    assert change[:5].max() < 1e-12 and change[e + 1:].max() < 1e-12       # outside the range: untouched
    assert change[e] > 0.1 and change[e - 10:e + 1].min() > 1e-3              # the edit there, propagated near it
    third = w.sigmas_nearest_first()[2]
    w.sigma = third                                                         # the editor still follows
    assert s.ops[-1]["sigma"] == pytest.approx(third) and s.edited() is not None
    w.frame_range = [0, F]                        # a range that holds the edit: taken as asked, the note goes
    assert w.frame_range == [0, F] and w.range_note == "" and "edit range" not in w.message


def test_an_edit_moved_out_of_the_range_widens_it(walk):
    s, w = _wand(walk)
    w.edit_frame = 20
    w.rx = 10.0
    w.frame_range = [10, 40]
    assert w.frame_range == [10, 40] and w.range_note == ""
    w.edit_frame = 70                             # moves the edit there
    assert w.frame_range == [10, 71] and "70" in w.range_note
    assert s.ops[-1]["frame_range"] == [10, 71] and s.edited() is not None


def _warp(walk, **ops):
    s = Session(walk)
    w = M.WarpModel()
    b = M.ModelBinding(w, s)
    return s, w, b


def test_shortest_is_the_skip_bound_and_the_runner_agrees(walk):
    """``shortest(skip)`` is the closed form ``ceil((N - 1) / skip)`` frames; the session's guided warp reaches it
    and refuses one frame less (the runner's own check), so the model refuses exactly what cannot apply."""
    s, w, _ = _warp(walk)
    ft, N = walk.frame_time, walk.num_frames
    for skip in (2, 3, 5, 8):
        need = w.shortest(skip)
        assert need == pytest.approx(math.ceil((N - 1) / skip) * ft)
        ok = Session(walk, ops=[{"op": "guided_warp", "duration": need, "skip": skip}])
        assert ok.edited().num_frames == round(need / ft) + 1
        bad = Session(walk)
        with pytest.raises(ValueError):
            bad.set_ops([{"op": "guided_warp", "duration": need - ft, "skip": skip}])
            bad.edited()


def test_skip_that_cannot_shorten_the_clip_is_refused_in_a_sentence_and_the_session_replays(walk):
    s, w, _ = _warp(walk)
    assert w.set_control("duration", w.shortest(4) + 2 * walk.frame_time) == ""  # skip 4 reaches it, 1..3 do not
    short = w.duration
    before = s.ops
    why = w.set_control("skip", 1)
    assert why.startswith("skip 1 cannot shorten the clip") and "raise skip to 4" in why
    assert not _RAW.search(why) and w.notes["skip"] == why
    assert w.skip == 8 and s.ops == before and s.edited().num_frames == round(short / walk.frame_time) + 1
    assert w.set_control("skip", 4) == "" and s.ops[-1]["skip"] == 4        # the next valid change applies
    why = w.set_control("duration", round(w.shortest(4) - walk.frame_time, 6))   # shorter than skip 4 reaches
    assert "needs a skip of 5 or more" in why and not _RAW.search(why) and s.ops[-1]["duration"] == short
    assert w.set_control("free_length", True) == ""          # free length has no such bound
    assert w.set_control("skip", 1) == "" and s.ops[-1]["free_length"] is True
    # turning free length off at skip 1 and that duration cannot apply: refused at the control, in a sentence
    before = s.ops
    why = w.set_control("free_length", False)
    assert why.startswith("a fixed length at") and "raise skip to 4 or more first" in why and not _RAW.search(why)
    assert w.free_length is True and s.ops == before and s.edited() is not None
    assert w.set_control("skip", 4) == "" and w.set_control("free_length", False) == ""    # then it applies
    assert s.ops[-1]["skip"] == 4 and not s.ops[-1].get("free_length")


def test_switching_to_guided_at_a_skip_that_cannot_reach_the_duration_is_refused(walk):
    """A linear warp has no skip bound; switching it to guided at skip 1 and a short duration is refused at the
    mode control (not at replay, where the runner's message names its parameters) and the linear warp stays."""
    s, w, _ = _warp(walk)
    assert w.set_control("mode", "linear") == "" and w.set_control("skip", 1) == ""
    assert w.set_control("duration", round(w.shortest(4) + walk.frame_time, 6)) == ""
    before = s.ops
    why = w.set_control("mode", "guided")
    assert why.startswith("a guided warp at") and "skip of 4 or more" in why and not _RAW.search(why)
    assert w.mode == "linear" and s.ops == before and s.ops[-1]["op"] == "linear_warp" and s.edited() is not None
    assert w.set_control("skip", 4) == "" and w.set_control("mode", "guided") == ""
    assert s.ops[-1]["op"] == "guided_warp" and s.edited().num_frames == round(w.duration / walk.frame_time) + 1


def test_the_tables_warmed_on_open_are_those_the_first_changes_use(walk, monkeypatch):
    """After the open-time warm-up, the first duration key (down and up), free-length toggle and backward toggle
    build no kNN table (``timewarp.prepare_warp`` is not called again): each replays a DP only."""
    from stagger_nb import timewarp
    s, w, b = _warp(walk)
    ops = warp_tables_first_changes(b, 16)
    keys = [warp_table_key(walk, o) for o in ops]
    assert len(set(keys)) == len(keys) >= 3     # compression, free length, backward, expansion: each table once
    assert ops[0]["skip"] == 16 and {o["skip"] for o in ops} <= {16, w.skip}
    s.warm(("warp_tables", ops)).result()
    calls = []
    real = timewarp.prepare_warp
    monkeypatch.setattr(timewarp, "prepare_warp", lambda *a, **k: calls.append(a[2:]) or real(*a, **k))
    D = walk.duration
    for k, v in (("duration", round(0.9 * D, 3)), ("free_length", True), ("free_length", False),
                 ("backward", True), ("backward", False), ("duration", round(1.1 * D, 3))):
        assert w.set_control(k, v) == ""
        assert s.edited().num_frames > 1
    assert calls == []
    assert s.ops[-1]["duration"] == pytest.approx(round(1.1 * D, 3)) and s.ops[-1]["backward"] is False


def test_a_first_backward_toggle_at_the_source_duration_uses_the_warmed_tables(walk, monkeypatch):
    from stagger_nb import timewarp
    s, w, b = _warp(walk)
    s.warm(("warp_tables", warp_tables_first_changes(b, 16))).result()
    calls = []
    real = timewarp.prepare_warp
    monkeypatch.setattr(timewarp, "prepare_warp", lambda *a, **k: calls.append(a[2:]) or real(*a, **k))
    assert w.set_control("backward", True) == "" and s.ops[-1]["backward"] is True
    assert s.edited().num_frames == walk.num_frames and calls == []


def test_the_first_backward_toggle_is_replayed_by_the_warm_up(walk, monkeypatch):
    """After the WarpEditor's warm-up (tables, then ``warp_replays_first_changes``) the first backward toggle at
    the clip's own length runs no guided warp (its DP was the 0.77 s left on CMU 01_01); the motion it gives is
    the one a session without any warm-up replays, bit for bit. Inert toggles warm nothing."""
    from stagger_nb import timewarp
    s, w, b = _warp(walk)
    lists = warp_replays_first_changes(b)
    assert len(lists) == 1 and lists[0][-1]["backward"] is True and s.ops == []
    s.warm(("warp_tables", warp_tables_first_changes(b, 16)), ("replay", lists)).result()
    assert s.ops == []                              # warming changes neither the op list nor the model
    calls = []
    real = timewarp.guided_warp
    monkeypatch.setattr(timewarp, "guided_warp", lambda *a, **k: calls.append(a[2:]) or real(*a, **k))
    fresh = Session(walk)
    fresh.set_ops(lists[0])
    assert w.set_control("backward", True) == "" and s.ops == fresh.ops
    got = s.edited()
    assert calls == [] and got.num_frames == walk.num_frames
    monkeypatch.setattr(timewarp, "guided_warp", real)
    assert np.array_equal(fresh.edited().local_quats, got.local_quats)
    assert np.array_equal(fresh.edited().root_positions, got.root_positions)
    assert w.set_control("mode", "linear") == "" and warp_replays_first_changes(b) == []


@pytest.fixture(scope="module")
def cmu():
    return sn.data.load("cmu_01_01")


def test_cmu_skip_1_at_2_87_s_is_refused_plainly_and_the_session_replays(cmu):
    """Issue 26's held-out case on CMU 01_01 (2,751 frames): skip 1 at 2.87 s, by the skip control, by switching
    a linear warp to guided and by turning free length off, is refused in a sentence; the session replays."""
    s, w, _ = _warp(cmu)
    assert w.set_control("duration", 2.87) == ""
    before = s.ops
    why = w.set_control("skip", 1)
    assert "raise skip to 8" in why and not _RAW.search(why) and s.ops == before
    assert s.edited().num_frames == round(2.87 / cmu.frame_time) + 1
    assert w.set_control("free_length", True) == "" and w.set_control("skip", 1) == ""
    why = w.set_control("free_length", False)
    assert "raise skip to 8 or more first" in why and not _RAW.search(why) and s.edited() is not None
    assert w.set_control("mode", "linear") == "" and w.free_length is True
    why = w.set_control("mode", "guided")          # back to guided: free length still on, no bound: applies
    assert why == "" and s.ops[-1]["free_length"] is True and s.edited() is not None


def test_cmu_a_keytime_inside_the_clip_gives_a_warp_through_it(cmu):
    """The keytime 2.0 s -> 1.5 s at 22.83 s (issue 26): the warp passes through it (within one input frame at
    the output frame nearest 1.5 s) and ends at the clip's end."""
    s, w, _ = _warp(cmu)
    assert w.set_control("duration", 22.83) == "" and w.set_control("keytimes_text", "2:1.5") == ""
    assert s.ops[-1]["keytimes"] == [[2.0, 1.5]]
    v = warp_view(s)
    ft = cmu.frame_time
    k = int(round(1.5 / ft))
    assert abs(v["warp"][k] - 2.0) <= ft + 1e-9
    assert v["out_times"][-1] == pytest.approx(22.83, abs=ft) and v["warp"][-1] == pytest.approx(cmu.duration, abs=ft)
    assert np.all(np.diff(v["warp"]) >= -1e-12)
