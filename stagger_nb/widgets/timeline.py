"""The dope sheet of the staggered poses: :class:`Timeline`, one row per joint (grouped by limb, collapsible), a
mark at every knot ``t_k + r[k, j]`` (Coleman et al. 2008, §3), the pose times as columns, the playhead across.

Succession and random timing (§5.2) show as what they are: knots sliding along their rows away from the pose's
column. Dragging a knot asks for a ``refine`` op (that joint's knot of that pose at the dropped time); dragging a
pose's tab asks for a ``retime``; clicking a knot, a tab or a row label selects the pose and joint; clicking the
empty sheet seeks. The view only draws and asks: the numbers come from a
:class:`~stagger_nb.session.timeline.KnotTable` (``view.set_table(table)``), and what a request does is decided
by whoever registered ``on_refine`` / ``on_retime`` / ``on_select`` (the StaggerEditor: the session checks it and
either records the op or puts a plain sentence in ``view.message``).

As :class:`~stagger_nb.widgets.PlotView`, the state travels on a plain ipywidgets model (``view.store``), so a
view whose anywidget module loads late on a busy page still gets every update; ``frame`` also travels on the
view itself, so a browser-side ``jsdlink`` from a Play moves the playhead without the kernel.
"""
from __future__ import annotations

from collections.abc import Callable

import anywidget
import ipywidgets as widgets
import traitlets as t

from ._store_view import _FrameFromBrowser, store_view_esm

__all__ = ["Timeline", "TimelineState"]

_CSS = """
.sn-timeline { width: 100%; max-width: 100%; min-width: 0; box-sizing: border-box; }
.sn-timeline .sn-timeline-body { width: 100%; overflow-x: hidden; }
.sn-timeline .sn-timeline-message { color: #c53030; font: 12px sans-serif; padding: 2px 4px; display: none; }
"""


class TimelineState(widgets.Widget):
    """The synced state of one :class:`Timeline` (a data-only ipywidgets model the browser view reads)."""

    table = t.Dict(help="KnotTable.to_json(): joints, groups, pose_times, knots, frame_time, duration").tag(sync=True)
    frame = t.Int(0, min=0).tag(sync=True, echo_update=False)
    x_range = t.List(t.Float(), help="[lo, hi] seconds of the time axis ([] = the table's duration)").tag(sync=True)
    selected_pose = t.Int(-1).tag(sync=True)
    selected_joint = t.Unicode("").tag(sync=True)
    collapsed = t.List(t.Unicode(), help="labels of the closed limb groups").tag(sync=True)
    message = t.Unicode("", help="a plain sentence under the sheet (a refused drag)").tag(sync=True)
    region = t.List(t.Float(), help="the magic-wand region of the timing edits: a weight in [0, 1] per pose ([] none)"
                    ).tag(sync=True)


_MIRRORED = ("table", "x_range", "selected_pose", "selected_joint", "collapsed", "message", "region")


class Timeline(_FrameFromBrowser, anywidget.AnyWidget):
    """The dope sheet (CSS class ``sn-timeline``).

    Traits
    ------
    table : dict, :meth:`KnotTable.to_json <stagger_nb.session.timeline.KnotTable.to_json>` (set with
        :meth:`set_table`)
    frame : int >= 0, the playhead frame (a click on the empty sheet sets it)
    x_range : [lo, hi] seconds, the time axis ([] = 0 .. the table's duration)
    selected_pose : int (-1 none), selected_joint : str ('' none): drawn highlighted
    collapsed : list of limb-group labels drawn as one row; a click on a group's header toggles it
    message : str, shown under the sheet in red ('' hides it)
    region : list of K weights in [0, 1] ([] none): the region of a timing edit (``StaggerModel.region_weights``),
        drawn as a green mark under each pose's tab, as opaque as the pose's weight
    """

    _esm = store_view_esm("timeline.js")
    _css = _CSS
    store = t.Instance(TimelineState).tag(sync=True, **widgets.widget_serialization)
    frame = t.Int(0, min=0).tag(sync=True, echo_update=False)
    table = t.Dict()
    x_range = t.List(t.Float())
    selected_pose = t.Int(-1)
    selected_joint = t.Unicode("")
    collapsed = t.List(t.Unicode())
    message = t.Unicode("")
    region = t.List(t.Float())

    def __init__(self, table=None, **kwargs):
        if table is not None:
            kwargs["table"] = table if isinstance(table, dict) else table.to_json()
        own = {k: kwargs[k] for k in _MIRRORED + ("frame",) if k in kwargs}
        super().__init__(store=TimelineState(**own), **kwargs)
        store = self.store
        self._links = [t.link((self, k), (store, k)) for k in _MIRRORED]
        self._follow_store(store)
        self._callbacks: dict[str, list[Callable]] = {"refine": [], "retime": [], "select": []}
        store.on_msg(self._on_msg)

    def set_table(self, table) -> None:
        """Show a :class:`~stagger_nb.session.timeline.KnotTable` (or its ``to_json()`` dict); clears the message."""
        with self.hold_trait_notifications():
            self.table = table if isinstance(table, dict) else table.to_json()
            self.message = ""

    # -- requests from the browser (and from code: what a drag or a click does) ----------------------------------
    def on_refine(self, callback: Callable[[int, str, float], None]) -> None:
        """``callback(pose, joint, time)`` when a knot is dragged to ``time`` seconds."""
        self._callbacks["refine"].append(callback)

    def on_retime(self, callback: Callable[[int, float], None]) -> None:
        """``callback(pose, time)`` when a pose's tab is dragged to ``time`` seconds."""
        self._callbacks["retime"].append(callback)

    def on_select(self, callback: Callable[[int, str], None]) -> None:
        """``callback(pose, joint)`` when a knot, a pose's tab or a row label is clicked (joint '' for none)."""
        self._callbacks["select"].append(callback)

    def drag_knot(self, pose: int, joint: str, time: float) -> None:
        """What dropping joint ``joint``'s knot of pose ``pose`` at ``time`` seconds does."""
        for cb in list(self._callbacks["refine"]):
            cb(int(pose), str(joint), float(time))

    def drag_pose(self, pose: int, time: float) -> None:
        """What dropping pose ``pose``'s tab at ``time`` seconds does."""
        for cb in list(self._callbacks["retime"]):
            cb(int(pose), float(time))

    def select(self, pose: int, joint: str = "") -> None:
        """What a click on pose ``pose``'s knot of ``joint`` (or its tab, ``joint=''``) does."""
        for cb in list(self._callbacks["select"]):
            cb(int(pose), str(joint))

    def _on_msg(self, _widget, content, _buffers) -> None:
        if not isinstance(content, dict):
            return
        try:
            event = content.get("event")
            if event == "refine":
                self.drag_knot(int(content["pose"]), str(content["joint"]), float(content["time"]))
            elif event == "retime":
                self.drag_pose(int(content["pose"]), float(content["time"]))
            elif event == "select":
                self.select(int(content["pose"]), str(content.get("joint") or ""))
        except (KeyError, TypeError, ValueError) as e:   # a malformed message: say so under the sheet
            self.message = f"the dope sheet could not apply {content.get('event')!r}: {e}"

    def close(self):
        """Close the view's model and its store."""
        links, self._links = getattr(self, "_links", None), None
        if links is not None:
            for link in links:
                link.unlink()
            self.store.unobserve(self._frame_from_store, names="frame")
            self.store.close()
        super().close()
