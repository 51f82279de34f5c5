"""Background cache fills for :meth:`Session.warm <stagger_nb.session.Session.warm>`.

A :class:`Worker` is the session's own executor: one daemon thread running submitted job lists in order.
Each list is a sequence of ``(label, fn)`` items, ``fn(report)`` taking ``report(fraction)`` or None; its
:class:`concurrent.futures.Future` is cancellable between items (the item running finishes; what it computed
stays cached). The thread is a daemon so an interpreter exit never waits for a long warm-up (a
``ThreadPoolExecutor`` joins its threads at exit, which would wait for every remaining item).

The warm-up gives way to the user: while a foreground replay runs (:meth:`Worker.foreground`, which
``Session.states``/``edited`` enter), and for :data:`IDLE_S` after it, no new item starts, so a slider moved
just after an editor opens does not share the CPU with the warm-up (the item already running finishes).

The next step of a slider: after a foreground replay whose op list differs from the previous one in one number
of one op (a slider moved from ``v0`` to ``v1``), :func:`next_step` gives the list one more step along
(``2 v1 - v0``, at the values' own decimals) and the session warms it (:meth:`Worker.speculate`), so that the
next key press or drag tick of the same slider finds its replay cached. The states are the ones the
foreground replay would compute (the same ops on the same states, cached under their prefix digests): nothing
changes but when they are computed. A foreground replay that starts meanwhile stops it between two ops
(:meth:`Worker.wanted`) and resumes at the next pause; the steps it finished stay cached.
"""
from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, InvalidStateError
from contextlib import contextmanager

import numpy as np

__all__ = ["Worker", "IDLE_S", "NEXT_STEP_IDLE_S", "LINGER_S", "warm_items", "next_step"]

#: Seconds the warm-up waits after the last foreground replay before its next item (a slider being dragged
#: sends a value every ~50-100 ms: the warm-up resumes when the user pauses).
IDLE_S = 0.15
#: Seconds the warm-up of the next slider step (:meth:`Worker.speculate`) waits after the last foreground replay:
#: less than :data:`IDLE_S`, as the step is the one the user is most likely to ask for next (the views of the
#: move just made, ~5 ms of CPU in the kernel, are drawn by then; a foreground replay stops it between two ops).
NEXT_STEP_IDLE_S = 0.04
#: Seconds the worker thread waits for more work once its queue is empty before it ends (the next
#: :meth:`Worker.submit` starts a new one): a session nobody warms any more holds no thread.
LINGER_S = 2.0


