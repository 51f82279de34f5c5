"""A pythreejs 3D view of a skeleton playing a motion, with an optional translucent "original" ghost.

Joint positions come from :func:`stagger_nb.core.forward_kinematics` once per motion (kernel side, an
``(F, J, 3)`` float32 array); a frame step streams only that frame's ``J * 3`` floats into the shared
``position`` BufferAttribute (bones and joints use the same attribute), never the whole clip.
"""
from __future__ import annotations

import ipywidgets as widgets
import numpy as np
import pythreejs as three
import traitlets

from ..core.kinematics import forward_kinematics
from ..core.motion import Motion

__all__ = ["SkeletonView"]

_BONE = "#2b6cb0"
_BONE_POSE = "#dd6b20"      # bone colour while the current frame is a staggered pose time
_GHOST = "#888888"
_JOINT = np.array([0.15, 0.15, 0.15], dtype=np.float32)
_JOINT_SELECTED = np.array([0.9, 0.1, 0.1], dtype=np.float32)
_JOINT_CONTACT = np.array([0.1, 0.7, 0.2], dtype=np.float32)


def _bone_index(parents: np.ndarray) -> np.ndarray:
    """Line-segment vertex pairs ``(2 * (J - 1),)`` uint32: (parent, child) for every non-root joint."""
    child = np.arange(1, len(parents))
    return np.stack([parents[1:], child], axis=1).astype(np.uint32).reshape(-1)


