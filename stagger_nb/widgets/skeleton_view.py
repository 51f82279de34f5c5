"""A pythreejs 3D view of a skeleton that plays in the browser.

The whole skeleton is ONE indexed triangle mesh (a sphere per joint, an open tube per bone; per-vertex colours),
its original (the ghost) a second one built only when first shown, the trails one LineSegments + Points, the
ground one LineSegments: about 45 widget models per view (the previous design, one pythreejs model per bone,
joint, material and keyframe track, had ~280, and JupyterLab restored ~1,200 of them per notebook on a page
reload, slowly enough to give up on some: ipywidgets #4026/#4040). The world points of every frame (joints then
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

No public way does the job: the public routes all go through the kernel (setting ``BufferAttribute.array``
or calling ``exec_three_obj_method`` from Python is one kernel round trip and ~0.1 MB per shown frame of a
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

import html
from pathlib import Path

import anywidget
import ipywidgets as widgets
import numpy as np
import pythreejs as three
import traitlets
from ipywidgets import widget_serialization

from .. import scene3d
from ..core.motion import Motion

__all__ = ["SkeletonView"]

_JOINT = "#2d3748"
_POSE = "#dd6b20"
_CONTACT = "#38a169"
_SELECTED = "#e53e3e"
_GHOST = "#a0aec0"
_TRAILS = ("#805ad5", "#d69e2e", "#319795", "#d53f8c", "#3182ce", "#718096")
_TICK_S = 0.1          # the Play's tick: the kernel hears at most ~1 / _TICK_S frame updates a second
_SELECTED_SCALE = 1.6  # a selected joint's sphere is this much larger (and red)
_TEMPLATE = scene3d.mesh_template()
#: The one builder of the skeleton mesh (plain JS functions), prepended to the clock's module and inlined in the
#: exported page's player.
MESH_JS = _MESH_JS = (Path(__file__).with_name("_skeleton_mesh.js")).read_text(encoding="utf-8")


def _rgb(colour: str) -> list:
    return [int(colour[i:i + 2], 16) / 255 for i in (1, 3, 5)]


# joint state -> colour (scene3d.joint_states: 0 plain, 1 staggered pose, 2 contact), then the selected colour
_PALETTE = [_rgb(_JOINT), _rgb(_POSE), _rgb(_CONTACT), _rgb(_SELECTED)]


class _FramePlay(widgets.Play):
    """ipywidgets Play whose value is not echoed back to the browser (ipywidgets 8 echoes every front-end
    update by default: one kernel→browser message per tick)."""
    value = traitlets.CInt(0, help="current frame").tag(sync=True, echo_update=False)


class _FrameSlider(widgets.IntSlider):
    """IntSlider (CSS class ``sn-frame``) whose value is not echoed back to the browser."""
    value = traitlets.CInt(0, help="current frame").tag(sync=True, echo_update=False)


def _ref(cls):
    return traitlets.Instance(cls, allow_none=True).tag(sync=True, **widget_serialization)


class _Conductor(anywidget.AnyWidget):
    """The browser-side clock and mesh builder (see ``_conductor.js``): the data of the shown motion as binary
    buffers, and references to the pythreejs models it updates."""
    _esm = _MESH_JS + (Path(__file__).with_name("_conductor.js")).read_text(encoding="utf-8")
    player = _ref(widgets.Play)
    scene = _ref(three.Scene)
    rig = _ref(three.Object3D)
    skeleton = _ref(three.Mesh)
    ghost = _ref(three.Mesh)
    trails = _ref(three.LineSegments)
    points = traitlets.Bytes(b"", help="(F, P, 3) float32 world points: joints, then End Sites").tag(sync=True)
    num_frames = traitlets.Int(1).tag(sync=True)
    num_points = traitlets.Int(1).tag(sync=True)
    num_joints = traitlets.Int(1).tag(sync=True)
    ghost_points = traitlets.Bytes(b"", help="(Fg, P, 3) float32, the ghost's points (sent once shown)").tag(
        sync=True)
    ghost_frames = traitlets.Int(0).tag(sync=True)
    segments = traitlets.List(traitlets.Int(), help="bones as flattened point-index pairs").tag(sync=True)
    template = traitlets.Bytes(b"", help="float32 rows (x, y, z, nx, ny, nz): unit sphere, then unit tube").tag(
        sync=True)
    sphere_vertices = traitlets.Int(0).tag(sync=True)
    tube_vertices = traitlets.Int(0).tag(sync=True)
    joint_radius = traitlets.Float(1.0).tag(sync=True)
    bone_radius = traitlets.Float(0.5).tag(sync=True)
    selected = traitlets.List(traitlets.Int()).tag(sync=True)
    selected_scale = traitlets.Float(_SELECTED_SCALE).tag(sync=True)
    states = traitlets.Bytes(b"", help="(F, J) uint8 joint states: 0 plain, 1 pose, 2 contact").tag(sync=True)
    palette = traitlets.List(help="RGB in [0, 1] of the states 0, 1, 2 and of a selected joint").tag(sync=True)
    rig_path = traitlets.Bytes(b"", help="(F, 3) float32 position of the rig (minus the follow path)").tag(
        sync=True)
    frame_time = traitlets.Float(1 / 60).tag(sync=True)
    trail_joints = traitlets.List(traitlets.Int()).tag(sync=True)
    trail_window = traitlets.Int(30, help="frames shown each side of the playhead").tag(sync=True)
    preview = traitlets.Bytes(b"", help="(P, 3) float32 world points of one frame of an edit on its way: drawn at "
                              "once when that frame is shown and the view is not playing").tag(sync=True)
    preview_frame = traitlets.Int(-1, help="the frame of ``preview``").tag(sync=True)


def _f32(a) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, dtype=np.float32))


def _attr(array) -> three.BufferAttribute:
    return three.BufferAttribute(array=array, normalized=False, dynamic=True)


class SkeletonView(widgets.VBox):
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

    def __init__(self, motion: Motion, ghost: Motion | None = None, width: int = 480, height: int = 380,
                 ghost_offset=None, show_ghost: bool = True, camera: str = "follow", trail_joints=(),
                 trail_seconds: float = 0.6, **kwargs):
        if not isinstance(motion, Motion):
            raise ValueError(f"motion: expected a Motion, got {type(motion).__name__}")
        if ghost is not None and ghost.num_joints != motion.num_joints:
            raise ValueError(f"ghost: has {ghost.num_joints} joints, the motion {motion.num_joints}")
        self.width, self.height = int(width), int(height)
        self.trail_seconds = float(trail_seconds)
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
        tri_s = len(_TEMPLATE.sphere_index)
        self._tri_joint = np.concatenate([np.repeat(np.arange(J), tri_s),
                                          np.repeat(self._segs[:, 0], len(_TEMPLATE.tube_index))])
        sides = scene3d.joint_sides(sk.names)
        bone_rgb = [_rgb(scene3d.SIDE_COLOURS[sides[b] if b < J else sides[a]]) for a, b in self._segs]
        self._bone_colours = np.repeat(np.asarray(bone_rgb, np.float32).reshape(-1, 3), len(_TEMPLATE.tube),
                                       axis=0)
        self._sphere_vertices = vs
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

    # -- construction helpers ---------------------------------------------------------------------------
    @staticmethod
    def _tick(frame_time: float):
        """Play step (frames) and interval (ms): ~_TICK_S per tick, an exact multiple of the frame time."""
        step = max(1, int(round(_TICK_S / frame_time)))
        return step, max(10, int(round(step * frame_time * 1000)))

    def _constant_arrays(self):
        """The mesh's attribute arrays as the kernel holds them, (V, 3) float32 each: positions zero (the browser's
        clock writes every shown frame's, ``_skeleton_mesh.js``), the spheres' normals (the unit sphere's) and the
        constant colours (joints plain, bones by side). Sent once, with the mesh; never per edit."""
        J, vs = len(self._names), self._sphere_vertices
        V = J * vs + len(self._segs) * len(_TEMPLATE.tube)
        nrm = np.zeros((V, 3), np.float32)
        nrm[:J * vs] = np.tile(_TEMPLATE.sphere[:, 3:], (J, 1))
        col = np.concatenate([np.tile(np.asarray(_PALETTE[0], np.float32), (J * vs, 1)), self._bone_colours])
        return np.zeros((V, 3), np.float32), nrm, np.ascontiguousarray(col, np.float32)

    # -- public ------------------------------------------------------------------------------------------
    @property
    def motion(self) -> Motion:
        return self._motion

    @property
    def positions(self) -> np.ndarray:
        """World joint positions of the shown motion, shape (F, J, 3), float32 (read-only view)."""
        v = self._points[:, :self._motion.num_joints]
        v.setflags(write=False)
        return v

    @property
    def playing(self) -> bool:
        return bool(self.player.playing)

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

    def link_frame(self, widget, trait: str = "frame"):
        """Make ``widget.<trait>`` follow the playhead browser-side (a jsdlink from the Play): plot playheads
        move while playing without a kernel round trip. Returns the link (``.unlink()`` to stop)."""
        return widgets.jsdlink((self.player, "value"), (widget, trait))

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

    # -- sending -----------------------------------------------------------------------------------------
    @staticmethod
    def _contact_list(contacts, motion):
        sk = motion.skeleton
        return [(sk.index(n) if isinstance(n, str) else int(n), int(a), int(b)) for n, a, b in contacts]

    def _states_array(self) -> np.ndarray:
        m = self._motion
        return scene3d.joint_states(m.num_frames, m.frame_time, m.num_joints, self._pose_frames, self._contacts)

    def _push_motion(self, motion: Motion) -> None:
        F = motion.num_frames
        step, interval = self._tick(motion.frame_time)
        pts = self._points.tobytes()
        self._states = self._states_array()
        with self.hold_trait_notifications():
            if self.frame > F - 1:
                self.frame = F - 1
            states = self._states.tobytes()
            nbytes = (len(pts) if pts != self.conductor.points else 0) + \
                (len(states) if states != self.conductor.states else 0)   # traitlets sends changes only
            with self.conductor.hold_sync():
                self.conductor.points = pts
                self.conductor.num_frames = F
                self.conductor.states = states
                self.conductor.frame_time = motion.frame_time
                self.conductor.trail_window = max(1, int(round(self.trail_seconds / motion.frame_time)))
                nbytes += self._push_camera()
                nbytes += self._push_ghost()
            nbytes += self._push_trails()
            self.player.max = self.frame_slider.max = F - 1
            self.player.step, self.player.interval = step, interval
        self.edit_bytes = int(nbytes + self._update_grid())
        self._update_legend()

    def _push_ghost(self) -> int:
        """Build (first time), fill and send the ghost, only while it is shown. Returns the bytes sent."""
        if not self.show_ghost or self._ghost_motion is None:
            if self.ghost_mesh is not None:
                self.ghost_mesh.visible = False
            return 0
        nbytes = 0
        if self._ghost_points is None:
            self._ghost_points = scene3d.skeleton_points(self._ghost_motion) + self._ghost_offset.astype(np.float32)
            gp = self._ghost_points.tobytes()
            with self.conductor.hold_sync():
                self.conductor.ghost_points = gp
                self.conductor.ghost_frames = len(self._ghost_points)
            nbytes += len(gp)
        if self.ghost_mesh is None:   # the same constant arrays; the browser's clock writes its frames
            pos, nrm, _ = self._constant_arrays()
            geom = three.BufferGeometry(attributes={"position": _attr(pos), "normal": _attr(nrm)}, index=self._index)
            mat = three.MeshLambertMaterial(color=_GHOST, transparent=True, opacity=0.35, depthWrite=False)
            self.ghost_mesh = three.Mesh(geom, mat, name="ghost", frustumCulled=False)
            self.rig.children = tuple(self.rig.children) + (self.ghost_mesh,)
            self.conductor.ghost = self.ghost_mesh
            nbytes += pos.nbytes + nrm.nbytes
        self.ghost_mesh.visible = True
        return nbytes

    def _push_highlights(self) -> None:
        self._states = self._states_array()
        self.conductor.states = self._states.tobytes()
        self._update_legend()

    def _push_camera(self) -> int:
        m = self._motion
        # every point (the End Sites too: the top of the head) and the joints' spheres stay in the canvas
        cam = scene3d.follow_camera(self._points, m.frame_time, self.camera, aspect=self.width / self.height,
                                    pad=self._radius)
        self._camera = cam
        self.three_camera.fov, self.three_camera.near, self.three_camera.far = cam.fov, cam.near, cam.far
        if not getattr(self, "_camera_placed", None) == self.camera:   # keep the user's orbit across edits
            self.three_camera.position = cam.position
            self.controls.target = cam.target
            self.three_camera.quaternion = scene3d.look_at_quaternion(cam.position, cam.target)
            self._camera_placed = self.camera
        self.rig.position = tuple(-float(x) for x in cam.rig[min(self.frame, m.num_frames - 1)])
        path = _f32(-cam.rig).tobytes()
        nbytes = len(path) if path != self.conductor.rig_path else 0
        self.conductor.rig_path = path
        return nbytes

    def _push_trails(self) -> int:
        """Trails of ``trail_joints``: one LineSegments and one Points sharing a geometry of ``2 window``
        segments per joint, filled around the playhead (browser-side per frame; here for the current frame)."""
        idx = [self._names.index(n) for n in self.trail_joints]
        old = list(self.trails_group.children)
        w = self.conductor.trail_window
        if not idx:
            self.trails_group.children = ()
            self.conductor.trails = None
            self.conductor.trail_joints = []
            nbytes = 0
        else:
            seg = scene3d.trail_segments(self._points, idx, self.frame, w)
            col = np.repeat(np.asarray([_rgb(_TRAILS[i % len(_TRAILS)]) for i in range(len(idx))], np.float32),
                            4 * w, axis=0)
            geom = three.BufferGeometry(attributes={"position": _attr(seg), "color": _attr(col)})
            line = three.LineSegments(geom, three.LineBasicMaterial(vertexColors="VertexColors"),
                                      frustumCulled=False)
            dots = three.Points(geom, three.PointsMaterial(vertexColors="VertexColors", size=self._radius * 0.6),
                                frustumCulled=False)
            self.trails_group.children = (line, dots)
            with self.conductor.hold_sync():
                self.conductor.trail_joints = idx
                self.conductor.trails = line
            nbytes = seg.nbytes + col.nbytes
        for o in old:
            if isinstance(o, three.LineSegments):
                for w_ in (*o.geometry.attributes.values(), o.geometry, o.material):
                    w_.close()
            else:
                o.material.close()
            o.close()
        return nbytes

    def _update_grid(self) -> int:
        """The ground: cell-edge line segments over the clip's ground track (see scene3d.ground_segments), built at
        height 0 and lifted to the ground by the grid's position; the segments are replaced only when the extent
        changes (an edit moving the lowest point moves the grid: one small message). Returns the bytes sent."""
        lo, hi, cell = scene3d.ground_extent(self._points, scene3d.grid_cell(self._size), 2 * self._size)
        ground = (0.0, float(self._camera.ground), 0.0)
        key = (tuple(lo), tuple(hi), cell)
        if key == getattr(self, "_grid_key", None):
            if tuple(self.grid.position) != ground:
                self.grid.position = ground
            return 0
        seg = scene3d.ground_grid(lo, hi, cell, 0.0)
        if self.grid is not None and self.grid.geometry.attributes["position"].array.shape == seg.shape:
            with self.grid.hold_sync():
                self.grid.geometry.attributes["position"].array = seg   # same size: the array only, in place
                self.grid.position = ground
        else:
            old = self.grid
            self.grid = three.LineSegments(three.BufferGeometry(attributes={"position": three.BufferAttribute(seg)}),
                                           three.LineBasicMaterial(color="#cbd5e0"), name="ground", position=ground)
            self.rig.children = tuple(ch for ch in self.rig.children if ch is not old) + (self.grid,)
            if old is not None:   # its geometry, array and material too (not left behind)
                for w in (old.geometry.attributes["position"], old.geometry, old.material, old):
                    w.close()
        self._grid_key, self._grid_cell = key, cell
        return seg.nbytes

    def _update_legend(self) -> None:
        def sw(colour, label, shape="bar"):
            style = ("width:14px;height:5px;border-radius:2px" if shape == "bar" else
                     "width:9px;height:9px;border-radius:50%")
            return (f'<span style="display:inline-flex;align-items:center;margin-right:10px;white-space:nowrap">'
                    f'<span style="display:inline-block;{style};background:{colour};margin-right:4px"></span>'
                    f'{html.escape(label)}</span>')
        items = [sw(scene3d.SIDE_COLOURS["left"], "left"), sw(scene3d.SIDE_COLOURS["right"], "right"),
                 sw(scene3d.SIDE_COLOURS["centre"], "centre"), sw(_JOINT, "joint (click to select)", "dot")]
        if self._selected:
            items.append(sw(_SELECTED, "selected: " + ", ".join(self._names[j] for j in self._selected), "dot"))
        if len(self._pose_frames):
            items.append(sw(_POSE, f"staggered pose ({len(self._pose_frames)})", "dot"))
        if self._contacts:
            items.append(sw(_CONTACT, "contact", "dot"))
        if self._ghost_motion is not None and self.show_ghost:   # what is drawn
            items.append(sw(_GHOST, "original (ghost)"))
        for i, n in enumerate(self.trail_joints):
            items.append(sw(_TRAILS[i % len(_TRAILS)], f"trail {n} (±{self.trail_seconds:g} s)"))
        # one unit: an entry moves to the next line whole, never split ("grid" | "square: 5 units" was seen)
        items.append(f'<span style="color:#718096;display:inline-block;white-space:nowrap">'
                     f'grid square: {getattr(self, "_grid_cell", 0):g} units</span>')
        self.legend.value = '<div style="font-size:12px;line-height:18px">' + "".join(items) + "</div>"

    # -- events ------------------------------------------------------------------------------------------
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

    @traitlets.observe("show_ghost")
    def _on_ghost(self, change):
        self._push_ghost()
        self._update_legend()

    @traitlets.observe("camera")
    def _on_camera(self, change):
        self._push_camera()
        self._update_grid()

    @traitlets.validate("trail_joints")
    def _valid_trails(self, proposal):
        names = list(proposal["value"])
        for n in names:
            if n not in self._names:
                raise ValueError(f"trail_joints: unknown joint {n!r}")
        return names

    @traitlets.observe("trail_joints")
    def _on_trails(self, change):
        self._push_trails()
        self._update_legend()

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