class Worker:
    """One daemon thread running job lists in submission order, started on first use and ended when it has
    had nothing to do for :data:`LINGER_S` or when :meth:`stop` is called."""

    def __init__(self, name: str = "stagger_nb-warm"):
        self._name = name
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._futures: list[Future] = []
        self._lock = threading.Lock()
        self._gate = threading.Condition()
        self._foreground = 0                 # foreground replays running now (other threads than the worker)
        self._idle_since = float("-inf")     # time.monotonic() when the last one ended
        self._speculation: Future | None = None   # the latest next-step warm-up (one at a time)

    def wanted(self) -> bool:
        """Whether a foreground replay is running or waiting now (a warm-up replay stops between two ops)."""
        return self._foreground > 0

    def speculate(self, label: str, fn: Callable) -> Future:
        """Run ``fn(report)`` in the background like a :meth:`submit` item once no foreground replay has run for
        :data:`NEXT_STEP_IDLE_S`, in place of the previous speculation (cancelled: only the latest next step is
        worth computing). ``fn`` raising :class:`~.replay.Stopped` (it gave way to a foreground replay) runs again
        after the next such pause, until it returns or a newer speculation cancels it (the steps it finished are
        cached: it resumes after them)."""
        from .replay import Stopped
        with self._lock:
            old = self._speculation
        if old is not None:
            old.cancel()
        holder: list[Future] = []
        known = threading.Event()       # set once ``holder`` has the future (the item may start before)

        def resumed(report):
            while True:
                try:
                    return fn(report)
                except Stopped:
                    known.wait()
                    fut = holder[0]
                    self._wait_for_idle(fut, NEXT_STEP_IDLE_S)
                    if fut.cancelled():
                        return None
        fut = self.submit([(label, resumed, NEXT_STEP_IDLE_S)])
        holder.append(fut)
        known.set()
        with self._lock:
            self._speculation = fut
        return fut

    @contextmanager
    def foreground(self):
        """Mark a replay the user waits for: no warm-up item starts while it runs and for :data:`IDLE_S`
        after (a no-op on the worker's own thread)."""
        if threading.current_thread() is self._thread:
            yield
            return
        with self._gate:
            self._foreground += 1
        try:
            yield
        finally:
            with self._gate:
                self._foreground -= 1
                self._idle_since = time.monotonic()
                self._gate.notify_all()

    def _wait_for_idle(self, fut: Future, idle: float = IDLE_S) -> None:
        """Block the worker until no foreground replay has run for ``idle`` seconds (or ``fut`` is cancelled)."""
        with self._gate:
            while not fut.cancelled():
                if self._foreground:
                    self._gate.wait(0.5)
                    continue
                rest = idle - (time.monotonic() - self._idle_since)
                if rest <= 0:
                    return
                self._gate.wait(rest)

    def submit(self, items: list, progress: Callable | None = None) -> Future:
        """Run ``items`` (``[(label, fn), ...]``, each called as ``fn(report)``; ``(label, fn, False)`` for an
        item every foreground replay needs too, which does not wait for the user to pause; ``(label, fn, seconds)``
        for one that waits for a shorter or longer pause than :data:`IDLE_S`) in the background; the
        future's result is how many ran. ``progress(done, total, label)`` is called before each item, with a
        fractional ``done`` as an item reports ``report(fraction)``, and with ``"done"`` at the end
        (``report`` is None without ``progress``)."""
        fut: Future = Future()
        with self._lock:
            self._futures = [f for f in self._futures if not f.done()] + [fut]
            self._queue.put((fut, list(items), progress))
            if self._thread is None:
                self._thread = threading.Thread(target=self._loop, name=self._name, daemon=True)
                self._thread.start()
        return fut

    def cancel_all(self) -> None:
        """Cancel every pending or running job list (each stops before its next item)."""
        with self._lock:
            futures, self._futures = self._futures, []
        for f in futures:
            f.cancel()

    def stop(self) -> None:
        """Cancel everything and let the thread end after the item running now (a later :meth:`submit`
        starts a new thread)."""
        self.cancel_all()
        with self._lock:
            if self._thread is not None:
                self._queue.put(None)
        with self._gate:
            self._gate.notify_all()   # a thread waiting for the user to pause sees its future cancelled

    def join(self, timeout: float | None = None) -> None:
        """Wait until the thread has ended (after :meth:`stop`; not from the worker's own thread)."""
        t = self._thread
        if t is not None and t is not threading.current_thread():
            t.join(timeout)

    @property
    def alive(self) -> bool:
        """Whether the worker's thread is running now."""
        t = self._thread
        return t is not None and t.is_alive()

    def _loop(self) -> None:
        while True:
            try:
                job = self._queue.get(timeout=LINGER_S)
            except queue.Empty:
                job = None
            if job is None:
                with self._lock:   # submit() puts under this lock: nothing can slip in between
                    if self._queue.empty():
                        self._thread = None
                        return
                continue
            fut, items, progress = job
            _run(fut, items, progress, self._wait_for_idle)


def _run(fut: Future, items: list, progress: Callable | None, wait: Callable[[Future], None]) -> None:
    done, n_items = 0, len(items)
    try:
        for item in items:
            label, fn = item[:2]
            gate = item[2] if len(item) > 2 else True
            if gate is True:
                wait(fut)
            elif gate is not False:        # seconds of idle to wait for (the next slider step)
                wait(fut, gate)            # (False: the user's next replay needs it anyway)
            if fut.cancelled():
                return
            report = None
            if progress is not None:
                progress(done, len(items), label)
                def report(f, d=done, n=n_items, lb=label):
                    progress(d + min(max(float(f), 0.0), 1.0), n, lb)
            fn(report)
            done += 1
        if progress is not None:
            progress(done, len(items), "done")
        fut.set_result(done)
    except InvalidStateError:  # cancelled between the last check and the result
        pass
    except BaseException as e:
        try:
            fut.set_exception(e)
        except InvalidStateError:
            pass


