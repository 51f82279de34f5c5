"""The StaggerEditor's dope sheet (:class:`.timeline.Timeline`): it follows the selected pose and joint, the
playhead and the timing region; its knot drags refine, its tab drags retime, its clicks select, each through the
model (a refused drag says why under the sheet). A mixin of :class:`.stagger_editor.StaggerEditor`."""
from __future__ import annotations

import traitlets

from ..core.motion import Motion
from ..session.models import plain_message
from ..session.timeline import knot_table_of
from ._sizes import _x_span


class _DopeSheet:
    """The dope sheet's binding and drawing (``self.timeline``, the knots it shows in ``self._knots``)."""

    def _bind_timeline(self) -> None:
        """The dope sheet follows the selected pose and joint, the playhead and the timing region; its drags and
        clicks go to the model (a refused drag says why under the sheet)."""
        t, m = self.timeline, self.model
        self._links += [traitlets.dlink((m, "pose"), (t, "selected_pose")),
                        traitlets.dlink((m, "joint"), (t, "selected_joint")),
                        traitlets.dlink((m, "frame"), (t, "frame"))]
        self._js_links.append(self.view.link_frame(t, "frame"))   # browser playback moves its playhead too
        t.observe(self._timeline_seeks, names="frame")
        m.observe(self._open_joint_group, names="joint")
        t.on_refine(self._on_refine)
        t.on_retime(self._on_retime)
        t.on_select(self._on_timeline_select)
        self._show_region()

    def _timeline_seeks(self, change) -> None:
        if not self.timeline.frame_from_browser:
            self.model.frame = change["new"]

    def _open_joint_group(self, change=None) -> None:
        """Every limb group closed but the selected joint's (the sheet stays a few rows tall); after the first
        time, the user's choice with the selected joint's group opened."""
        if self._knots is None:
            return
        mine = self._knots.groups_of(self.model.joint)
        if getattr(self, "_groups_set", False):
            self.timeline.collapsed = [g for g in self.timeline.collapsed if g not in mine]
        else:
            self.timeline.collapsed = [label for label, _ in self._knots.groups if label not in mine]
            self._groups_set = True

    def _on_refine(self, pose: int, joint: str, time: float) -> None:
        """A knot dropped at ``time``: the model's refine op when the knot stays between its neighbours, else the
        plain sentence under the sheet (nothing recorded)."""
        if self._knots is None:
            return
        try:
            op = self._knots.refine_op(pose, joint, self.model.snap_time(time))
            self.model.joint = joint
            self.model.refine(op["pose"], op["joint"], op["time"])
        except (ValueError, traitlets.TraitError) as e:
            self.timeline.message = plain_message(e)

    def _on_retime(self, pose: int, time: float) -> None:
        """A pose's tab dropped at ``time``: the pose retimed (the model's retime op), else a sentence."""
        if self._knots is None:
            return
        try:
            t = self._knots.retime_time(pose, self.model.snap_time(time))
            self.model.pose = pose
            self.model.pose_time = t
        except (ValueError, traitlets.TraitError) as e:
            self.timeline.message = plain_message(e)

    def _on_timeline_select(self, pose: int, joint: str) -> None:
        try:
            if 0 <= pose < len(self.model.pose_times):
                self.model.pose = pose
            if joint:
                self.model.joint = joint
        except traitlets.TraitError as e:
            self.timeline.message = plain_message(e)

    def _draw_timeline(self, edited: Motion, sm) -> None:
        """The dope sheet of ``sm``: sent again only when the knots (or the axis) changed (an exaggeration or a
        pose edit leaves them: nothing is sent)."""
        last = self._knots
        self._knots = knots = knot_table_of(sm, edited.duration)
        self.timeline.x_range = [float(x) for x in _x_span(edited)]
        if not knots.same_as(last):
            self.timeline.set_table(knots)
        else:
            self.timeline.message = ""
        self._open_joint_group()

    def _show_region(self, change=None) -> None:
        """The timing edits' region (``model.region_weights``, a weight per pose) on the dope sheet, when the editor
        has one (``editor.timeline``); the pose-probability plot draws it too."""
        timeline = self.__dict__.get("timeline")
        if timeline is not None and hasattr(timeline, "region"):
            timeline.region = [float(w) for w in self.model.region_weights]
