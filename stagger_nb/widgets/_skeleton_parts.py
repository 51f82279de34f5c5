"""The browser-side parts of :class:`~stagger_nb.widgets.skeleton_view.SkeletonView`: its colours, the anywidget
clock and mesh builder (:class:`_Conductor`: ``_skeleton_mesh.js`` + ``_conductor.js``, see the view's module
docstring for what it relies on in pythreejs), the Play and slider that do not echo their value, and the
float32 buffer attributes the view sends."""
from __future__ import annotations

from pathlib import Path

import anywidget
import ipywidgets as widgets
import numpy as np
import pythreejs as three
import traitlets
from ipywidgets import widget_serialization

from .. import scene3d

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


_rgb = scene3d.hex_rgb


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
