"""A tqdm progress bar as the ``progress`` callback of :meth:`Session.edited <stagger_nb.session.Session.edited>`,
:meth:`Session.warm <stagger_nb.session.Session.warm>` and friends.

Those call ``progress(done, total, label)`` (``done`` may be fractional while a long step reports how far it
is); :class:`ProgressBar` draws that with ``tqdm.auto`` (a notebook bar in Jupyter, text elsewhere)::

    s.edited(progress=progress_bar("extract"))
    with progress_bar("warm") as bar:
        s.warm("extract", ("cull", range(5, 101, 5)), progress=bar).result()

The bar is created at the first call (nothing is drawn when everything was cached) and closed when the
label ``"done"`` arrives, or when the ``with`` block ends.
"""
from __future__ import annotations

import threading

__all__ = ["ProgressBar", "progress_bar"]


class ProgressBar:
    """``callable(done, total, label)`` drawing a tqdm bar (see the module docstring)."""

    def __init__(self, desc: str = "", **tqdm_options):
        self.desc = str(desc)
        self._options = tqdm_options
        self._bar = None
        self._lock = threading.Lock()  # warm() reports from its worker thread
        self.closed = False

    def __call__(self, done, total, label: str = "") -> None:
        with self._lock:
            if self.closed:
                return
            if self._bar is None:
                from tqdm.auto import tqdm
                self._bar = tqdm(total=float(total), desc=self.desc, unit="step",
                                 bar_format="{l_bar}{bar}| {n:.1f}/{total:.0f} [{elapsed}<{remaining}]{postfix}",
                                 **self._options)
            bar = self._bar
            if bar.total != float(total):
                bar.total = float(total)
            bar.n = min(float(done), float(total))
            if label and label != "done":
                bar.set_postfix_str(str(label), refresh=False)
            bar.refresh()
            if label == "done":
                self._close()

    @property
    def n(self) -> float:
        """Steps done so far (0 before the first report)."""
        return 0.0 if self._bar is None else float(self._bar.n)

    def close(self) -> None:
        with self._lock:
            self._close()

    def _close(self) -> None:
        if self._bar is not None and not self.closed:
            self._bar.close()
        self.closed = True

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def progress_bar(desc: str = "", **tqdm_options) -> ProgressBar:
    """A :class:`ProgressBar` titled ``desc`` (``tqdm_options`` go to ``tqdm.auto.tqdm``, e.g. ``file=``,
    ``disable=True``)."""
    return ProgressBar(desc, **tqdm_options)
