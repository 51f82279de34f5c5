"""The next step of a slider (session/warm.py ``next_step``, ``Session.check_ops``): the op list one step further
is warmed in the background, and what it caches is exactly what the foreground replay computes."""
from __future__ import annotations

import threading
import time

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb.session import Session
from stagger_nb.session.cache import Cache
from stagger_nb.session.heads import Heads
from stagger_nb.session.ops import Op
from stagger_nb.session.replay import Replay, Stopped, chain_keys
from stagger_nb.session.warm import next_step


def typed(*ops):
    return tuple(Op.from_json(o) for o in ops)


def ex(w):
    return {"op": "exaggerate", "w_r": w}


def rt(tau, seed=0):
    return {"op": "random_timing", "tau": tau, "seed": seed}


CULL = {"op": "cull", "percent": 40.0}


def test_next_step_extrapolates_one_number_at_its_decimals():
    a, b = typed(CULL, ex(0.5), rt(0.1)), typed(CULL, ex(0.55), rt(0.1))
    nxt = next_step(a, b)
    assert [o.to_json() for o in nxt] == [o.to_json() for o in typed(CULL, ex(0.6), rt(0.1))]
    assert nxt[0] is b[0] and nxt[2] is b[2]            # the other ops are the same objects
    assert next_step(b, a)[1].w_r == 0.45                # the other way
    assert next_step(typed(rt(0.105)), typed(rt(0.11)))[0].tau == 0.115   # not 0.11499999999999999
    assert next_step(typed(ex(0.55)), typed(ex(0.55))) is None           # nothing moved
    # an op appearing with its one required number: the slider left 0 (the editor writes no op at identity)
    assert next_step(typed(CULL, rt(0.1)), typed(CULL, ex(0.05), rt(0.1)))[1].w_r == 0.1
    assert next_step(typed(CULL), typed(CULL, rt(0.005)))[1].tau == 0.01
    assert next_step(typed(ex(0.5)), typed(ex(0.5), {"op": "succession", "root": "Hips", "s": -0.005}))[1].s == -0.01


@pytest.mark.parametrize("before, after", [
    ((CULL, ex(0.5)), (CULL, ex(0.55), rt(0.1))),                     # an op added and another changed
    ((), (CULL,)),                                                     # an op added without a required number
    ((CULL, ex(0.5)), (CULL,)),                                        # an op removed
    ((ex(0.5), rt(0.1)), (ex(0.55), rt(0.12))),                        # two ops changed
    ((rt(0.1, seed=0),), (rt(0.1, seed=1),)),                          # an int field (a seed is no slider)
    ((rt(0.1), ), (ex(0.1),)),                                         # another op
    ((rt(0.14),), (rt(0.15 + 30.0),)),                                 # past the op's bound (60 s): refused
    ((ex(1 / 3),), (ex(0.4),)),                                        # not on a decimal grid
    ((CULL,), ({"op": "cull", "percent": 45.0},)),                     # a cull (the editor warms those)
    (({"op": "resample", "frame_time": 0.01},), ({"op": "resample", "frame_time": 0.02},)),   # a motion op
])
def test_next_step_is_none_unless_one_number_of_one_op_moved(before, after):
    assert next_step(typed(*before), typed(*after)) is None


def test_stopped_between_two_ops_keeps_the_finished_steps():
    m = sn.data.load("walk").slice(0, 120)
    replay = Replay(Heads(Cache(), m, {}), m)
    ops = typed(CULL, ex(0.5), rt(0.05))
    asked = []

    def stop():                 # let the first two ops run, stop before the third
        asked.append(1)
        return len(asked) > 2
    with pytest.raises(Stopped):
        replay.check(ops, stop=stop)
    computed = []                                # resumes: only the last op is left
    replay.run(ops, chain_keys(ops), len(ops), progress=lambda d, t, label: computed.append(label))
    assert computed == ["random_timing", "done"]
    ref = Session(m, ops=[o.to_json() for o in ops]).edited()
    got = replay.edited(ops)
    assert np.array_equal(got.local_quats, ref.local_quats) and np.array_equal(got.root_positions, ref.root_positions)
    replay.into_cache(typed(CULL, ex(0.6)), stop=lambda: True)    # into_cache swallows a stop


@pytest.mark.parametrize("field, values", [("w_r", (0.5, 0.55)), ("tau", (0.04, 0.045))])
def test_check_ops_warms_the_next_step_and_it_replays_bit_exactly(field, values):
    """Two check_ops moving one slider warm the third value; replaying it then computes no op, and its result
    is bit for bit a fresh session's replay of the same list (the fast path is the full replay, cached)."""
    m = sn.data.load("walk").slice(0, 120)

    def ops(v):
        return [CULL, ex(v if field == "w_r" else 0.5), rt(v if field == "tau" else 0.04)]
    s = Session(m, ops=ops(values[0]))
    s.edited()
    for v in values:
        s.check_ops(ops(v))
        s.set_ops(ops(v))
        s.edited()
    fut = s.next_step
    assert fut is not None and fut.result(timeout=120) == 1
    third = round(2 * values[1] - values[0], 3)
    s.set_ops(ops(third))
    computed = []
    got = s.edited(progress=lambda d, t, label: computed.append(label))
    assert computed == []                                   # every step came from the warm-up
    ref = Session(m, ops=ops(third)).edited()
    assert np.array_equal(got.local_quats, ref.local_quats)
    assert np.array_equal(got.root_positions, ref.root_positions)
    s.close()


