"""The next step of a guided warp's duration slider, solved ahead (Hsu et al. 2007, §3.3).

A duration move replays one ``guided_warp`` op whose tables are cached (the WarpEditor warms them): what is
left is the constrained search for the new length (on CMU 01_01, 2,751 frames: 25-80 ms CPU) and the §3.4 tail
(smoothing, resampling: ~12 ms). After a foreground replay whose op list differs from the previous one only in
one guided warp's ``duration``, :func:`next_warp_lengths` gives the lengths the next move most likely asks for
(``2 n1 - n0`` output frames: one more step along; then one frame either way) and the session solves them in
the background (:meth:`Heads.solve_ahead
<stagger_nb.session.heads.Heads.solve_ahead>`, cancellable between chunks of the search: the partial work is
thrown away). The next key press (either way) or drag tick of the same slider then finds its search cached
(``Heads.warp_solution``) and runs only the tail; a step back to a length searched before finds it cached
too. Nothing but *when* the search runs changes: the same function on the same tables, so the same arrays.
"""
from __future__ import annotations

from ..core.motion import Motion
from . import ops as O
from .motion_runners import warp_k, warp_search

__all__ = ["next_warp_lengths", "solve_next_lengths", "warm_next_lengths"]


def _changed(before: tuple, after: tuple):
    """``(i, op before or None)``: the one op of ``after`` that differs from ``before`` (same length), or its
    last op appended to ``before``; None otherwise."""
    same = lambda x, y: x is y or x.key == y.key   # noqa: E731
    if len(after) == len(before) + 1 and all(same(x, y) for x, y in zip(before, after)):
        return len(after) - 1, None
    if len(before) != len(after):
        return None
    diff = [i for i, (x, y) in enumerate(zip(before, after)) if not same(x, y)]
    return (diff[0], before[diff[0]]) if len(diff) == 1 else None


def next_warp_lengths(before: tuple, after: tuple, state_of) -> tuple[O.GuidedWarp, Motion, list] | None:
    """``(op, state, ops)`` when the typed op lists ``before`` -> ``after`` differ only in the ``duration`` of one
    ``guided_warp`` op (both with a duration, not free length), or ``after`` appends one (the first duration
    move), and ``state_of(i)`` (the state that op ``i`` warps, or None when it is not known) is a Motion:
    ``op`` is that warp, ``ops`` the same warp at the lengths the slider's next move most likely asks for, in
    this order: ``2 n1 - n0`` output frames (the same move again: a key held, a steady drag; ``n0``, ``n1`` the
    frames of the two durations), one frame further (a key after a drag), one frame back (a key the other way;
    ``n0`` itself is cached already); an appended warp: one frame either way. Lengths refused (past the
    slider's end) are left out. None when the lists differ otherwise or the length did not change."""
    found = _changed(before, after)
    if found is None:
        return None
    i, a = found
    b = after[i]
    if not isinstance(b, O.GuidedWarp) or b.free_length or (a is not None and (
            not isinstance(a, O.GuidedWarp) or a.free_length)):
        return None
    jb = b.to_json()
    jb.pop("duration")
    if a is not None:
        ja = a.to_json()
        if ja.pop("duration") == b.duration or ja != jb:
            return None
    state = state_of(i)
    if not isinstance(state, Motion):
        return None
    try:
        n1 = warp_search(state, b)[0]
        n0 = n1 - 1 if a is None else warp_search(state, a)[0]
    except ValueError:
        return None
    if n0 == n1:
        return None
    d = 1 if n1 > n0 else -1
    ops, seen = [], {n1} if a is None else {n0, n1}
    for n2 in ((n1 + 1, n1 - 1) if a is None else (2 * n1 - n0, n1 + d, n1 - d)):
        if n2 in seen or n2 < 2:
            continue
        seen.add(n2)
        try:
            nxt = O.Op.from_json(dict(b.to_json(), duration=round((n2 - 1) * state.frame_time, 6)))
            if warp_search(state, nxt)[0] == n2:
                ops.append(nxt)
        except ValueError:
            continue
    return b, state, ops


def solve_next_lengths(heads, state: Motion, current: O.GuidedWarp, ops, stop=None) -> int:
    """In the background: the sweep of the lengths around ``current``'s (``Heads.sweep_ahead``, where the search
    is the exact DP: any small move is then a backtrack), then each guided warp of ``ops`` on ``state`` into
    the heads' cache, in order (``Heads.solve_ahead``: only from cached tables, a search cached already
    skipped). ``stop()`` True raises ``Stopped`` and the computation running is thrown away. Returns how many
    searches (the sweep included) were computed."""
    done = 0
    for i, op in enumerate([current, *ops]):
        n, u, step = warp_search(state, op)
        keytimes = None if op.keytimes is None else [list(p) for p in op.keytimes]
        ahead = heads.sweep_ahead if i == 0 else heads.solve_ahead
        done += ahead(state, op.reference, op.skip, u, op.backward, warp_k(n), step, n, keytimes, stop=stop)
    return done


def warm_next_lengths(replay, worker, heads, before: tuple, ops: tuple):
    """After ``Session.check_ops`` of ``ops`` (``before``: the list checked before it): when it moved one guided
    warp's duration (or added the warp), :func:`solve_next_lengths` in the background on the session's
    ``worker`` (``Worker.speculate``: it replaces the previous speculation, gives way to every foreground replay
    and resumes at the next pause, starting the search it was in again; cancelled, by a newer speculation or
    ``Session.close``, it stops between two chunks of its search). The future, or None when the change is
    anything else."""
    guess = next_warp_lengths(before, ops, lambda i: replay.known_state(ops, i))
    if guess is None:
        return None
    cur, state, nxt = guess
    mine: list = []

    def wanted() -> bool:   # a foreground replay started, a thread waits for the replay's lock, or cancelled
        return worker.wanted() or replay.waiting > 0 or bool(mine and mine[0].cancelled())
    mine.append(worker.speculate("next warp lengths", lambda report: solve_next_lengths(heads, state, cur, nxt,
                                                                                        stop=wanted)))
    return mine[0]
