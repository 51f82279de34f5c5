"""A pythreejs 3D view of a skeleton that plays in the browser.

The whole skeleton is ONE indexed triangle mesh (a sphere per joint, an open tube per bone; per-vertex colours),
its original (the ghost) a second one built only when first shown, the trails one LineSegments + Points, the
ground one LineSegments: about 45 widget models per view (one pythreejs model per bone, joint, material and
keyframe track would be ~280, ~1,200 per notebook, which JupyterLab restores on a page reload slowly enough to
give up on some: ipywidgets #4026/#4040). The world points of every frame (joints then
End Sites, :func:`stagger_nb.scene3d.skeleton_points`, float32) go to the browser once per edit as one binary
buffer on a small anywidget clock (``_conductor.js``), with the per-frame joint states (pose / contact colours)
and the camera rig path; the clock builds the mesh's vertices for each shown frame (``_skeleton_mesh.js``: the
only builder of the mesh, also the exported page's). The kernel holds the mesh's constant parts only (the
index, the spheres' normals, the bones' colours), sent once when the view is made, never per edit.

What the clock relies on in pythreejs 2.4.2 (hence the pin), and why: it writes into the three.js objects of
the view's pythreejs models in the browser, through three things that are not pythreejs's Python API:

1. ``ThreeModel.obj``, the three.js object a pythreejs model holds, reached with
   ``widget_manager.get_model(id)`` once the model's ``initPromise`` has resolved. It is declared in the
   package's type definitions for extension authors (``obj``, ``initPromise``) and is what pythreejs itself
   uses to resolve an ``IPY_MODEL_`` argument of ``exec_three_obj_method``.
2. three.js r97 (the version pythreejs bundles) on those objects: ``BufferGeometry.addAttribute`` of the
   clock's own copy of an attribute, ``needsUpdate``, ``computeBoundingSphere``, ``Object3D.position``.
3. The ``"rerender"`` event triggered on the Scene model: the event the pythreejs ``RendererView`` listens to
   for re-rendering after a change of the scene.

No public way does the job: the public routes all go through the kernel (setting ``BufferAttribute.array``,
what pythreejs's maintainer advises for animating a geometry in pythreejs issues #255 and #292, or calling
``exec_three_obj_method`` from Python is one kernel round trip and ~0.1 MB per shown frame of a
31-joint rig, so playback would stop whenever the kernel is busy and could not keep a 120 Hz clip's rate),
``jslink`` can drive a trait from a Play but no trait maps a frame index to vertex arrays, pythreejs's keyframe
animation needs one Object3D model per bone and per track (~280 models, which JupyterLab restores too slowly
after a page reload), and the documented extension point (a ``Blackbox`` subclass) needs a JavaScript package built
against ``jupyter-threejs``, which an anywidget module cannot import. pythreejs has had no release since 2023;
a new one must be checked against ``tests/test_skeleton_view_js.py`` (the clock run in node against stand-in
models) and the browser tests before the pin moves.

Playback: the clock sets the shown frame from ``performance.now()`` while the ipywidgets ``Play`` runs, and
from the Play's value when it is stopped. So Play runs at the clip's real rate with the kernel busy, and the
kernel hears only the Play's coarse ticks (every ~100 ms, not echoed back). ``view.frame`` follows the Play when
playback stops or the user scrubs; while playing it holds still, so nothing kernel-side (plots linked to the
editor's model) sends per-frame messages. Plots follow browser-side with :meth:`SkeletonView.link_frame`.

Drawn: bones coloured by body side, joints dark (orange at a staggered pose's frame, green in contact, red and
larger when selected), a grid ground, a camera on a rig that follows the root (``camera="follow"``) or frames
everything (``camera="all"``) with orbit controls, the original as a translucent ghost, motion trails of
``trail_joints`` over a window around the playhead; clicking a joint or bone (pythreejs Picker) selects it.
"""
from __future__ import annotations

import ipywidgets as widgets
import numpy as np
import pythreejs as three
import traitlets

from .. import scene3d
from ..core.motion import Motion
from ._skeleton_parts import (
    _PALETTE,
    _TEMPLATE,
    MESH_JS,  # noqa: F401 (widgets/export.py reads it here)
    _attr,
    _Conductor,
    _FramePlay,
    _FrameSlider,
)
from .skeleton_playback import _Playback
from .skeleton_readout import _Readout
from .skeleton_scene import _SceneSender

__all__ = ["SkeletonView"]


