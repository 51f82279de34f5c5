"""What the StaggerEditor's model reads off its current poses, with no session and no edit: the frame of a pose,
the times a pose may be retimed into (Fig. 6c), a time rounded as the pose-time control rounds it, the extracted
pose nearest a click (§4.3), and why a pose cannot be inserted at a time (§5.1). A mixin of
:class:`.stagger.StaggerModel` (it reads ``pose_times``, ``candidate_times``, ``frame_time``, ``frame``)."""
from __future__ import annotations

from ..ops import Retime, limits
from ._base import snap


class _PoseReadouts:
    """Read-only answers about the model's current poses (nothing set, nothing recorded)."""

    def pose_time_range(self, k: int | None = None) -> tuple:
        """``(lo, hi)`` seconds pose ``k`` (default: the selected pose) may be retimed to: strictly between the
        poses beside it as they are now; the first pose from 0 s, the last up to the source's end."""
        k = self.pose if k is None else int(k)
        t = self.pose_times
        lo = t[k - 1] if k > 0 else limits(Retime, "time")[0]
        hi = t[k + 1] if k + 1 < len(t) else max(self.source_duration, t[k]) if self.source_duration else t[k]
        return float(lo), float(hi)

    def snap_time(self, time: float) -> float:
        """``time`` seconds rounded as the pose-time control rounds it (one decimal finer than a frame)."""
        return snap(float(time), self.step("pose_time"))

    def pose_frame(self, k: int) -> int:
        """Frame of pose ``k`` (nearest to its time)."""
        return int(round(self.pose_times[k] / self.frame_time))

    def insert_refusal(self, time: float | None = None) -> str:
        """Why a pose cannot be inserted at ``time`` seconds (default: the playhead), in one plain sentence with
        rounded numbers, or "" when it can: a new pose goes strictly between two poses (§5.1), so not on a pose
        (to 1e-6 s) nor before the first or after the last."""
        t = self.frame * self.frame_time if time is None else float(time)
        pt = self.pose_times
        where = "the playhead" if time is None else f"{t:.2f} s"
        fix = "move it between two poses to insert one" if time is None else "choose a time between two poses"
        if not pt:   # not known yet (before the extraction): the replay judges
            return ""
        if len(pt) == 1:
            return "there is one pose: a pose is inserted between two"
        on = [k for k, x in enumerate(pt) if abs(x - t) <= 1e-6]
        if on:
            return f"{where} is on pose {on[0]} ({pt[on[0]]:.2f} s): {fix}"
        if t < pt[0]:
            return f"{where} is before the first pose ({pt[0]:.2f} s): {fix}"
        if t > pt[-1]:
            return f"{where} is after the last pose ({pt[-1]:.2f} s): {fix}"
        return ""

    def pose_frames(self) -> list:
        """The frame of each current pose (nearest to its time): where the 3D view marks the poses."""
        return [self.pose_frame(k) for k in range(len(self.pose_times))]

    def candidate_near(self, time: float) -> int | None:
        """Index of the extracted pose nearest to ``time`` seconds (None before the extraction is known)."""
        t = self.candidate_times
        return min(range(len(t)), key=lambda k: abs(t[k] - float(time))) if t else None
