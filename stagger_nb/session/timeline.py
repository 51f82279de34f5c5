"""The dope sheet's numbers: every knot of the staggered poses, grouped by limb, and the ops a drag writes.

A staggered pose ``k`` has one knot per joint ``j`` at the refined time ``T[k, j] = t_k + r[k, j]`` (Coleman et
al. 2008, §3). Succession and random timing (§5.2) slide these knots along each joint's row; a drag of one knot
is the ``refine`` op, a drag of a pose's column the ``retime`` op. :func:`knot_table` reads them from a session's
last staggered state; :class:`KnotTable` checks a drag and gives the op (a plain sentence where it cannot
apply); the StaggerEditor's model records it (``StaggerModel.refine``: the binding puts refine ops after the
timing edits, before the contact layer). No widgets here (the view is
:class:`stagger_nb.widgets.timeline.Timeline`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.body import limb_groups

__all__ = ["KnotTable", "knot_table", "knot_table_of"]


@dataclass(frozen=True, eq=False)
class KnotTable:
    """Every knot of a staggered motion, for the dope sheet.

    Attributes
    ----------
    joints : tuple of str, the J joint names (rows)
    groups : tuple of (label, tuple of joint indices), the rows grouped by limb
        (:func:`~stagger_nb.core.body.limb_groups`)
    pose_times : ndarray, shape (K,), seconds, the staggered pose times ``t_k`` (columns)
    knots : ndarray, shape (K, J), seconds, the refined times ``t_k + r[k, j]``
    frame_time : float, seconds per frame of the shown motion (the playhead's unit)
    duration : float, seconds, the end of the time axis (the edited motion's last frame)
    """

    joints: tuple
    groups: tuple
    pose_times: np.ndarray
    knots: np.ndarray
    frame_time: float
    duration: float

    @property
    def num_poses(self) -> int:
        return int(self.pose_times.size)

    def _pose(self, pose) -> int:
        K = self.num_poses
        if isinstance(pose, bool) or not isinstance(pose, (int, np.integer)) or not 0 <= pose < K:
            raise ValueError(f"pose: expected a pose index in [0, {K}), got {pose!r}")
        return int(pose)

    def _joint(self, joint) -> int:
        if joint not in self.joints:
            raise ValueError(f"joint: no joint named {joint!r} in this skeleton")
        return self.joints.index(joint)

    def groups_of(self, joint) -> list:
        """Labels of the limb groups holding ``joint`` ([] for a name not in the table)."""
        if joint not in self.joints:
            return []
        j = self.joints.index(joint)
        return [label for label, js in self.groups if j in js]

    def same_as(self, other) -> bool:
        """Whether ``other`` (a KnotTable or None) draws the same sheet: same joints, pose times, knots and time
        axis (what a view needs to be sent again)."""
        return (isinstance(other, KnotTable) and other.joints == self.joints and other.duration == self.duration
                and np.array_equal(other.pose_times, self.pose_times) and np.array_equal(other.knots, self.knots))

    def knot_range(self, pose, joint) -> tuple[float, float]:
        """The open interval (seconds) joint ``joint``'s knot of pose ``pose`` may move in: between the same
        joint's knots of the neighbouring poses. An end pose's knots do not move: ValueError."""
        k, j = self._pose(pose), self._joint(joint)
        if k in (0, self.num_poses - 1):
            raise ValueError(f"pose {k} is the clip's {'first' if k == 0 else 'last'} frame: its knots stay at "
                             f"{self.pose_times[k]:.2f} s")
        return float(self.knots[k - 1, j]), float(self.knots[k + 1, j])

    def refine_op(self, pose, joint, time) -> dict:
        """The ``refine`` op that puts the knot at ``time`` seconds, or ValueError with a plain sentence where
        it would leave that joint's knots out of order (``staggered.refine`` refuses the same)."""
        lo, hi = self.knot_range(pose, joint)
        t = float(time)
        if not np.isfinite(t) or not lo < t < hi:
            raise ValueError(f"{joint}'s knot of pose {int(pose)} must stay between its neighbours' knots, "
                             f"{lo:.2f} s and {hi:.2f} s (it was dropped at {t:.2f} s)")
        return {"op": "refine", "pose": int(pose), "joint": str(joint), "time": t}

    def pose_range(self, pose) -> tuple[float, float]:
        """The open interval (seconds) pose ``pose``'s time may move in (between its neighbours); the end poses
        are the clip's ends: ValueError."""
        k = self._pose(pose)
        if k in (0, self.num_poses - 1):
            raise ValueError(f"pose {k} is the clip's {'first' if k == 0 else 'last'} frame: it stays at "
                             f"{self.pose_times[k]:.2f} s")
        return float(self.pose_times[k - 1]), float(self.pose_times[k + 1])

    def retime_time(self, pose, time) -> float:
        """``time`` when pose ``pose`` may be retimed there, else ValueError with a plain sentence."""
        lo, hi = self.pose_range(pose)
        t = float(time)
        if not np.isfinite(t) or not lo < t < hi:
            raise ValueError(f"pose {int(pose)} must stay between poses {int(pose) - 1} and {int(pose) + 1}, "
                             f"{lo:.2f} s and {hi:.2f} s (it was dropped at {t:.2f} s)")
        return t

    def to_json(self) -> dict:
        """What the view draws: plain lists (times rounded to 0.1 ms)."""
        r = lambda a: np.round(np.asarray(a, float), 4).tolist()   # noqa: E731
        return {"joints": list(self.joints), "groups": [[label, list(js)] for label, js in self.groups],
                "pose_times": r(self.pose_times), "knots": r(self.knots), "frame_time": float(self.frame_time),
                "duration": float(self.duration)}


_GROUPS: dict = {}   # limb groups by skeleton (a skeleton is frozen: computed once per rig)


def knot_table_of(sm, duration: float | None = None) -> KnotTable:
    """The knots of the staggered motion ``sm``; the time axis ends at ``duration`` seconds (default the last
    pose's time)."""
    sk = sm.skeleton
    key = (sk.names, sk.parents.tobytes())
    if key not in _GROUPS:
        _GROUPS[key] = tuple((label, tuple(js)) for label, js in limb_groups(sk))
    t = np.array(sm.pose_times, dtype=float)
    knots = t[:, None] + np.asarray(sm.refinements, dtype=float)
    for a in (t, knots):
        a.setflags(write=False)
    end = max(float(t[-1]), float(duration or 0.0))
    return KnotTable(joints=tuple(sk.names), groups=_GROUPS[key], pose_times=t, knots=knots,
                     frame_time=float(sm.frame_time), duration=end)


def knot_table(session) -> KnotTable:
    """The knots of ``session``'s last staggered state (``Session.staggered()``: the extraction of the source
    when no op is staggered). May replay the session (raises its ValueError when the replay fails)."""
    return knot_table_of(session.staggered(), session.edited().duration)
