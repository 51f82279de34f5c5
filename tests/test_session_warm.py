"""Session.warm: background cache fills on the session's executor, returning a cancellable future."""
from __future__ import annotations

import itertools
import threading
import time
from concurrent.futures import CancelledError

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb.session import Session


@pytest.fixture
def session():
    return Session(sn.data.load("walk").slice(0, 120))


def test_warm_fills_the_caches_the_replay_uses(session):
    busy = []
    session.observe_busy(lambda kind, started: busy.append((kind, started, threading.current_thread().name)))
    seen = []
    fut = session.warm("extract", ("cull", [40, 60]), ("wand_basis", [0.3]),
                       progress=lambda d, t, label: seen.append((d, t, label)))
    assert fut.result(120) == 5
    assert [label for label, _ in itertools.groupby(lb for _, _, lb in seen)] == [
        "extract", "cull 40 %", "cull 60 %", "pose graph", "basis sigma=0.3", "done"]
    assert all(name.startswith("stagger_nb-warm") for _, _, name in busy)
    kinds = [k for k, started, _ in busy if started]
    assert kinds == ["extract", "cull", "cull", "graph", "basis"]
    busy.clear()
    m = session.source
    session.set_ops([{"op": "cull", "percent": 60}])
    session.edited()
    session.set_ops([{"op": "propagate", "frame": 10, "sigma": 0.3, "deltas": {m.skeleton.names[2]: [10.0, 0, 0]}}])
    session.edited()
    assert busy == []  # everything came from the warmed cache
    session.close()


def test_warm_replay_fills_every_step_and_leaves_the_op_list_alone(session, monkeypatch):
    """("replay", lists): each list replayed into the cache under its prefix digests; the session's ops and
    history do not change; a later set_ops to a warmed list computes nothing and gives exactly the result of
    a fresh replay; a list that fails is skipped (the failure shows when a user reaches it)."""
    from stagger_nb import staggered
    lists = [[{"op": "cull", "percent": p}, {"op": "succession", "root": "Hips", "s": 0.02, "l": 1.0},
              {"op": "keep_contacts"}] for p in (40.0, 70.0)]
    bad = [{"op": "edit_pose", "pose": 999, "deltas": {"Hips": [1.0, 0.0, 0.0]}}]
    assert session.warm(("replay", lists + [bad])).result(120) == 3
    assert session.ops == [] and not session.can_undo
    calls = []
    for name in ("succession", "keep_contacts", "cull", "evaluate", "extract"):
        real = getattr(staggered, name)
        monkeypatch.setattr(staggered, name, lambda *a, _r=real, _n=name, **k: calls.append(_n) or _r(*a, **k))
    for ops in lists:
        session.set_ops(ops)
        got = session.edited()
        assert calls == []   # every step came from the warm-up
        monkeypatch.undo()
        fresh = Session(session.source, ops).edited()
        assert np.array_equal(got.local_quats, fresh.local_quats)
        assert np.array_equal(got.root_positions, fresh.root_positions)
        for name in ("succession", "keep_contacts", "cull", "evaluate", "extract"):
            real = getattr(staggered, name)
            monkeypatch.setattr(staggered, name, lambda *a, _r=real, _n=name, **k: calls.append(_n) or _r(*a, **k))
    session.set_ops(bad)
    with pytest.raises(ValueError, match=r"ops\[0\] \(edit_pose\): pose"):
        session.edited()
    with pytest.raises(ValueError, match=r"^jobs\[0\]\[1\]\[0\]\[0\]"):
        session.warm(("replay", [[{"op": "nope"}]]))
    session.close()


def test_warm_future_cancels_before_the_next_item(session):
    gate, entered = threading.Event(), threading.Event()
    labels = []

    def progress(done, total, label):
        labels.append(label)
        if label == "extract":
            entered.set()
            assert gate.wait(30)

    fut = session.warm("extract", ("cull", [30, 40, 50]), progress=progress)
    assert entered.wait(30)
    assert fut.cancel() and fut.cancelled()
    gate.set()
    with pytest.raises(CancelledError):
        fut.result(30)
    done = session.warm("extract")  # the worker moves on: the same executor runs the next job
    assert done.result(120) == 1
    assert set(labels) == {"extract"}  # no cull item ran after the cancel (extract reports fractions)
    session.close()


