"""A pythreejs 3D view of a skeleton that plays in the browser.

The motion goes to the browser once per edit, as binary pythreejs keyframe tracks (a position track for the root,
one quaternion track per joint that moves; float32). An edit updates the existing track widgets in place (new
``values`` arrays, ``times`` only when they change; tracks created or closed only when the set of moving joints
changes) and bumps ``conductor.data_version``, on which the browser rebuilds its three.js actions: one batch of
binary updates, a few ms kernel-side (issue 11 item 8, issue 12 item 1). The tracks form an
:class:`pythreejs.AnimationClip` played by a paused
:class:`pythreejs.AnimationAction` whose time a small anywidget clock (``_conductor.js``) sets from
``performance.now()`` while the ipywidgets ``Play`` runs, and from the Play's value when it is stopped. So Play
runs at the clip's real rate with the kernel busy, and the kernel hears only the Play's coarse ticks (every
~100 ms, not echoed back). ``view.frame`` follows the Play when playback stops or the user scrubs; while playing
it holds still, so nothing kernel-side (plots linked to the editor's model) sends per-frame messages.
Plots follow browser-side with :meth:`SkeletonView.link_frame`.

Drawn: the joint hierarchy as pythreejs Groups (bones are cylinders coloured by body side, joints spheres),
a grid ground, a camera on a rig that follows the root (``camera="follow"``) or frames everything
(``camera="all"``) with orbit controls, the original as a translucent ghost, motion trails of
``trail_joints`` over a window around the playhead, staggered-pose frames and contacts as sphere colours
(keyframed), the selected joint ringed in red; clicking a joint (pythreejs Picker) selects it.
The numbers (tracks, bones, camera path, highlight keys) come from :mod:`stagger_nb.scene3d`.
"""
from __future__ import annotations

import html
from dataclasses import dataclass
from pathlib import Path

import anywidget
import ipywidgets as widgets
import numpy as np
import pythreejs as three
import traitlets
from ipydatawidgets import NDArrayWidget
from ipywidgets import widget_serialization

from .. import scene3d
from ..core.kinematics import fk_arrays
from ..core.motion import Motion

__all__ = ["SkeletonView"]

_JOINT = "#2d3748"
_POSE = "#dd6b20"
_CONTACT = "#38a169"
_SELECTED = "#e53e3e"
_GHOST = "#a0aec0"
_TRAILS = ("#805ad5", "#d69e2e", "#319795", "#d53f8c", "#3182ce", "#718096")
_STATE_COLOURS = np.array([[0x2d, 0x37, 0x48], [0xdd, 0x6b, 0x20], [0x38, 0xa1, 0x69]], dtype=np.float32) / 255
_TICK_S = 0.1          # the Play's tick: the kernel hears at most ~1 / _TICK_S frame updates a second


class _FramePlay(widgets.Play):
    """ipywidgets Play whose value is not echoed back to the browser (ipywidgets 8 echoes every front-end
    update by default: one kernel→browser message per tick)."""
    value = traitlets.CInt(0, help="current frame").tag(sync=True, echo_update=False)


class _FrameSlider(widgets.IntSlider):
    """IntSlider (CSS class ``sn-frame``) whose value is not echoed back to the browser."""
    value = traitlets.CInt(0, help="current frame").tag(sync=True, echo_update=False)


class _Conductor(anywidget.AnyWidget):
    """The browser-side clock (see ``_conductor.js``); holds references to the pythreejs models it drives."""
    _esm = (Path(__file__).with_name("_conductor.js")).read_text(encoding="utf-8")
    player = traitlets.Instance(widgets.Play, allow_none=True).tag(sync=True, **widget_serialization)
    mixer = traitlets.Instance(three.AnimationMixer, allow_none=True).tag(sync=True, **widget_serialization)
    scene = traitlets.Instance(three.Scene, allow_none=True).tag(sync=True, **widget_serialization)
    actions = traitlets.List(traitlets.Instance(three.AnimationAction)).tag(sync=True, **widget_serialization)
    trails = traitlets.List(traitlets.Instance(three.Object3D)).tag(sync=True, **widget_serialization)
    frame_time = traitlets.Float(1 / 60).tag(sync=True)
    trail_window = traitlets.Int(30, help="frames shown each side of the playhead").tag(sync=True)
    data_version = traitlets.Int(0, help="bumped after the tracks of the actions were updated in place: the "
                                 "browser rebuilds its three.js actions from the current tracks").tag(sync=True)