def test_warm_next_step_off():
    m = sn.data.load("walk").slice(0, 120)
    s = Session(m, ops=[CULL, ex(0.5)])
    s.warm_next_step = False
    s.check_ops([CULL, ex(0.5)])
    s.check_ops([CULL, ex(0.55)])
    assert s.next_step is None
    s.close()


def test_a_replay_waiting_for_the_lock_stops_a_background_replay():
    """``Replay.waiting`` counts a thread waiting for the replay's lock: the next-step warm-up asks it between two
    ops and gives way (here its ``stop`` holds the lock until someone waits, then stops)."""
    m = sn.data.load("walk").slice(0, 120)
    replay = Replay(Heads(Cache(), m, {}), m)
    ops = typed(CULL, ex(0.5), rt(0.05))
    result = {}

    def stop():
        end = time.monotonic() + 30
        while replay.waiting == 0 and time.monotonic() < end:
            time.sleep(0.005)
        return replay.waiting > 0

    def background():
        try:
            replay.check(ops, stop=stop)
            result["bg"] = "finished"
        except Stopped:
            result["bg"] = "stopped"
    t = threading.Thread(target=background)
    t.start()
    while replay.lock.acquire(blocking=False):   # until the background thread holds the lock
        replay.lock.release()
        time.sleep(0.001)
    got = replay.edited(ops)            # waits for the lock: the background stops at its first op
    t.join(30)
    assert result == {"bg": "stopped"} and replay.waiting == 0
    ref = Session(m, ops=[o.to_json() for o in ops]).edited()
    assert np.array_equal(got.local_quats, ref.local_quats)


def test_a_stopped_speculation_resumes_at_the_next_pause_and_a_newer_one_replaces_it():
    from stagger_nb.session.warm import Worker
    w = Worker()
    calls = []

    def fn(report):
        calls.append("run")
        if len(calls) == 1:
            raise Stopped(0)    # gave way to a foreground replay
    assert w.speculate("next step", fn).result(timeout=30) == 1 and calls == ["run", "run"]
    with w.foreground():        # held: neither starts; the first is replaced by the second
        first = w.speculate("a", lambda r: calls.append("a"))
        second = w.speculate("b", lambda r: calls.append("b"))
    assert second.result(timeout=30) == 1 and first.cancelled() and calls[2:] == ["b"]
    w.stop()


def test_a_stagger_model_slider_finds_its_next_step_warmed_and_bit_exact(monkeypatch):
    """Through the StaggerModel's binding (the editor's path: check_ops, then set_ops): w_r 0 -> 0.05 -> 0.1 (the
    exaggerate op appears, then moves) warms 0.15; moving there runs no op on this thread, and the edited motion
    is a fresh session's replay of the same op list, bit for bit; then τ the same way."""
    from stagger_nb import staggered
    from stagger_nb.session import models as M
    m = sn.data.load("walk").slice(0, 120)
    s = Session(m)
    model = M.StaggerModel(root="Hips")
    M.ModelBinding(model, s)
    model.percent = 50.0
    here = []                    # the ops run on this (the user's) thread
    for name in ("exaggerate", "random_timing", "evaluate"):
        real = getattr(staggered, name)

        def counted(*a, _real=real, _name=name, **k):
            if threading.current_thread() is threading.main_thread():
                here.append(_name)
            return _real(*a, **k)
        monkeypatch.setattr(staggered, name, counted)
    for field, vals, op in (("w_r", (0.05, 0.1, 0.15), "exaggerate"), ("tau", (0.005, 0.01, 0.015), "random_timing")):
        here.clear()
        for v in vals[:2]:
            setattr(model, field, v)
        assert op in here                                 # the first two moves computed their replay here
        s.next_step.result(timeout=120)
        here.clear()
        setattr(model, field, vals[2])
        got = s.edited()
        assert here == [], (field, here)                  # the third came from the warm-up
        ref = Session(m, ops=s.ops).edited()
        assert np.array_equal(got.local_quats, ref.local_quats)
        assert np.array_equal(got.root_positions, ref.root_positions)
    s.close()


def test_the_state_a_slider_resumes_from_stays_cached(monkeypatch):
    """Each τ move adds its states to the bounded cache; the state its replays resume from (after the exaggeration)
    is marked recently used each time, so it is not the one dropped: the exaggeration runs once for six moves."""
    from stagger_nb import staggered
    m = sn.data.load("walk").slice(0, 120)
    replay = Replay(Heads(Cache(bounds={"state": 4}), m, {}), m)
    runs = []
    real = staggered.exaggerate
    monkeypatch.setattr(staggered, "exaggerate", lambda *a, **k: runs.append(1) or real(*a, **k))
    for i in range(6):
        ops = typed(CULL, ex(0.5), rt(0.04 + 0.005 * i))
        got = replay.edited(ops)
    assert len(runs) == 1
    ref = Session(m, ops=[o.to_json() for o in ops]).edited()
    assert np.array_equal(got.local_quats, ref.local_quats)
