"""The one playhead of an editor and what an edit sends to the views: ``model.frame`` moved by a plot's click or
a picked joint, the 3D view fed the shown frame at once and the whole clip once edits rest, the quality line asked
for once a drag rests. A mixin of :class:`._editor._Editor`."""
from __future__ import annotations

import weakref

from ..core.motion import Motion
from ..session.models import plain_message
from ._lifecycle import _on_kernel_loop_later, _weakly


class _Playhead:
    """The shared playhead and the rested sends of an editor."""

    def _quality_later(self, delay: float = 0.5) -> None:
        """Ask the binding for the edit's quality line ``delay`` s after the last edit (on the kernel's loop,
        once a drag rests: its ~55 ms CPU on a 2,751-frame clip is not added to each slider move, nor to key
        presses a few tenths of a second apart); at once outside a kernel. One pending at a time, as every
        :meth:`_later` job (an error is shown in the message line)."""
        self._later("quality", _weakly(self.binding.show_quality), delay)

    def _plot_seeks(self, change) -> None:
        """A plot's frame moves the playhead, unless the browser set it through the Play's jsdlink: the Play's
        own message then moves it, and the Play, the slider and the kernel agree on one frame."""
        if not change["owner"].frame_from_browser:
            self.model.frame = change["new"]

    def _on_picked(self, change) -> None:
        """Clicking a joint in the 3D view selects it in the editor."""
        if change["new"] and change["new"] in self.model.joint_names:
            self.model.joint = change["new"]

    #: seconds an edit rests before the work a user does not see at once runs (the whole clip's points for the
    #: 3D view, the dope sheet): a drag sends the plot and the 3D view's shown frame for every value the kernel
    #: takes, and the rest once, when it pauses
    _REST_S = 0.05

    def _later(self, key: str, fn, delay: float | None = None) -> None:
        """``fn()`` on the kernel's loop once edits have rested ``delay`` s (default ``_REST_S``), replacing the
        one pending under ``key``; at once outside a kernel (scripts, tests)."""
        pending = self.__dict__.setdefault("_pending", {})
        handle = pending.pop(key, None)
        if handle is not None:
            handle.cancel()
        me = weakref.ref(self)

        def run():
            ed = me()
            if ed is not None and ed._finalizer.alive:
                ed._pending.pop(key, None)
                try:
                    fn()
                except Exception as e:   # never raised into the kernel's loop: shown as a replay error is
                    ed.error = plain_message(e)
                    ed._show_message()
        h = _on_kernel_loop_later(self._REST_S if delay is None else delay, run)
        if h is not None:
            pending[key] = h

    def _show_motion(self, edited: Motion, pose_frames=None, contacts=None) -> None:
        """Send the edited motion to the 3D view once per edit (not again for a view-only change); the pose
        frames and contacts only when they changed (each is a set of highlight tracks to rebuild). In a kernel
        the shown frame goes at once (``SkeletonView.preview``: a few hundred bytes) and the whole clip once the
        edit rests (:meth:`_later`: a drag does not send megabytes per value)."""
        pf = None if pose_frames is None else tuple(int(f) for f in pose_frames)
        ct = None if contacts is None else tuple(tuple(c) for c in contacts)
        last = getattr(self, "_shown", (None, None))   # the highlights last sent (the motion: view.motion)
        pf_new = pf if pf is not None and pf != last[0] else None
        ct_new = ct if ct is not None and ct != last[1] else None
        self.model.num_frames = edited.num_frames   # the playhead's range (a longer frame is refused)
        pending = self.__dict__.get("_pending", {}).pop("motion", None) if self.view.motion is edited else None
        if pending is not None:   # back to what is shown before an edit on its way was sent: not sent
            pending.cancel()
        if self.view.motion is edited and pf_new is None and ct_new is None:
            return
        self._shown = (pf if pf is not None else last[0], ct if ct is not None else last[1])
        if self.view.motion is edited:   # only the highlights changed
            if pf_new is not None:
                self.view.set_pose_frames(pf_new)
            if ct_new is not None:
                self.view.set_contacts(ct_new)
            return
        if hasattr(self.view, "preview") and not self.view.playing:
            self.view.preview(edited)
        pfs, cts = self._shown
        self._later("motion", lambda: self.view.set_motion(edited, pose_frames=pfs, contacts=cts))

    def seek(self, frame: int) -> None:
        """Move the playhead (what a click on a plot does)."""
        self.model.frame = max(0, int(frame))
