"""session.cache: compute-once futures under one lock, per-kind bounds, weakref tokens never reused."""
from __future__ import annotations

import threading
import weakref

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb.session.cache import Cache, nbytes


class Thing:  # a weak-referenceable object compared by identity, like Motion / StaggeredMotion
    pass


def test_computes_once_across_threads_and_never_blocks_other_entries():
    """An entry asked for by two threads is computed once; while it is being computed another entry can be
    computed and read (no lock is held around make())."""
    cache = Cache()
    calls, release, started = [], threading.Event(), threading.Event()

    def slow():
        calls.append("slow")
        started.set()
        assert release.wait(10)  # held until the main thread has used another entry
        return "A"

    results = []
    workers = [threading.Thread(target=lambda: results.append(cache.get("cull", "m", 1.0, slow))) for _ in range(2)]
    for w in workers:
        w.start()
    assert started.wait(10)
    assert cache.get("cull", "m", 2.0, lambda: "B") == "B"  # would deadlock with the lock held around make()
    assert cache.get("cull", "m", 2.0, lambda: "other") == "B"  # cached
    assert cache.pending() == 1
    release.set()
    for w in workers:
        w.join(10)
    assert results == ["A", "A"] and calls == ["slow"]
    assert cache.pending() == 0


def test_a_failed_computation_is_computed_again():
    cache = Cache()

    def boom():
        raise RuntimeError("no")

    with pytest.raises(RuntimeError):
        cache.get("cull", "m", 3.0, boom)
    assert cache.peek("cull", "m", 3.0) is None
    assert cache.get("cull", "m", 3.0, lambda: "ok") == "ok" and cache.pending() == 0


def test_each_kind_is_bounded_least_recently_used_first():
    cache = Cache(bounds={"basis": 3})
    for s in range(3):
        cache.get("basis", "m", s, lambda s=s: s * 10)
    cache.get("basis", "m", 0, lambda: "recomputed")  # touch 0: now 1 is the oldest
    cache.get("basis", "m", 3, lambda: 30)
    assert [cache.peek("basis", "m", s) for s in range(4)] == [0, None, 20, 30]
    assert cache.get("extract", "m", None, lambda: "e") == "e"  # another kind: its own bound
    assert len(cache) == 4


def test_a_byte_budget_drops_the_least_recently_used_arrays_first():
    """Besides its count bound, a budgeted kind keeps the arrays of its finished entries within the budget
    (least recently used dropped first; the newest always stays, even alone over budget)."""
    kb = np.zeros(128)                                  # 1 KiB
    cache = Cache(budgets={"state": 3 * 1024})
    for i in range(3):
        cache.put("state", f"p{i}", None, kb.copy())
    assert cache.nbytes("state") == 3 * 1024
    cache.get("state", "p0", None)                      # touch p0: now p1 is the oldest
    cache.put("state", "p3", None, {"a": kb.copy(), "b": [kb.copy()]})   # 2 KiB, nested
    assert [cache.peek("state", f"p{i}") is not None for i in range(4)] == [True, False, False, True]
    assert cache.nbytes("state") == 3 * 1024
    cache.get("state", "big", None, lambda: np.zeros(1024))          # 8 KiB > budget: kept alone
    assert cache.peek("state", "big") is not None and cache.nbytes("state") == 8 * 1024
    assert cache.peek("state", "p0") is None and cache.peek("state", "p3") is None
    cache.get("cull", "m", 1, lambda: np.zeros(10**4))  # a kind without budget: not counted
    assert cache.nbytes("cull") == 0 and cache.peek("cull", "m", 1) is not None
    m = sn.data.load("walk")                             # a real state: its arrays are counted
    assert nbytes(m) >= m.local_quats.nbytes + m.root_positions.nbytes


def test_tokens_are_weak_and_never_reused():
    """Keys of live objects by weak reference: a dead object's entries can never be found through a new
    object at the same address (the id() pitfall)."""
    cache = Cache()
    seen = set()
    for _ in range(200):  # new objects often reuse the address of the one just freed
        t = Thing()
        tok = cache.token(t)
        assert tok not in seen and cache.token(t) == tok
        seen.add(tok)
        alive = weakref.ref(t)
        del t  # freed at once (reference counting): the token table does not keep it alive
        assert alive() is None


def test_named_objects_share_content_keys_and_first_name_stays():
    cache = Cache()
    a, b = Thing(), Thing()
    cache.name(a, "digest1")
    cache.name(b, "digest1")
    assert cache.token(a) == cache.token(b) == "digest1"
    cache.name(a, "digest2")
    assert cache.token(a) == "digest1"


def test_busy_listener_sees_heads_not_replay_steps():
    seen = []
    cache = Cache(busy=lambda kind, started: seen.append((kind, started)))
    cache.get("extract", "m", None, lambda: 1)
    cache.get("extract", "m", None, lambda: 2)
    cache.get("state", "k", None, lambda: 3)
    assert seen == [("extract", True), ("extract", False)]
