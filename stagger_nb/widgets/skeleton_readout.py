"""What a :class:`~stagger_nb.widgets.skeleton_view.SkeletonView` shows, read back (a mixin of the view, one job:
answering where a joint is drawn, how tall the figure is on the canvas, what was sent to the browser, what is
highlighted and how many widget models the view is made of). Every number comes from :mod:`stagger_nb.scene3d` or
from the buffers the view sent; nothing is computed here that the view does not draw."""
from __future__ import annotations

import ipywidgets as widgets
import numpy as np

from .. import scene3d


class _Readout:
    """The read-back half of :class:`~stagger_nb.widgets.skeleton_view.SkeletonView` (its state lives in the view)."""

    @property
    def positions(self) -> np.ndarray:
        """World joint positions of the shown motion, shape (F, J, 3), float32 (read-only view)."""
        v = self._points[:, :self._motion.num_joints]
        v.setflags(write=False)
        return v

    @property
    def camera_framing(self) -> scene3d.Camera:
        """The framing sent to the browser (rig path, camera position/target relative to the rig)."""
        return self._camera

    def joint_pixel(self, joint, frame: int | None = None) -> tuple[float, float]:
        """Canvas pixel (x, y) where ``joint`` (name or index) is drawn at ``frame`` (default: the current one),
        for the camera as framed (before the user orbits)."""
        j = self._motion.skeleton.index(joint) if isinstance(joint, str) else int(joint)
        f = self.frame if frame is None else int(frame)
        eye, target = self._camera.world(f)
        px = scene3d.project(self._points[f, j][None], eye, target, self._camera.fov, self.width, self.height)
        return float(px[0, 0]), float(px[0, 1])

    def drawn_height(self, frame: int | None = None) -> float:
        """The character's drawn height at ``frame`` as a fraction of the canvas height (framed camera)."""
        f = self.frame if frame is None else int(frame)
        return scene3d.drawn_height_fraction(self._points[f], self._camera, f, self.width, self.height)

    @property
    def pose_frames(self) -> np.ndarray:
        """Frames of the staggered poses highlighted, (K,) int."""
        return self._pose_frames.copy()

    @property
    def contacts(self) -> list:
        """Contacts highlighted, ``[(joint_name, start_frame, end_frame), ...]`` (half-open)."""
        return [(self._names[j], a, b) for j, a, b in self._contacts]

    def shown_positions(self, frame: int | None = None) -> np.ndarray:
        """World joint positions ``(J, 3)`` at ``frame`` (default: the current one) decoded from the buffer sent to
        the browser (``conductor.points``, float32), from which the browser builds the mesh."""
        f = self.frame if frame is None else int(frame)
        c = self.conductor
        pts = np.frombuffer(c.points, dtype=np.float32).reshape(c.num_frames, c.num_points, 3)
        return pts[f, :c.num_joints].astype(float)

    @property
    def widget_count(self) -> int:
        """How many widget models this view is made of (it and every widget it references, recursively)."""
        return len(_reachable(self))


def _reachable(root) -> set:
    """Model ids of ``root`` and of every widget its synced traits reference (recursively)."""
    seen, todo = {}, [root]
    while todo:
        w = todo.pop()
        if not isinstance(w, widgets.Widget) or w.model_id in seen:
            continue
        seen[w.model_id] = w
        for name in w.keys:
            v = getattr(w, name, None)
            vals = v.values() if isinstance(v, dict) else v if isinstance(v, (list, tuple)) else [v]
            todo.extend(x for x in vals if isinstance(x, widgets.Widget))
    return set(seen)
