"""Background cache fills for :meth:`Session.warm <stagger_nb.session.Session.warm>`.

A :class:`Worker` is the session's own executor: one daemon thread running submitted job lists in order.
Each list is a sequence of ``(label, fn)`` items, ``fn(report)`` taking ``report(fraction)`` or None; its :class:`concurrent.futures.Future` is cancellable
between items (the item running finishes; what it computed stays cached). The thread is a daemon so an
interpreter exit never waits for a long warm-up (a ``ThreadPoolExecutor`` joins its threads at exit, which
would wait for every remaining item).

The warm-up gives way to the user: while a foreground replay runs (:meth:`Worker.foreground`, which
``Session.states``/``edited`` enter), and for :data:`IDLE_S` after it, no new item starts, so a slider moved
just after an editor opens does not share the CPU with the warm-up (the item already running finishes).
"""
from __future__ import annotations

import queue
import threading
import time
from concurrent.futures import Future, InvalidStateError
from contextlib import contextmanager
from typing import Callable

__all__ = ["Worker", "IDLE_S"]

#: Seconds the warm-up waits after the last foreground replay before its next item (a slider being dragged
#: sends a value every ~50-100 ms: the warm-up resumes when the user pauses).
IDLE_S = 0.15


class Worker:
    """One daemon thread running job lists in submission order (started on first use)."""

    def __init__(self, name: str = "stagger_nb-warm"):
        self._name = name
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._futures: list[Future] = []
        self._lock = threading.Lock()
        self._gate = threading.Condition()
        self._foreground = 0                 # foreground replays running now (other threads than the worker)
        self._idle_since = float("-inf")     # time.monotonic() when the last one ended

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

    def _wait_for_idle(self, fut: Future) -> None:
        """Block the worker until no foreground replay has run for :data:`IDLE_S` (or ``fut`` is cancelled)."""
        with self._gate:
            while not fut.cancelled():
                if self._foreground:
                    self._gate.wait(0.5)
                    continue
                rest = IDLE_S - (time.monotonic() - self._idle_since)
                if rest <= 0:
                    return
                self._gate.wait(rest)

    def submit(self, items: list, progress: Callable | None = None) -> Future:
        """Run ``items`` (``[(label, fn), ...]``, each called as ``fn(report)``; ``(label, fn, False)`` for an
        item every foreground replay needs too, which does not wait for the user to pause) in the background; the
        future's result is how many ran. ``progress(done, total, label)`` is called before each item, with a
        fractional ``done`` as an item reports ``report(fraction)``, and with ``"done"`` at the end
        (``report`` is None without ``progress``)."""
        fut: Future = Future()
        with self._lock:
            self._futures = [f for f in self._futures if not f.done()] + [fut]
            if self._thread is None:
                self._thread = threading.Thread(target=self._loop, name=self._name, daemon=True)
                self._thread.start()
        self._queue.put((fut, list(items), progress))
        return fut

    def cancel_all(self) -> None:
        """Cancel every pending or running job list (each stops before its next item)."""
        with self._lock:
            futures, self._futures = self._futures, []
        for f in futures:
            f.cancel()

    def _loop(self) -> None:
        while True:
            fut, items, progress = self._queue.get()
            _run(fut, items, progress, self._wait_for_idle)


def _run(fut: Future, items: list, progress: Callable | None, wait: Callable[[Future], None]) -> None:
    done = 0
    try:
        for item in items:
            label, fn = item[:2]
            if len(item) < 3 or item[2]:   # a third field False: the user's next replay needs it anyway
                wait(fut)
            if fut.cancelled():
                return
            report = None
            if progress is not None:
                progress(done, len(items), label)
                report = (lambda f, d=done, n=len(items), lb=label: progress(d + min(max(float(f), 0.0), 1.0), n, lb))
            fn(report)
            done += 1
        if progress is not None:
            progress(done, len(items), "done")
        fut.set_result(done)
    except InvalidStateError:  # cancelled between the last check and the result
        pass
    except BaseException as e:  # noqa: BLE001 - handed to whoever waits on the future
        try:
            fut.set_exception(e)
        except InvalidStateError:
            pass
