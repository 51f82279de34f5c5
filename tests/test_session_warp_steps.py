"""A guided warp's duration slider (issue 26, "sliders <= 50 ms warm"): after a duration move the session solves
the searches of the likely next moves in the background (session/warp_steps.py: a sweep of the lengths around,
then the next lengths), and a replay that finds them gives exactly the arrays a fresh session replaying the same
ops computes, also after an undo and after a speculation stopped half-way."""
from __future__ import annotations

import threading

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import timewarp
from stagger_nb.session import Session
from stagger_nb.session import models as M
from stagger_nb.session.cache import BOUNDS, BUDGETS, Cache
from stagger_nb.session.heads import Heads
from stagger_nb.session.ops import Op
from stagger_nb.session.replay import Stopped
from stagger_nb.session.warp_steps import next_warp_lengths


@pytest.fixture(scope="module")
def clip():
    return sn.data.load("cmu_01_01").slice(0, 480)     # 4 s at 120 Hz: the exact DP (the sweep's case)


def _warp(duration, **kw):
    return Op.from_json(dict({"op": "guided_warp", "duration": duration}, **kw), "op")


def _same(a, b) -> bool:
    return np.array_equal(a.local_quats, b.local_quats) and np.array_equal(a.root_positions, b.root_positions)


def _fresh(clip, session):
    fresh = Session(clip, ops=session.ops)
    try:
        return fresh.edited(), fresh.warp_curve()
    finally:
        fresh.close()


def test_next_lengths_follow_the_move(clip):
    ft = clip.frame_time
    n = 400
    a, b = _warp(round((n - 1) * ft, 4)), _warp(round(n * ft, 4))          # one frame longer: n -> n + 1
    op, state, ops = next_warp_lengths((a,), (b,), lambda i: clip)
    assert op is b and state is clip
    lengths = [timewarp_frames(clip, o) for o in ops]
    assert lengths == [n + 2]              # the same move again (also one frame further); one back is n0, cached
    c = _warp(round((n + 3) * ft, 4))                                       # a drag tick: n + 1 -> n + 4
    assert [timewarp_frames(clip, o) for o in next_warp_lengths((b,), (c,), lambda i: clip)[2]] == \
        [n + 7, n + 5, n + 3]
    # the first duration move appends the warp: one frame either way
    assert [timewarp_frames(clip, o) for o in next_warp_lengths((), (b,), lambda i: clip)[2]] == [n + 2, n]
    assert next_warp_lengths((b,), (b,), lambda i: clip) is None                        # nothing moved
    assert next_warp_lengths((b,), (_warp(b.duration, skip=4),), lambda i: clip) is None  # another field
    assert next_warp_lengths((b,), (_warp(None, free_length=True),), lambda i: clip) is None
    assert next_warp_lengths((a,), (b,), lambda i: None) is None                          # state not known


def timewarp_frames(m, op) -> int:
    from stagger_nb.session.motion_runners import warp_search
    return warp_search(m, op)[0]


def test_duration_moves_replay_the_cold_paths_arrays(clip, monkeypatch):
    s = Session(clip)
    w = M.WarpModel()
    b = M.ModelBinding(w, s)
    s.warm(("warp_tables", M.views.warp_tables_first_changes(b, 16))).result()
    ft = clip.frame_time
    w.set_control("duration", round(0.85 * clip.duration, 3))
    s.edited()
    calls = []
    real = timewarp.solve_warp

    def counted(*a, **kw):
        if threading.current_thread() is threading.main_thread():   # the user's replay, not the speculation
            calls.append(kw.get("sweep") is not None)
        return real(*a, **kw)
    monkeypatch.setattr(timewarp, "solve_warp", counted)
    for step in (1, 1, 3, 3, -1, -1, 12, -40):
        s.next_step.result()                         # the user paused: the speculation has run
        calls.clear()
        assert not w.set_control("duration", w.duration + step * ft)
        out = s.edited()
        mine = list(calls)                           # the user's replay's searches
        ref, ref_warp = _fresh(clip, s)
        assert _same(out, ref) and np.array_equal(s.warp_curve(), ref_warp), step
        if abs(step) <= 3:
            # the search was found (solved ahead, or a backtrack of the sweep around the last length)
            assert mine in ([], [True]), (step, mine)
    # an undo (the moves above are one gesture: a separate change, then undo)
    before = s.ops
    longer = [dict(before[0], duration=round(before[0]["duration"] + 2 * ft, 4))]
    s.check_ops(longer)
    s.set_ops(longer)
    s.edited()
    s.next_step.result()
    assert s.undo() and s.ops == before
    out = s.edited()
    ref, ref_warp = _fresh(clip, s)
    assert _same(out, ref) and np.array_equal(s.warp_curve(), ref_warp)
    s.close()


def test_a_stopped_speculation_caches_nothing_and_the_search_is_the_same(clip):
    heads = Heads(Cache(), clip, {})
    tables = heads.warp_tables(clip, "self", 8, 1)               # cached: what the editor warms
    n, asked = 410, []

    def stop():
        asked.append(1)
        return len(asked) > 3                        # gives way after three chunks of the search
    with pytest.raises(Stopped):
        heads.solve_ahead(clip, "self", 8, 1, False, 3, 1, n, None, stop=stop)
    assert not heads.solve_ahead(clip, "self", 8, 2, False, 3, 1, n, None)   # tables not cached: refused
    computed = []
    real = timewarp.solve_warp
    got = heads.warp_solution(clip, "self", 8, 1, False, 3, 1, n, None,
                              progress=lambda f: computed.append(f))[1]       # nothing was cached: searched now
    assert computed and computed[-1] == 1.0
    want = real(tables, n)
    assert np.array_equal(got.frames, want.frames) and got.cost == want.cost
    # a sweep around n, then a search it serves: the same solution
    assert heads.sweep_ahead(clip, "self", 8, 1, False, 3, 1, n, None)
    assert not heads.sweep_ahead(clip, "self", 8, 1, False, 3, 1, n + 1, None)   # still well inside it
    assert heads.solve_ahead(clip, "self", 8, 1, False, 3, 1, n + 5, None)
    a, b = heads.warp_solution(clip, "self", 8, 1, False, 3, 1, n + 5, None)[1], real(tables, n + 5)
    assert np.array_equal(a.frames, b.frames) and np.array_equal(a.times, b.times) and a.cost == b.cost


def test_the_caches_of_searches_are_bounded():
    assert BOUNDS["warp_solution"] <= 64 and BOUNDS["warp_sweep"] <= 2 and BUDGETS["warp_sweep"] <= 256 << 20
