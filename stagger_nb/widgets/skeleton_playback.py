"""The playhead of a :class:`~stagger_nb.widgets.skeleton_view.SkeletonView` (a mixin of the view, one job: its
``frame`` trait and the Play / slider that drive it). The browser's clock plays at the clip's rate; the kernel hears
the Play's coarse ticks only, and its ``frame`` follows the Play when playback stops or the user scrubs (see the
view's module docstring, "Playback")."""
from __future__ import annotations

import ipywidgets as widgets
import numpy as np
import traitlets

from ._skeleton_parts import _TICK_S


class _Playback(traitlets.HasTraits):
    """The playback half of :class:`~stagger_nb.widgets.skeleton_view.SkeletonView` (its widgets and the ``frame``
    trait live in the view; a ``HasTraits`` so that traitlets registers the handlers below for the view)."""

    @staticmethod
    def _tick(frame_time: float):
        """Play step (frames) and interval (ms): ~_TICK_S per tick, an exact multiple of the frame time."""
        step = max(1, int(round(_TICK_S / frame_time)))
        return step, max(10, int(round(step * frame_time * 1000)))

    @property
    def playing(self) -> bool:
        return bool(self.player.playing)

    def link_frame(self, widget, trait: str = "frame"):
        """Make ``widget.<trait>`` follow the playhead browser-side (a jsdlink from the Play): plot playheads
        move while playing without a kernel round trip. Returns the link (``.unlink()`` to stop)."""
        return widgets.jsdlink((self.player, "value"), (widget, trait))

    @traitlets.validate("frame")
    def _valid_frame(self, proposal):
        return int(np.clip(proposal["value"], 0, self._motion.num_frames - 1))

    @traitlets.observe("frame")
    def _on_frame(self, change):
        if getattr(self, "_frame_from_browser", False):
            return   # the browser already shows it (and links the slider to the Play): writing back would race
            # the user's next key presses (the slider jumped back to an older frame, seen under load)
        with self.player.hold_sync(), self.frame_slider.hold_sync():
            if self.player.value != change["new"]:
                self.player.value = change["new"]   # a seek from Python: the browser shows that frame
            self.frame_slider.value = change["new"]   # (the browser links them; keep the kernel's copy in step)

    def _on_player_value(self, change):
        if not self.player.playing:            # a scrub; while playing the kernel does not follow per tick
            self._set_frame_from_browser(change["new"])

    def _on_playing(self, change):
        if not change["new"]:
            self._set_frame_from_browser(self.player.value)

    def _set_frame_from_browser(self, frame: int) -> None:
        self._frame_from_browser = True
        try:
            self.frame = frame
        finally:
            self._frame_from_browser = False
        if self.frame != frame:                 # clamped: the browser must show the clamped frame
            self.player.value = self.frame