class SkeletonView(widgets.VBox):
    """3D view with a frame scrubber and play button.

    Parameters
    ----------
    motion : Motion
        The motion shown (usually the edited one); replace it with :meth:`set_motion`.
    ghost : Motion, optional
        Shown translucent beside/over ``motion`` (usually the original); same skeleton.
    width, height : int
        Canvas size in pixels.
    show_ghost : bool
        Start with the ghost shown (it doubles the floats sent per frame step: 2 * J * 3).
    ghost_offset : (3,) or None
        Where the ghost stands relative to the motion, in file units; default beside it (along x, by
        0.6 of the body's extent); ``(0, 0, 0)`` overlays the two.

    Traits
    ------
    frame : int
        Current frame index (0-based), linked to the scrubber and the ``Play`` widget.
    show_ghost : bool
    """

    frame = traitlets.Int(0, help="current frame index (0-based)")
    show_ghost = traitlets.Bool(True, help="show the translucent original")

    def __init__(self, motion: Motion, ghost: Motion | None = None, width: int = 480, height: int = 380,
                 ghost_offset=None, show_ghost: bool = True, **kwargs):
        if not isinstance(motion, Motion):
            raise ValueError(f"motion: expected a Motion, got {type(motion).__name__}")
        self._motion = motion
        self._pos = self._positions(motion)
        self._ghost_motion = ghost
        self._ghost_offset = None if ghost_offset is None else np.asarray(ghost_offset, dtype=np.float32).reshape(3)
        self._ghost_pos = None
        if ghost is not None:
            if self._ghost_offset is None:
                first = self._pos[0]
                body = float(np.max(first.max(axis=0) - first.min(axis=0)))
                self._ghost_offset = np.array([0.6 * body, 0.0, 0.0], dtype=np.float32)
            self._ghost_pos = self._positions(ghost) + self._ghost_offset
        self._selected: list[int] = []
        self._pose_frames = np.zeros(0, dtype=int)
        self._contacts: list = []
        self._contact_key = None
        J = motion.num_joints

        self._attr = three.BufferAttribute(array=self._pos[0], normalized=False)
        index = three.BufferAttribute(array=_bone_index(motion.skeleton.parents), normalized=False)
        self._colors = three.BufferAttribute(array=np.tile(_JOINT, (J, 1)), normalized=False)
        ext = self._extent()
        self._bone_material = three.LineBasicMaterial(color=_BONE, linewidth=2)
        self.bones = three.LineSegments(three.BufferGeometry(attributes={"position": self._attr}, index=index),
                                        self._bone_material, frustumCulled=False)
        self.joints = three.Points(three.BufferGeometry(attributes={"position": self._attr, "color": self._colors}),
                                   three.PointsMaterial(size=ext * 0.025, vertexColors="VertexColors",
                                                        sizeAttenuation=True),
                                   frustumCulled=False)
        children = [self.bones, self.joints]
        self.ghost_bones = None
        if ghost is not None:
            self._ghost_attr = three.BufferAttribute(array=self._ghost_pos[0], normalized=False)
            gindex = three.BufferAttribute(array=_bone_index(ghost.skeleton.parents), normalized=False)
            self.ghost_bones = three.LineSegments(
                three.BufferGeometry(attributes={"position": self._ghost_attr}, index=gindex),
                three.LineBasicMaterial(color=_GHOST, transparent=True, opacity=0.45, linewidth=2),
                frustumCulled=False)
            children.append(self.ghost_bones)

        lo, hi = self._bounds()
        center = (lo + hi) / 2
        self.grid = three.GridHelper(size=float(np.ceil(ext * 2.0)), divisions=20,
                                     colorCenterLine="#999999", colorGrid="#dddddd",
                                     position=(float(center[0]), float(lo[1]), float(center[2])))
        self.camera = three.PerspectiveCamera(
            position=tuple(float(x) for x in center + np.array([0.9, 0.5, 1.6]) * ext),
            up=(0, 1, 0), fov=45, aspect=width / height, near=ext * 0.01, far=ext * 100)
        self.controls = three.OrbitControls(controlling=self.camera, target=tuple(float(x) for x in center))
        self.camera.lookAt(tuple(float(x) for x in center))
        self.scene = three.Scene(children=children + [self.grid, three.AmbientLight(intensity=0.8),
                                                      three.DirectionalLight(position=(3, 5, 1), intensity=0.4)],
                                 background="#ffffff")
        self.renderer = three.Renderer(camera=self.camera, scene=self.scene, controls=[self.controls],
                                       width=width, height=height, antialias=True)

        F = motion.num_frames
        self.slider = widgets.IntSlider(value=0, min=0, max=F - 1, description="frame",
                                        continuous_update=True, layout=widgets.Layout(width="360px"))
        self.play = widgets.Play(value=0, min=0, max=F - 1, step=1,
                                 interval=max(10, int(round(motion.frame_time * 1000))), description="play")
        self._links = [traitlets.link((self.play, "value"), (self.slider, "value")),
                       traitlets.link((self.slider, "value"), (self, "frame"))]
        self.ghost_toggle = widgets.Checkbox(value=ghost is not None, description="original (ghost)",
                                             indent=False, disabled=ghost is None)
        traitlets.link((self.ghost_toggle, "value"), (self, "show_ghost"))
        super().__init__([self.renderer, widgets.HBox([self.play, self.slider, self.ghost_toggle])], **kwargs)
        self.show_ghost = ghost is not None and bool(show_ghost)
        self.ghost_toggle.value = self.show_ghost

    # -- geometry ----------------------------------------------------------------------------------
    @staticmethod
    def _positions(motion: Motion) -> np.ndarray:
        p, _ = forward_kinematics(motion)
        return np.ascontiguousarray(p, dtype=np.float32)

    def _bounds(self):
        pts = self._pos.reshape(-1, 3)
        if self._ghost_pos is not None:
            pts = np.concatenate([pts, self._ghost_pos.reshape(-1, 3)])
        return pts.min(axis=0), pts.max(axis=0)

    def _extent(self) -> float:
        lo, hi = self._bounds()
        first = self._pos[0]
        body = float(np.max(first.max(axis=0) - first.min(axis=0)))
        return max(body, float(np.max(hi - lo)) * 0.5, 1e-6)

    # -- public ------------------------------------------------------------------------------------
    @property
    def motion(self) -> Motion:
        return self._motion

    @property
    def positions(self) -> np.ndarray:
        """World joint positions of the shown motion, shape (F, J, 3), float32 (read-only view)."""
        v = self._pos.view()
        v.setflags(write=False)
        return v

    def set_motion(self, motion: Motion, ghost: Motion | None = None) -> None:
        """Show another motion of the same skeleton (e.g. a new edit); streams only the current frame.
        The frame is clamped to the new length; the camera stays where the user put it."""
        if motion.num_joints != self._motion.num_joints:
            raise ValueError(f"motion: has {motion.num_joints} joints, the view shows {self._motion.num_joints}")
        self._motion = motion
        self._pos = self._positions(motion)
        if ghost is not None and self.ghost_bones is not None:
            self._ghost_motion, self._ghost_pos = ghost, self._positions(ghost) + self._ghost_offset
        F = motion.num_frames
        with self.hold_trait_notifications():
            if self.frame > F - 1:
                self.frame = F - 1
            self.slider.max = F - 1
            self.play.max = F - 1
        self._show(self.frame, force=True)

    def highlight_joints(self, names) -> None:
        """Colour these joints (names or indices) red; sends J * 3 floats once, not per frame."""
        sk = self._motion.skeleton
        self._selected = [sk.index(n) if isinstance(n, str) else int(n) for n in (names or [])]
        self._contact_key = None
        self._update_colors(self.frame)

    def set_pose_frames(self, frames) -> None:
        """Frames (indices) of staggered poses: the bones turn orange while the view is on one."""
        self._pose_frames = np.unique(np.asarray(frames, dtype=int).reshape(-1))
        self._update_pose_colour(self.frame)

    def set_contacts(self, contacts) -> None:
        """``[(joint_name, start_frame, end_frame), ...]`` (half-open): those joints turn green
        while in contact; colours are re-sent only when the set of joints in contact changes."""
        sk = self._motion.skeleton
        self._contacts = [(sk.index(n) if isinstance(n, str) else int(n), int(a), int(b)) for n, a, b in contacts]
        self._contact_key = None
        self._update_colors(self.frame)

    # -- frame streaming ---------------------------------------------------------------------------
    @traitlets.observe("frame")
    def _on_frame(self, change):
        self._show(change["new"])

    @traitlets.validate("frame")
    def _valid_frame(self, proposal):
        return int(np.clip(proposal["value"], 0, self._motion.num_frames - 1))

    @traitlets.observe("show_ghost")
    def _on_ghost(self, change):
        if self.ghost_bones is not None:
            self.ghost_bones.visible = bool(change["new"])
            if change["new"]:
                self._show(self.frame, force=True)

    def _show(self, f: int, force: bool = False) -> None:
        self._attr.array = self._pos[f]
        if self.ghost_bones is not None and self.show_ghost:
            self._ghost_attr.array = self._ghost_pos[min(f, len(self._ghost_pos) - 1)]
        self._update_colors(f)
        self._update_pose_colour(f)

    def _update_colors(self, f: int) -> None:
        in_contact = tuple(sorted({j for j, a, b in self._contacts if a <= f < b}))
        key = (tuple(self._selected), in_contact)
        if key == self._contact_key:
            return
        self._contact_key = key
        c = np.tile(_JOINT, (self._motion.num_joints, 1))
        c[list(in_contact)] = _JOINT_CONTACT
        c[self._selected] = _JOINT_SELECTED
        self._colors.array = c

    def _update_pose_colour(self, f: int) -> None:
        on_pose = self._pose_frames.size and np.any(self._pose_frames == f)
        colour = _BONE_POSE if on_pose else _BONE
        if self._bone_material.color != colour:
            self._bone_material.color = colour