def test_close_wait_returns_once_the_running_item_has_finished(session):
    """close(wait=True): the warm-ups are cancelled and the item running now has finished on return."""
    gate, entered, finished = threading.Event(), threading.Event(), threading.Event()

    def progress(done, total, label):
        if label == "extract" and not entered.is_set():
            entered.set()
            assert gate.wait(30)
        if label == "cull 30 %":
            finished.set()   # the extraction item is over (its successor is announced)

    fut = session.warm("extract", ("cull", [30, 40]), progress=progress)
    assert entered.wait(30)
    threading.Timer(0.3, gate.set).start()
    session.close(wait=True)
    busy = []
    session.observe_busy(lambda kind, started: busy.append(kind))
    assert fut.cancelled() and gate.is_set()
    assert session.extraction() is not None and busy == []   # the running item had finished: cached
    assert not finished.is_set()                             # and nothing after the cancel ran


def test_warm_checks_its_jobs_at_once(session):
    with pytest.raises(ValueError, match=r"^jobs\[1\]"):
        session.warm("extract", "everything")
    with pytest.raises(ValueError, match=r"^jobs\[0\]\[1\]\[1\]"):
        session.warm(("cull", [10, 150]))
    with pytest.raises(ValueError, match=r"^jobs\[0\]\[1\]\[0\]\.skip"):
        session.warm(("warp_tables", [{"duration": 1.0, "skip": 0}]))


def test_warm_error_reaches_the_future(session, monkeypatch):
    from stagger_nb import staggered

    def boom(*a, **k):
        raise RuntimeError("extraction failed")

    monkeypatch.setattr(staggered, "extract", boom)
    with pytest.raises(RuntimeError, match="extraction failed"):
        session.warm("extract").result(30)
    session.close()


def test_interpreter_exit_does_not_wait_for_the_whole_warm_up(tmp_path):
    """The worker stops before its next item once the main thread has finished: of 30 items of >= 0.5 s each
    (a plain executor's exit would wait for all of them) only the one or two started before the exit run."""
    import subprocess
    import sys
    from pathlib import Path
    log = tmp_path / "items.txt"
    code = ("import time, stagger_nb as sn; from stagger_nb.session import Session\n"
            "s = Session(sn.data.load('walk').slice(0, 60)); s.extraction()\n"
            f"log = open({str(log)!r}, 'a', buffering=1)\n"
            "s.warm(('cull', [100 - i for i in range(30)]), progress=lambda d, t, l: (log.write(l + '\\n'), "
            "time.sleep(0.5)))\n"
            "time.sleep(0.2)\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120, cwd=Path(__file__).resolve().parents[1])
    started = [ln for ln in log.read_text().splitlines() if ln.startswith("cull")]
    assert 1 <= len(started) <= 3, started


def test_the_warm_up_gives_way_to_a_foreground_replay():
    """While a foreground replay runs (``Worker.foreground``, entered by ``Session.edited``/``states``) and
    for ``IDLE_S`` after it, no gated item starts; an item marked ``False`` (the extraction, which every
    replay needs) starts at once; the worker's own thread never blocks itself."""
    from stagger_nb.session.warm import IDLE_S, Worker
    w = Worker()
    started = []
    w.submit([]).result()                                     # the worker thread exists
    with w.foreground():
        t0 = time.monotonic()
        urgent = w.submit([("urgent", lambda r: started.append(("urgent", time.monotonic() - t0)), False)])
        gated = w.submit([("gated", lambda r: started.append(("gated", time.monotonic() - t0)))])
        urgent.result(timeout=5)
        time.sleep(0.3)
        assert [s[0] for s in started] == ["urgent"]          # held while the foreground runs
        t1 = time.monotonic()
    gated.result(timeout=5)
    assert started[1][0] == "gated" and started[1][1] >= (t1 - t0) + IDLE_S * 0.9   # and IDLE_S after it
    def nested(report):                                       # on the worker's own thread: a no-op
        with w.foreground():
            pass
    assert w.submit([("nested", nested), ("after", lambda r: None)]).result(timeout=5) == 2
    cancelled = None
    with w.foreground():
        cancelled = w.submit([("never", lambda r: started.append("never"))])
        cancelled.cancel()
    time.sleep(IDLE_S * 2)
    assert cancelled.cancelled() and "never" not in started
