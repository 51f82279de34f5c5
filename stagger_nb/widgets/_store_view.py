"""What the two views with a state model share (:class:`.plots.PlotView` with its ``PlotState``,
:class:`.timeline.Timeline` with its ``TimelineState``): in the browser, ``storeOf`` (``_store_view.js``: the
view's store, asked for again until a page reload has restored it), put before each view's own module (an
anywidget ESM is one string: it cannot import a sibling file); in the kernel, the ``frame`` that travels both on
the view (a browser-side ``jsdlink`` target) and on its store (what a reload draws), and which of the two set it.
"""
from __future__ import annotations

from pathlib import Path

_HERE = Path(__file__).parent


def store_view_esm(name: str) -> str:
    """The ESM of the view module ``name`` (a .js file beside this one), ``_store_view.js`` before it."""
    return (_HERE / "_store_view.js").read_text(encoding="utf-8") + (_HERE / name).read_text(encoding="utf-8")


class _FrameFromBrowser:
    """The playhead of a view with a ``store``: the view's ``frame`` and the store's follow each other, and
    :attr:`frame_from_browser` says when the browser set it. Call :meth:`_follow_store` in ``__init__``."""

    def _follow_store(self, store) -> None:
        """``frame`` of the view and of ``store`` (the view's state model) follow each other."""
        self._browser_frame = False
        self.observe(self._frame_to_store, names="frame")
        store.observe(self._frame_from_store, names="frame")

    def set_state(self, sync_data):
        """State from the browser (ipywidgets calls it): a ``frame`` set there (a ``jsdlink`` from a Play
        widget) is already drawn, so the store takes it without sending it back."""
        self._browser_frame = "frame" in sync_data
        try:
            super().set_state(sync_data)
        finally:
            self._browser_frame = False

    @property
    def frame_from_browser(self) -> bool:
        """True while the kernel applies a ``frame`` the browser set on this view (a ``jsdlink`` from a Play
        widget). The Play's own message brings that frame to whatever follows the Play; an observer that moved
        the Play from here would write it back from the kernel, already out of date under load (its message
        arrives before the Play's: the browser saves a link's target inside the Play's change)."""
        return self._browser_frame

    def _frame_to_store(self, change) -> None:
        if self._browser_frame:
            self.store.set_state({"frame": change["new"]})   # the kernel's copy only (what a reload draws)
        else:
            self.store.frame = change["new"]

    def _frame_from_store(self, change) -> None:
        self.frame = change["new"]