class SkeletonView(_SceneSender, _Playback, _Readout, widgets.VBox):
    """3D view with a Play button, a frame slider (CSS class ``sn-frame``) and a legend.

    Parameters
    ----------
    motion : Motion
        The motion shown (usually the edited one); replace it with :meth:`set_motion`.
    ghost : Motion, optional
        The original, drawn translucent (same skeleton) when ``show_ghost``; sent to the browser only once shown.
    width, height : int
        Canvas size in pixels.
    show_ghost : bool
    ghost_offset : (3,) or None
        Where the ghost stands relative to the motion, file units; default ``(0, 0, 0)`` (overlaid).
    camera : "follow" | "all"
    trail_joints : list of joint names
    trail_seconds : float
        Half-width of the trail window around the playhead, seconds.

    Traits
    ------
    frame : int — the playhead (0-based); follows the Play when it stops and when the user scrubs.
    selected_joint : str — the picked joint ('' for none); clicking a joint sets it.
    trail_joints : list[str]; camera : "follow" | "all"; show_ghost : bool
    """

    frame = traitlets.Int(0, help="current frame index (0-based)")
    selected_joint = traitlets.Unicode("", help="name of the selected (picked) joint, '' for none")
    trail_joints = traitlets.List(traitlets.Unicode(), help="joints whose motion trails are drawn")
    camera = traitlets.Enum(("follow", "all"), "follow", help="follow the root, or frame the whole clip")
    # the ghost checkbox says why it is greyed out (a control that does nothing must say why)
    _GHOST_TIP = {False: "show the original motion as a translucent ghost",
                  True: "no original to show: pass ghost=<Motion> (the editors pass the unedited clip)"}
    show_ghost = traitlets.Bool(False, help="show the translucent original")
    pose_label = traitlets.Unicode("staggered pose", help="the legend's word for the marked frames' joints")

    def __init__(self, motion: Motion, ghost: Motion | None = None, width: int = 480, height: int = 380,
                 ghost_offset=None, show_ghost: bool = True, camera: str = "follow", trail_joints=(),
                 trail_seconds: float = 0.6, pose_label: str = "staggered pose", **kwargs):
        if not isinstance(motion, Motion):
            raise ValueError(f"motion: expected a Motion, got {type(motion).__name__}")
        if ghost is not None and ghost.num_joints != motion.num_joints:
            raise ValueError(f"ghost: has {ghost.num_joints} joints, the motion {motion.num_joints}")
        self.width, self.height = int(width), int(height)
        self.trail_seconds = float(trail_seconds)
        self.pose_label = str(pose_label)
        self._motion = motion
        self._points = scene3d.skeleton_points(motion)
        self._ghost_motion = ghost
        self._ghost_points = None          # computed (and sent) once the ghost is first shown
        self._ghost_offset = np.zeros(3) if ghost_offset is None else np.asarray(ghost_offset, float).reshape(3)
        self._pose_frames = np.zeros(0, dtype=int)
        self._contacts: list = []
        self._selected: list[int] = []
        self.edit_bytes = 0
        sk = motion.skeleton
        self._names = list(sk.names)
        J = sk.num_joints
        self._radius = radius = scene3d.joint_radius(motion)
        self._size = scene3d.body_size(self._points[:, :J])

        # -- the merged skeleton mesh -------------------------------------------------------------------
        self._segs = scene3d.segments(motion)
        index = scene3d.mesh_index(J, len(self._segs), _TEMPLATE)
        vs = len(_TEMPLATE.sphere)
        self._tri_joint = scene3d.triangle_joints(J, self._segs, _TEMPLATE)
        self._bone_colours = scene3d.bone_colours(motion, self._segs)
        pos, nrm, col = self._constant_arrays()
        self._index = _attr(index.reshape(-1))
        self.skeleton_mesh = three.Mesh(
            three.BufferGeometry(attributes={"position": _attr(pos), "normal": _attr(nrm), "color": _attr(col)},
                                 index=self._index),
            three.MeshLambertMaterial(vertexColors="VertexColors"), name="skeleton", frustumCulled=False)
        self.ghost_mesh = None             # built when the ghost is first shown

        # -- ground, lights, camera rig ----------------------------------------------------------------------
        self.grid = None   # the ground segments (a LineSegments), once the camera is known
        # the camera stays put and the world moves under it: a "rig" group holding everything drawn is shifted by
        # minus the follow path (browser-side, per frame), so orbit controls and picking work in scene coordinates
        self.three_camera = three.PerspectiveCamera(fov=40, aspect=width / height, up=(0, 1, 0))
        # no arrow-key panning: three's OrbitControls listens to keys on the whole window, so moving any slider
        # with the keyboard panned every 3D view on the page (and the panned camera was saved with the notebook)
        self.controls = three.OrbitControls(controlling=self.three_camera, enableKeys=False)
        self.picker = three.Picker(controlling=self.skeleton_mesh, event="click")
        self.picker.observe(self._on_pick, names=["point", "faceIndex"])
        self.trails_group = three.Group(name="trails")
        self.rig = three.Group(name="rig", children=[self.skeleton_mesh, self.trails_group])
        self.scene = three.Scene(children=[self.rig, three.HemisphereLight(color="#ffffff", groundColor="#a0aec0",
                                                                           intensity=1.1)],
                                 background="#ffffff")
        self.renderer = three.Renderer(camera=self.three_camera, scene=self.scene,
                                       controls=[self.controls, self.picker], width=width, height=height,
                                       antialias=True, layout=widgets.Layout(width=f"{width}px",
                                                                             height=f"{height}px"))
        # one Layout model for the plain controls of this view (each widget would otherwise create its own: fewer
        # models for JupyterLab to restore on a page reload)
        plain = widgets.Layout()

        # -- playback widgets ---------------------------------------------------------------------------
        F = motion.num_frames
        step, interval = self._tick(motion.frame_time)
        self.player = _FramePlay(value=0, min=0, max=F - 1, step=step, interval=interval, description="play",
                                 show_repeat=False, layout=plain)
        self.frame_slider = _FrameSlider(value=0, min=0, max=F - 1, description="frame", continuous_update=True,
                                         layout=widgets.Layout(width="300px"))
        self.frame_slider.add_class("sn-frame")
        self.player.add_class("sn-play")
        self._frame_link = widgets.jslink((self.player, "value"), (self.frame_slider, "value"))
        self.player.observe(self._on_player_value, names="value")
        self.player.observe(self._on_playing, names="playing")
        self.play, self.slider = self.player, self.frame_slider   # older names
        self.conductor = _Conductor(
            player=self.player, scene=self.scene, rig=self.rig, skeleton=self.skeleton_mesh,
            num_joints=J, num_points=self._points.shape[1], segments=[int(i) for i in self._segs.reshape(-1)],
            template=np.concatenate([_TEMPLATE.sphere, _TEMPLATE.tube]).astype(np.float32).tobytes(),
            sphere_vertices=vs, tube_vertices=len(_TEMPLATE.tube), joint_radius=radius,
            bone_radius=radius * 0.45, palette=_PALETTE, frame_time=motion.frame_time, layout=plain)

        self.camera_toggle = widgets.ToggleButtons(options=[("follow", "follow"), ("frame all", "all")],
                                                   value=camera, style={"button_width": "84px"},
                                                   tooltips=["camera follows the character", "frame the whole clip"],
                                                   layout=plain)
        self.ghost_toggle = widgets.Checkbox(value=False, description="original (ghost)", indent=False,
                                             disabled=ghost is None, layout=widgets.Layout(width="130px"),
                                             tooltip=self._GHOST_TIP[ghost is None])
        self.legend = widgets.HTML(layout=widgets.Layout(margin="0 0 0 4px"))
        self.legend.add_class("sn-legend")
        super().__init__([self.renderer,
                          widgets.HBox([self.player, self.frame_slider], layout=plain),
                          widgets.HBox([self.camera_toggle, self.ghost_toggle], layout=plain),
                          self.legend, self.conductor], **kwargs)
        self.add_class("sn-skeleton-view")
        # as wide as its canvas (the legend wraps under it), so a tool column fits beside it
        self.layout.width = f"{width + 4}px"
        self.layout.flex = "0 0 auto"
        widgets.link((self.camera_toggle, "value"), (self, "camera"))
        widgets.link((self.ghost_toggle, "value"), (self, "show_ghost"))
        self._push_motion(motion)
        self.show_ghost = ghost is not None and bool(show_ghost)
        self.trail_joints = list(trail_joints)

    # -- public ------------------------------------------------------------------------------------------
    @property
    def motion(self) -> Motion:
        return self._motion

    def set_motion(self, motion: Motion, ghost: Motion | None = None, pose_frames=None, contacts=None) -> None:
        """Show another motion of the same skeleton (e.g. a new edit): its points go to the browser once, binary.
        ``ghost`` replaces the original (kept if None); ``pose_frames`` (frame indices of staggered poses) and
        ``contacts`` (``[(joint, start, end), ...]`` half-open frames) replace the highlights (kept if None).
        The frame is clamped to the new length; the camera keeps the user's orbit."""
        if not isinstance(motion, Motion):
            raise ValueError(f"motion: expected a Motion, got {type(motion).__name__}")
        if motion.num_joints != self._motion.num_joints:
            raise ValueError(f"motion: has {motion.num_joints} joints, the view shows {self._motion.num_joints}")
        if ghost is not None:
            if ghost.num_joints != self._motion.num_joints:
                raise ValueError(f"ghost: has {ghost.num_joints} joints, the view shows {self._motion.num_joints}")
            self._ghost_motion, self._ghost_points = ghost, None
            self.ghost_toggle.disabled = False
            self.ghost_toggle.tooltip = self._GHOST_TIP[False]
        if pose_frames is not None:
            self._pose_frames = np.unique(np.asarray(pose_frames, dtype=int).reshape(-1))
        if contacts is not None:
            self._contacts = self._contact_list(contacts, motion)
        self._motion = motion
        self._points = scene3d.skeleton_points(motion)
        self._push_motion(motion)

    def preview(self, motion: Motion, frame: int | None = None) -> int:
        """Show ``motion`` at ``frame`` (default: the shown frame) at once, before the whole clip follows with
        :meth:`set_motion`: one frame's points (P x 3 float32, under a kilobyte on a 31-joint rig, where the whole
        clip is F times that), drawn when the view shows that frame and is not playing. Returns the bytes sent."""
        if not isinstance(motion, Motion) or motion.num_joints != self._motion.num_joints:
            raise ValueError("motion: expected a Motion of the view's skeleton")
        f = min(max(0, int(self.frame if frame is None else frame)), motion.num_frames - 1)
        pts = scene3d.skeleton_points(motion.slice(f, f + 1))[0]
        with self.conductor.hold_sync():
            self.conductor.preview = pts.tobytes()
            self.conductor.preview_frame = f
        return pts.nbytes

    def highlight_joints(self, names) -> None:
        """Draw these joints (names or indices) red and larger (the first becomes ``selected_joint``)."""
        sk = self._motion.skeleton
        selected = [sk.index(n) if isinstance(n, str) else int(n) for n in (names or []) if n != ""]
        if selected != self._selected:   # the same selection (an editor redraw): nothing to rebuild or send
            self._selected = selected
            self.conductor.selected = list(selected)
            self._update_legend()
        first = sk.names[self._selected[0]] if self._selected else ""
        if first != self.selected_joint:
            self.selected_joint = first

    def set_pose_frames(self, frames) -> None:
        """Frames (indices) of staggered poses: the joints flash orange there (± 50 ms) while playing."""
        self._pose_frames = np.unique(np.asarray(frames, dtype=int).reshape(-1))
        self._push_highlights()

    def set_contacts(self, contacts) -> None:
        """``[(joint_name, start_frame, end_frame), ...]`` (half-open): those joints are green while in contact."""
        self._contacts = self._contact_list(contacts, self._motion)
        self._push_highlights()

    # -- events ------------------------------------------------------------------------------------------
    #: what a change of each drawn trait sends: the part of the scene it changes, then what else shows it
    _SENDS = {"show_ghost": ("_push_ghost", "_update_legend"), "camera": ("_push_camera", "_update_grid"),
              "trail_joints": ("_push_trails", "_update_legend")}

    @traitlets.observe(*_SENDS)
    def _on_drawn(self, change):
        for send in self._SENDS[change["name"]]:
            getattr(self, send)()

    @traitlets.validate("trail_joints")
    def _valid_trails(self, proposal):
        names = list(proposal["value"])
        for n in names:
            if n not in self._names:
                raise ValueError(f"trail_joints: unknown joint {n!r}")
        return names

    @traitlets.observe("selected_joint")
    def _on_selected(self, change):
        name = change["new"]
        if name and name not in self._names:
            raise ValueError(f"selected_joint: unknown joint {name!r}")
        want = [self._names.index(name)] if name else []
        if want != self._selected[:1]:
            self.highlight_joints([name] if name else [])

    def _on_pick(self, change):
        """A click on the skeleton mesh: the picked triangle's joint (a bone's is its parent joint)."""
        k = self.picker.faceIndex
        if self.picker.object is not self.skeleton_mesh or k is None or not 0 <= k < len(self._tri_joint):
            return
        self.selected_joint = self._names[int(self._tri_joint[k])]