def warm_items(session, jobs) -> list:
    """The ``(label, fn[, wait])`` items of :meth:`Session.warm <stagger_nb.session.Session.warm>`'s ``jobs`` on
    ``session`` (each checked now: ValueError naming ``jobs[i]``)."""
    from .heads import DIFFUSION_MAX_FRAMES
    from .motion_runners import warp_k, warp_search
    from .ops import GuidedWarp
    from .ops.fields import _fail, number, optional
    percent, sigma = number(0.0, 100.0, open_lo=True), optional(number(0.0, open_lo=True))
    items = []
    for i, job in enumerate(jobs):
        where = f"jobs[{i}]"
        name, values = (job, None) if isinstance(job, str) else (
            tuple(job) if isinstance(job, (list, tuple)) and len(job) == 2 else (None, None))
        if name == "extract" and values is None:
            # not held back while the user moves a slider: every replay of theirs waits for it anyway
            items.append(("extract", lambda p: session._ctx.extract(session.source, p), False))
        elif name == "cull" and isinstance(values, (list, tuple, range, np.ndarray)):
            pcs = [percent(v, f"{where}[1][{k}]") for k, v in enumerate(list(values))]
            items += [(f"cull {p:g} %", lambda r, p=p: session._ctx.cull(session.extraction(), p, progress=r))
                      for p in pcs]
        elif name == "wand_basis" and isinstance(values, (list, tuple, range, np.ndarray)):
            sgs = [sigma(v, f"{where}[1][{k}]") for k, v in enumerate(list(values))]
            items.append(("pose graph", lambda r: session.wand_graph()))
            items += [(f"basis sigma={'default' if s is None else format(s, 'g')}",
                       lambda r, s=s: session.wand_basis(s)) for s in sgs]
        elif name == "compare" and isinstance(values, (list, tuple)):
            for k, pair in enumerate(values):
                if not (isinstance(pair, (list, tuple)) and len(pair) == 2 and pair[0] in ("isomap", "diffusion")):
                    _fail(f"{where}[1][{k}]", '("isomap", None) or ("diffusion", sigma)', pair)
                what, sg = pair[0], sigma(pair[1], f"{where}[1][{k}][1]")
                if what == "isomap":
                    items.append(("isomap graph", lambda r: session._ctx.isomap_graph(session.source)))
                else:
                    if session.source.num_frames > DIFFUSION_MAX_FRAMES:   # refused now, as on demand
                        try:
                            session._ctx.diffusion(session.source, sg)
                        except ValueError as e:
                            raise ValueError(f"{where}[1][{k}]: {e}") from None
                    items.append((f"diffusion sigma={'default' if sg is None else format(sg, 'g')}",
                                  lambda r, sg=sg: session._ctx.diffusion(session.source, sg)))
        elif name == "replay" and isinstance(values, (list, tuple)):
            for k, ops in enumerate(values):
                typed = session._typed_list(ops, f"{where}[1][{k}]")
                items.append((f"replay {k + 1}/{len(values)}",
                              lambda r, ops=typed: session._replay.into_cache(ops, r)))
        elif name == "warp_tables" and isinstance(values, (list, tuple)):
            for k, w in enumerate(values):
                op = session._typed(dict(w, op="guided_warp") if isinstance(w, dict) and "op" not in w else w,
                                    f"{where}[1][{k}]")
                if not isinstance(op, GuidedWarp):
                    _fail(f"{where}[1][{k}]", "a guided_warp op", w)
                try:   # checked now: an op the session cannot search is refused here, naming the job
                    n, u, step = warp_search(session.source, op)
                except ValueError as e:
                    raise ValueError(f"{where}[1][{k}]: {e}") from None
                items.append((f"warp tables {k}", lambda r, op=op, n=n, u=u, step=step: session._ctx.warp_tables(
                    session.source, op.reference, op.skip, u, op.backward, warp_k(n), r, out_step=step)))
        else:
            _fail(where, '"extract", ("cull", percents), ("wand_basis", sigmas), ("compare", pairs), '
                         '("warp_tables", warps) or ("replay", op_lists)', job)
    return items