def _array(a) -> np.ndarray:
    """The numpy array of a pythreejs array trait (an array or an ipydatawidgets NDArrayWidget)."""
    return np.asarray(a.array if isinstance(a, NDArrayWidget) else a)


def _f32(a) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, dtype=np.float32).reshape(-1))


@dataclass
class _Clip:
    """One pythreejs AnimationClip with its paused action, its tracks by name and the clip's shared times widget
    (or None), all kept across edits (updated in place)."""
    action: three.AnimationAction
    clip: three.AnimationClip
    tracks: dict
    times: NDArrayWidget | None


class SkeletonView(widgets.VBox):
    """3D view with a Play button, a frame slider (CSS class ``sn-frame``) and a legend.

    Parameters
    ----------
    motion : Motion
        The motion shown (usually the edited one); replace it with :meth:`set_motion`.
    ghost : Motion, optional
        The original, drawn translucent (same skeleton) when ``show_ghost``.
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
        self._pos = scene3d.world_positions(motion)
        self._ghost_motion = ghost
        self._ghost_offset = np.zeros(3) if ghost_offset is None else np.asarray(ghost_offset, float).reshape(3)
        self._pose_frames = np.zeros(0, dtype=int)
        self._contacts: list = []
        self._selected: list[int] = []
        self.edit_bytes = 0
        sk = motion.skeleton
        self._names = list(sk.names)
        radius = scene3d.joint_radius(motion)
        self._radius = radius
        self._size = scene3d.body_size(self._pos)

        # -- materials and shared geometry -------------------------------------------------------------
        self._side_materials = {s: three.MeshLambertMaterial(color=c) for s, c in scene3d.SIDE_COLOURS.items()}
        self._bone_geometry = three.CylinderGeometry(radiusTop=radius * 0.45, radiusBottom=radius * 0.45, height=1,
                                                     radialSegments=8)
        self._sphere_geometry = three.SphereGeometry(radius=radius, widthSegments=12, heightSegments=8)
        ghost_material = three.MeshLambertMaterial(color=_GHOST, transparent=True, opacity=0.35, depthWrite=False)

        # -- skeleton: joint groups j0..j{J-1}, spheres s{j} (own material: keyframed colour) -------------
        self._joint_materials = [three.MeshLambertMaterial(color=_JOINT) for _ in range(sk.num_joints)]
        self._bone_joint = {}   # bone mesh model id -> the joint rotating it (its parent joint), for picking
        self.spheres = [three.Mesh(self._sphere_geometry, self._joint_materials[j], name=f"s{j}")
                        for j in range(sk.num_joints)]
        self._groups = self._hierarchy(motion, "j", self._side_materials, self.spheres)
        self._ghost_groups = self._hierarchy(motion, "g", None, None, ghost_material)
        self._ghost_groups[0].visible = False
        self._marker_material = three.MeshLambertMaterial(color=_SELECTED, transparent=True, opacity=0.55)
        self._markers: dict[int, three.Mesh] = {}

        # -- ground, lights, camera rig ----------------------------------------------------------------------
        self.grid = three.Group(name="ground")   # replaced by the ground segments once the motion is known
        # the camera stays put and the world moves under it: a "rig" group holding everything drawn is shifted by
        # minus the follow path (keyframed), so orbit controls and picking work in plain scene coordinates
        self.three_camera = three.PerspectiveCamera(fov=40, aspect=width / height, up=(0, 1, 0))
        self.controls = three.OrbitControls(controlling=self.three_camera)
        self.picker = three.Picker(controlling=self._groups[0], event="click")
        self.picker.observe(self._on_pick, names=["point", "object"])
        self.trails_group = three.Group(name="trails")
        self.rig = three.Group(name="rig", children=[self._groups[0], self._ghost_groups[0], self.trails_group,
                                                     self.grid])
        self.scene = three.Scene(children=[self.rig, three.AmbientLight(intensity=0.45),
                                           three.HemisphereLight(color="#ffffff", groundColor="#718096",
                                                                 intensity=0.75)],
                                 background="#ffffff")
        self.renderer = three.Renderer(camera=self.three_camera, scene=self.scene,
                                       controls=[self.controls, self.picker], width=width, height=height,
                                       antialias=True)
        self.mixer = three.AnimationMixer(self.scene)

        # -- playback widgets ---------------------------------------------------------------------------
        F = motion.num_frames
        step, interval = self._tick(motion.frame_time)
        self.player = _FramePlay(value=0, min=0, max=F - 1, step=step, interval=interval, description="play",
                                 show_repeat=False)
        self.frame_slider = _FrameSlider(value=0, min=0, max=F - 1, description="frame", continuous_update=True,
                                         layout=widgets.Layout(width="300px"))
        self.frame_slider.add_class("sn-frame")
        self.player.add_class("sn-play")
        self._frame_link = widgets.jslink((self.player, "value"), (self.frame_slider, "value"))
        self.player.observe(self._on_player_value, names="value")
        self.player.observe(self._on_playing, names="playing")
        self.play, self.slider = self.player, self.frame_slider   # older names
        self.conductor = _Conductor(player=self.player, mixer=self.mixer, scene=self.scene,
                                    frame_time=motion.frame_time)
        self._clips: dict[str, _Clip] = {}   # "camera" | "highlight" | "motion" | "ghost" -> its clip and tracks

        self.camera_toggle = widgets.ToggleButtons(options=[("follow", "follow"), ("frame all", "all")],
                                                   value=camera, style={"button_width": "84px"},
                                                   tooltips=["camera follows the character", "frame the whole clip"])
        self.ghost_toggle = widgets.Checkbox(value=False, description="original (ghost)", indent=False,
                                             disabled=ghost is None, layout=widgets.Layout(width="130px"))
        self.legend = widgets.HTML(layout=widgets.Layout(margin="0 0 0 4px"))
        self.legend.add_class("sn-legend")
        self.renderer.layout = widgets.Layout(width=f"{width}px", height=f"{height}px")
        super().__init__([self.renderer,
                          widgets.HBox([self.player, self.frame_slider]),
                          widgets.HBox([self.camera_toggle, self.ghost_toggle]),
                          self.legend, self.conductor], **kwargs)
        self.add_class("sn-skeleton-view")
        widgets.link((self.camera_toggle, "value"), (self, "camera"))
        widgets.link((self.ghost_toggle, "value"), (self, "show_ghost"))
        if ghost is not None:
            self._set_ghost(ghost)
        self._push_motion(motion, first=True)
        self.show_ghost = ghost is not None and bool(show_ghost)
        self.trail_joints = list(trail_joints)

    # -- construction helpers ---------------------------------------------------------------------------
    @staticmethod
    def _tick(frame_time: float):
        """Play step (frames) and interval (ms): ~_TICK_S per tick, an exact multiple of the frame time."""
        step = max(1, int(round(_TICK_S / frame_time)))
        return step, max(10, int(round(step * frame_time * 1000)))

    def _hierarchy(self, motion: Motion, prefix: str, side_materials, spheres, material=None):
        """Groups ``{prefix}{j}`` nested like the skeleton, posed at frame 0, with bone cylinders (and spheres)."""
        sk = motion.skeleton
        tr = scene3d.motion_tracks(motion.slice(0, 1))
        sides = scene3d.joint_sides(sk.names)
        groups = []
        for j in range(sk.num_joints):
            pos = motion.root_positions[0] if j == 0 else (
                sk.offsets[j] if motion.local_translations is None else motion.local_translations[0, j])
            groups.append(three.Group(name=f"{prefix}{j}", position=tuple(float(x) for x in pos),
                                      quaternion=tuple(float(x) for x in tr.static_quats[j])))
        kids = [[] if spheres is None else [spheres[j]] for j in range(sk.num_joints)]
        for b in scene3d.bones(motion):
            side = sides[b.child] if b.child >= 0 else sides[b.parent]
            mat = material if material is not None else side_materials[side]
            mesh = three.Mesh(self._bone_geometry, mat, position=b.position, quaternion=b.quaternion,
                              scale=(1.0, b.length, 1.0))
            kids[b.parent].append(mesh)
            if spheres is not None:
                self._bone_joint[mesh.model_id] = b.parent
        for j in range(1, sk.num_joints):
            kids[int(sk.parents[j])].append(groups[j])
        for j in range(sk.num_joints):
            groups[j].children = tuple(kids[j])
        return groups

    # -- public ------------------------------------------------------------------------------------------
    @property
    def motion(self) -> Motion:
        return self._motion

    @property
    def positions(self) -> np.ndarray:
        """World joint positions of the shown motion, shape (F, J, 3), float32 (read-only view)."""
        v = self._pos.view()
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
        px = scene3d.project(self._pos[f, j][None], eye, target, self._camera.fov, self.width, self.height)
        return float(px[0, 0]), float(px[0, 1])

    def drawn_height(self, frame: int | None = None) -> float:
        """The character's drawn height at ``frame`` as a fraction of the canvas height (framed camera)."""
        f = self.frame if frame is None else int(frame)
        return scene3d.drawn_height_fraction(self._pos[f], self._camera, f, self.width, self.height)

    @property
    def pose_frames(self) -> np.ndarray:
        """Frames of the staggered poses highlighted, (K,) int."""
        return self._pose_frames.copy()

    @property
    def contacts(self) -> list:
        """Contacts highlighted, ``[(joint_name, start_frame, end_frame), ...]`` (half-open)."""
        return [(self._names[j], a, b) for j, a, b in self._contacts]

    @property
    def joint_groups(self) -> list:
        """The pythreejs Group of each joint (named ``j{index}``), nested like the skeleton."""
        return list(self._groups)

    @property
    def motion_tracks(self) -> list:
        """The keyframe tracks of the shown motion, as sent to the browser (pythreejs KeyframeTrack widgets)."""
        return list(self._clips["motion"].tracks.values())

    def shown_positions(self, frame: int | None = None) -> np.ndarray:
        """World joint positions ``(J, 3)`` at ``frame`` (default: the current one) decoded from the state sent
        to the browser (the tracks and the groups' rest transforms, float32), as three.js poses the hierarchy."""
        f = self.frame if frame is None else int(frame)
        J = self._motion.num_joints
        q = np.array([g.quaternion for g in self._groups], dtype=float)
        t = np.array([g.position for g in self._groups], dtype=float)
        for tr in self.motion_tracks:
            node, prop = tr.name.split(".")
            j = int(node[1:])
            values = _array(tr.values).astype(float).reshape(len(_array(tr.times)), -1)
            (q if prop == "quaternion" else t)[j] = values[f]
        p, _ = fk_arrays(q[None], t, np.asarray(self._motion.skeleton.parents))
        return p[0][:J]

    def link_frame(self, widget, trait: str = "frame"):
        """Make ``widget.<trait>`` follow the playhead browser-side (a jsdlink from the Play): plot playheads
        move while playing without a kernel round trip. Returns the link (``.unlink()`` to stop)."""
        return widgets.jsdlink((self.player, "value"), (widget, trait))

    def set_motion(self, motion: Motion, ghost: Motion | None = None, pose_frames=None, contacts=None) -> None:
        """Show another motion of the same skeleton (e.g. a new edit): its tracks go to the browser once, binary.
        ``ghost`` replaces the original (kept if None); ``pose_frames`` (frame indices of staggered poses) and
        ``contacts`` (``[(joint, start, end), ...]`` half-open frames) replace the highlights (kept if None).
        The frame is clamped to the new length; the camera keeps the user's orbit."""
        if not isinstance(motion, Motion):
            raise ValueError(f"motion: expected a Motion, got {type(motion).__name__}")
        if motion.num_joints != self._motion.num_joints:
            raise ValueError(f"motion: has {motion.num_joints} joints, the view shows {self._motion.num_joints}")
        if ghost is not None:
            self._set_ghost(ghost)   # published with the motion below
        if pose_frames is not None:
            self._pose_frames = np.unique(np.asarray(pose_frames, dtype=int).reshape(-1))
        if contacts is not None:
            self._contacts = self._contact_list(contacts, motion)
        self._motion = motion
        self._pos = scene3d.world_positions(motion)
        self._push_motion(motion)

    def highlight_joints(self, names) -> None:
        """Ring these joints (names or indices) in red (the first becomes ``selected_joint``)."""
        sk = self._motion.skeleton
        self._selected = [sk.index(n) if isinstance(n, str) else int(n) for n in (names or []) if n != ""]
        self._update_markers()
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

    def _update_clip(self, key: str, specs: list, shared_times=None) -> int:
        """Make the clip ``key`` play ``specs`` (``[(name, track class, times or None, values, interpolation)]``;
        times None: ``shared_times``, one array for all those tracks), updating the existing track widgets in
        place: arrays that changed are assigned (binary, one message per track), unchanged ones are not re-sent;
        tracks are created or closed only when the set of track names changes; the clip and its paused action
        stay. The browser rebuilds its actions on ``conductor.data_version`` (bumped by the caller). Returns the
        array bytes sent."""
        entry = self._clips.get(key)
        nbytes = 0
        times_w = None
        if shared_times is not None:
            shared_times = _f32(shared_times)
            if entry is not None and entry.times is not None and np.array_equal(_array(entry.times), shared_times):
                times_w = entry.times
            else:   # one new times widget for the whole clip (the old one is closed below)
                times_w = NDArrayWidget(shared_times)
                nbytes += shared_times.nbytes
        old = entry.tracks if entry is not None else {}
        tracks = {}
        for name, cls, times, values, interp in specs:
            t = old.get(name)
            if t is not None and type(t) is cls and t.interpolation == interp:
                with t.hold_sync():
                    if times is None:
                        if t.times is not times_w:
                            t.times = times_w
                    elif not np.array_equal(_array(t.times), times):
                        t.times = times
                        nbytes += times.nbytes
                    if not np.array_equal(_array(t.values), values):
                        t.values = values
                        nbytes += values.nbytes
            else:
                t = cls(name=name, times=times_w if times is None else times, values=values, interpolation=interp)
                nbytes += values.nbytes + (0 if times is None else times.nbytes)
            tracks[name] = t
        if entry is None:
            clip = three.AnimationClip(name=key, tracks=list(tracks.values()))
            entry = _Clip(three.AnimationAction(self.mixer, clip, self.scene, paused=True), clip, tracks, times_w)
            self._clips[key] = entry
        else:
            if list(tracks) != list(old) or any(tracks[n] is not old[n] for n in tracks):
                entry.clip.tracks = list(tracks.values())
            for n, t in old.items():
                if tracks.get(n) is not t:
                    t.close()
            if entry.times is not None and entry.times is not times_w:
                entry.times.close()
            entry.tracks, entry.times = tracks, times_w
        return nbytes

    def _publish(self) -> None:
        """Tell the browser: the actions (the ghost's last) and, by bumping ``data_version``, that their tracks
        changed."""
        acts = [v.action for k, v in sorted(self._clips.items()) if k != "ghost"]
        if "ghost" in self._clips:
            acts.append(self._clips["ghost"].action)
        self.conductor.actions = acts
        self.conductor.data_version += 1

    def _motion_tracks(self, motion: Motion, prefix: str, offset=None):
        """Track specs (see :meth:`_update_clip`) and the shared times of ``motion`` on the hierarchy ``prefix``."""
        tr = scene3d.motion_tracks(motion)
        root = tr.root_position if offset is None else tr.root_position + np.asarray(offset, np.float32)
        lin = "InterpolateLinear"
        out = [(f"{prefix}0.position", three.VectorKeyframeTrack, None, _f32(root), lin)]
        for j, q in tr.quats.items():
            out.append((f"{prefix}{j}.quaternion", three.QuaternionKeyframeTrack, None, _f32(q), lin))
        for j, t in tr.translations.items():
            out.append((f"{prefix}{j}.position", three.VectorKeyframeTrack, None, _f32(t), lin))
        # joints without a track hold their frame-0 rotation: set it on the group (a new motion may differ)
        groups = self._groups if prefix == "j" else self._ghost_groups
        for j in range(motion.num_joints):
            if j not in tr.quats:
                groups[j].quaternion = tuple(float(x) for x in tr.static_quats[j])
        return out, tr.times

    def _push_motion(self, motion: Motion, first: bool = False) -> None:
        F = motion.num_frames
        step, interval = self._tick(motion.frame_time)
        with self.hold_trait_notifications():
            specs, times = self._motion_tracks(motion, "j")
            nbytes = self._update_clip("motion", specs, times)
            nb_h = self._highlight_clip()
            nb_c = self._camera_clip()
            nb_t = self._push_trails()
            with self.conductor.hold_sync():
                self.conductor.frame_time = motion.frame_time
                self.conductor.trail_window = max(1, int(round(self.trail_seconds / motion.frame_time)))
            self.player.max = self.frame_slider.max = F - 1
            self.player.step, self.player.interval = step, interval
            if self.frame > F - 1:
                self.frame = F - 1
            self._publish()
        self.edit_bytes = int(nbytes + nb_h + nb_c + nb_t)
        self._update_grid()
        self._update_legend()

    def _set_ghost(self, ghost: Motion, publish: bool = False) -> None:
        if ghost.num_joints != self._motion.num_joints:
            raise ValueError(f"ghost: has {ghost.num_joints} joints, the view shows {self._motion.num_joints}")
        self._ghost_motion = ghost
        specs, times = self._motion_tracks(ghost, "g", offset=self._ghost_offset)
        self._update_clip("ghost", specs, times)
        self.ghost_toggle.disabled = False
        if publish:
            self._publish()

    def _highlight_clip(self) -> int:
        m = self._motion
        keys = scene3d.highlight_keys(m.num_frames, m.frame_time, m.num_joints, self._pose_frames, self._contacts)
        specs = [(f"s{j}.material.color", three.ColorKeyframeTrack, _f32(t), _f32(_STATE_COLOURS[s]),
                  "InterpolateDiscrete") for j, (t, s) in keys.items()]
        for j, mat in enumerate(self._joint_materials):   # joints without a track: plain colour
            if j not in keys and mat.color != _JOINT:
                mat.color = _JOINT
        return self._update_clip("highlight", specs)

    def _push_highlights(self) -> None:
        self._highlight_clip()
        self._publish()
        self._update_legend()

    def _camera_clip(self) -> int:
        m = self._motion
        cam = scene3d.follow_camera(self._pos, m.frame_time, self.camera, aspect=self.width / self.height)
        self._camera = cam
        step = max(1, int(round(0.05 / m.frame_time)))   # keys every ~50 ms; linear in between
        idx = np.unique(np.concatenate([np.arange(0, m.num_frames, step), [m.num_frames - 1]]))
        spec = ("rig.position", three.VectorKeyframeTrack, _f32(idx * m.frame_time), _f32(-cam.rig[idx]),
                "InterpolateLinear")
        self.three_camera.fov, self.three_camera.near, self.three_camera.far = cam.fov, cam.near, cam.far
        if not getattr(self, "_camera_placed", None) == self.camera:   # keep the user's orbit across edits
            self.three_camera.position = cam.position
            self.controls.target = cam.target
            self.three_camera.quaternion = scene3d.look_at_quaternion(cam.position, cam.target)
            self._camera_placed = self.camera
        self.rig.position = tuple(-float(x) for x in cam.rig[min(self.frame, m.num_frames - 1)])
        return self._update_clip("camera", [spec])

    def _push_trails(self) -> int:
        sk = self._motion.skeleton
        objs, lines, nbytes = [], [], 0
        for i, name in enumerate(self.trail_joints):
            j = sk.index(name)
            arr = np.ascontiguousarray(self._pos[:, j], dtype=np.float32)
            nbytes += arr.nbytes
            geom = three.BufferGeometry(attributes={"position": three.BufferAttribute(array=arr)})
            colour = _TRAILS[i % len(_TRAILS)]
            line = three.Line(geom, three.LineBasicMaterial(color=colour), frustumCulled=False)
            dots = three.Points(geom, three.PointsMaterial(color=colour, size=self._radius * 0.6), frustumCulled=False)
            objs += [line, dots]
            lines.append(line)
        old = list(self.trails_group.children)
        self.trails_group.children = tuple(objs)
        self.conductor.trails = lines
        for o in old:
            o.geometry.attributes["position"].close()
            o.close()
        return nbytes

    def _update_markers(self) -> None:
        for j, mk in list(self._markers.items()):
            if j not in self._selected:
                g = self._groups[j]
                g.children = tuple(c for c in g.children if c is not mk)
                mk.close()
                del self._markers[j]
        for j in self._selected:
            if j not in self._markers:
                mk = three.Mesh(self._sphere_geometry, self._marker_material, scale=(1.9, 1.9, 1.9))
                self._markers[j] = mk
                self._groups[j].children = tuple(self._groups[j].children) + (mk,)
        self._update_legend()

    def _update_grid(self) -> None:
        """The ground: cell-edge line segments over the clip's ground track (see scene3d.ground_segments)."""
        cell = scene3d.grid_cell(self._size)
        seg = scene3d.ground_segments(self._pos, cell, 2 * self._size, self._camera.ground)
        key = (seg.shape, float(seg[:, 0].min()), float(seg[:, 2].min()), float(self._camera.ground), cell)
        if key == getattr(self, "_grid_key", None):
            return
        old = self.grid
        self.grid = three.LineSegments(three.BufferGeometry(attributes={"position": three.BufferAttribute(seg)}),
                                       three.LineBasicMaterial(color="#cbd5e0"), name="ground")
        self.rig.children = tuple(self.grid if ch is old else ch for ch in self.rig.children)
        if isinstance(old, three.LineSegments):   # its geometry, array and material too (not left behind)
            for w in (old.geometry.attributes["position"], old.geometry, old.material):
                w.close()
        old.close()
        self._grid_key, self._grid_cell = key, cell

    def _update_legend(self) -> None:
        def sw(colour, label, shape="bar"):
            style = ("width:14px;height:5px;border-radius:2px" if shape == "bar" else
                     "width:9px;height:9px;border-radius:50%")
            return (f'<span style="display:inline-flex;align-items:center;margin-right:10px">'
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
        if self._ghost_motion is not None:
            items.append(sw(_GHOST, "original (ghost)"))
        for i, n in enumerate(self.trail_joints):
            items.append(sw(_TRAILS[i % len(_TRAILS)], f"trail {n} (±{self.trail_seconds:g} s)"))
        items.append(f'<span style="color:#718096">grid square: {getattr(self, "_grid_cell", 0):g} units</span>')
        self.legend.value = '<div style="font-size:12px;line-height:18px">' + "".join(items) + "</div>"

    # -- events ------------------------------------------------------------------------------------------
    @traitlets.validate("frame")
    def _valid_frame(self, proposal):
        return int(np.clip(proposal["value"], 0, self._motion.num_frames - 1))

    @traitlets.observe("frame")
    def _on_frame(self, change):
        if self.player.value != change["new"]:
            self.player.value = change["new"]   # a seek from Python: the browser shows that frame
        self.frame_slider.value = change["new"]   # (the browser links them; keep the kernel's copy in step)

    def _on_player_value(self, change):
        if not self.player.playing:            # a scrub; while playing the kernel does not follow per tick
            self.frame = change["new"]

    def _on_playing(self, change):
        if not change["new"]:
            self.frame = self.player.value

    @traitlets.observe("show_ghost")
    def _on_ghost(self, change):
        self._ghost_groups[0].visible = bool(change["new"]) and self._ghost_motion is not None

    @traitlets.observe("camera")
    def _on_camera(self, change):
        self._camera_clip()
        self._publish()
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
        obj = self.picker.object
        if obj is None:
            return
        j = next((k for k, s in enumerate(self.spheres) if s is obj), None)
        if j is None:
            j = self._bone_joint.get(obj.model_id)
        if j is None:
            j = next((k for k, mk in self._markers.items() if mk is obj), None)
        if j is not None:
            self.selected_joint = self._names[j]
