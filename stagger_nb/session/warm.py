"""Background cache fills for :meth:`Session.warm <stagger_nb.session.Session.warm>`.

A :class:`Worker` is the session's own executor: one daemon thread running submitted job lists in order.
Each list is a sequence of ``(label, fn)`` items, ``fn(report)`` taking ``report(fraction)`` or None; its :class:`concurrent.futures.Future` is cancellable
between items (the item running finishes; what it computed stays cached). The thread is a daemon so an
interpreter exit never waits for a long warm-up (a ``ThreadPoolExecutor`` joins its threads at exit, which
would wait for every remaining item).
"""
from __future__ import annotations

import queue
import threading
from concurrent.futures import Future, InvalidStateError
from typing import Callable

__all__ = ["Worker"]


class Worker:
    """One daemon thread running job lists in submission order (started on first use)."""

    def __init__(self, name: str = "stagger_nb-warm"):
        self._name = name
        self._queue: queue.SimpleQueue = queue.SimpleQueue()
        self._thread: threading.Thread | None = None
        self._futures: list[Future] = []
        self._lock = threading.Lock()

    def submit(self, items: list, progress: Callable | None = None) -> Future:
        """Run ``items`` (``[(label, fn), ...]``, each called as ``fn(report)``) in the background; the
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
            _run(fut, items, progress)


def _run(fut: Future, items: list, progress: Callable | None) -> None:
    done = 0
    try:
        for label, fn in items:
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