_DECIMALS = 10   # a slider value with more decimals than this is not on a decimal grid: no next step guessed


def _decimals(x: float) -> int | None:
    """Fewest decimals (<= _DECIMALS) that write ``x`` exactly as Python rounds it, else None."""
    for n in range(_DECIMALS + 1):
        if round(x, n) == x:
            return n
    return None


#: Staggered ops whose next step is not guessed: a cull refits (a few hundred ms on a long clip, one op a
#: foreground replay would have to wait for; the StaggerEditor warms every cull position itself).
_NO_GUESS = ("cull",)


def _added_slider(before: tuple, after: tuple):
    """``(index, field)`` when ``after`` is ``before`` with one op inserted whose only required field that is a
    number is ``field`` (exaggerate's ``w_r``, random timing's ``tau``: a slider that left its identity 0, where an
    editor writes no op), else None."""
    import dataclasses
    if len(after) != len(before) + 1:
        return None
    i = 0
    while i < len(before) and (before[i] is after[i] or before[i].key == after[i].key):
        i += 1
    if any(a is not b and a.key != b.key for a, b in zip(before[i:], after[i + 1:])):
        return None
    op = after[i]
    required = [f.name for f in dataclasses.fields(op) if f.default is dataclasses.MISSING
                and f.default_factory is dataclasses.MISSING and type(getattr(op, f.name)) is float]
    return (i, required[0]) if len(required) == 1 else None


def next_step(before: tuple, after: tuple):
    """The typed op tuple one slider step past ``after`` when ``before`` -> ``after`` changed one number of one
    op: that field at ``2 v1 - v0`` rounded to the decimals of ``v0`` and ``v1`` (a control's values are snapped
    to its step: 0.55 -> 0.6 gives 0.65); an op inserted with one required number ``v1`` counts as a move from 0
    (``2 v1``: w_r 0 -> 0.05, where the editor wrote no op, gives 0.1). None when the change is anything else
    (several fields or ops, a field that is not a float, an op removed) or the next value is refused by the op's
    own checks (a slider at its end). Only ops on the staggered poses (Coleman et al. 2008, §5: their replay
    is a few evaluations long), not a cull (see ``_NO_GUESS``) nor the motion ops (a warp or a propagation may
    run for seconds, and a foreground replay stops a warm-up only between two ops; a guided warp's duration is
    guessed by :mod:`.warp_steps`, whose searches stop between chunks)."""
    from .ops import Op
    added = _added_slider(before, after)
    if added is not None:
        i, field = added
        b = after[i].to_json()
        v0, v1 = 0.0, b[field]
    else:
        if len(before) != len(after):
            return None
        diff = [i for i, (x, y) in enumerate(zip(before, after)) if x is not y and x.key != y.key]
        if len(diff) != 1 or type(before[diff[0]]) is not type(after[diff[0]]):
            return None
        i = diff[0]
        a, b = before[i].to_json(), after[i].to_json()
        keys = [k for k in b if a.get(k, None) != b[k] or k not in a]
        if len(keys) != 1 or a.keys() != b.keys():
            return None
        field = keys[0]
        v0, v1 = a[field], b[field]
    if not (type(v0) is float and type(v1) is float):
        return None
    n0, n1 = _decimals(v0), _decimals(v1)
    if n0 is None or n1 is None:
        return None
    v2 = round(2.0 * v1 - v0, max(n0, n1)) + 0.0
    if after[i].needs != "staggered" or after[i].name in _NO_GUESS:
        return None
    try:
        op = Op.from_json({**b, field: v2})
    except ValueError:
        return None
    return after[:i] + (op,) + after[i + 1:]
