"""``export_html(obj, path)``: one self-contained HTML file that plays the (edited) motion in 3D with play / pause /
scrub, beside the editor's plots at their current state. Every script is inlined from installed packages —
three.js r97 from the pythreejs package (``pythreejs/static/three.js``), plotly.js from the plotly package
(``plotly.offline.get_plotlyjs()``) — and the motion is embedded as base64 float32 arrays (the same keyframe
tracks :class:`~stagger_nb.widgets.SkeletonView` sends), so the page works from a file or an e-mail, offline.
"""
from __future__ import annotations

import base64
import html
import json
import os
from importlib import resources
from pathlib import Path

import numpy as np

from .. import scene3d
from ..core.motion import Motion
from ..io._common import atomic_write_bytes, read_file_head

__all__ = ["export_html"]

_JOINT, _GHOST = "#2d3748", "#a0aec0"
_STATE_COLOURS = np.array([[0x2d, 0x37, 0x48], [0xdd, 0x6b, 0x20], [0x38, 0xa1, 0x69]], dtype=np.float32) / 255


def _b64(a) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f4").tobytes()).decode("ascii")


def _motion_json(m: Motion) -> dict:
    tr = scene3d.motion_tracks(m)
    return {"times": _b64(tr.times), "root_position": _b64(tr.root_position),
            "quats": {str(j): _b64(q) for j, q in tr.quats.items()},
            "translations": {str(j): _b64(t) for j, t in tr.translations.items()}}


def _skeleton_json(m: Motion) -> dict:
    sk = m.skeleton
    tr = scene3d.motion_tracks(m.slice(0, 1))
    rest = np.array(sk.offsets, dtype=float)
    if m.local_translations is not None:
        rest = np.array(m.local_translations[0], dtype=float)
    rest[0] = m.root_positions[0]
    sides = scene3d.joint_sides(sk.names)
    return {"names": list(sk.names), "parents": [int(p) for p in sk.parents],
            "rest_positions": rest.tolist(), "rest_quats": tr.static_quats.astype(float).tolist(),
            "bones": [{"parent": b.parent, "position": list(b.position), "quaternion": list(b.quaternion),
                       "length": b.length, "side": sides[b.child] if b.child >= 0 else sides[b.parent]}
                      for b in scene3d.bones(m)]}


def _figure_json(fig) -> dict:
    """A plotly figure dict from a dict, a plotly Figure/FigureWidget or a PlotView (``.figure``)."""
    if hasattr(fig, "figure") and not isinstance(fig, dict) and not hasattr(fig, "to_plotly_json"):
        fig = fig.figure
    if hasattr(fig, "to_plotly_json"):
        fig = fig.to_plotly_json()
    if not isinstance(fig, dict):
        raise ValueError(f"obj: a figure must be a plotly figure dict, got {type(fig).__name__}")
    import plotly.utils
    return json.loads(json.dumps({"data": fig.get("data", []), "layout": fig.get("layout", {})},
                                 cls=plotly.utils.PlotlyJSONEncoder))


def _unpack(obj):
    """(motion, ghost, figures, pose_frames, contacts, source_path, title) for a Motion, a Session or an editor."""
    from ..session import Session
    figures, pose_frames, contacts = [], (), ()
    view = getattr(obj, "view", None)
    if isinstance(obj, Motion):
        return obj, None, [], (), (), None, "motion"
    if isinstance(obj, Session):
        session = obj
    elif isinstance(getattr(obj, "session", None), Session):
        session = obj.session
        if hasattr(obj, "figures"):
            figures = list(obj.figures())
        else:
            figures = [p for p in getattr(obj, "plots", [])]
        if view is not None and hasattr(view, "pose_frames"):
            pose_frames, contacts = view.pose_frames, view.contacts
    else:
        raise ValueError(f"obj: expected a Motion, a Session or an editor, got {type(obj).__name__}")
    return (session.edited(), session.source, [_figure_json(f) for f in figures], pose_frames, contacts,
            session.source_path, type(obj).__name__)


def _refuse(path: str, source_path) -> None:
    real = os.path.realpath(path)
    if source_path is not None and real == os.path.realpath(source_path):
        raise ValueError(f"path: {path} is the source clip; export_html never writes over it")
    if os.path.exists(real):
        if not os.path.isfile(real):
            raise ValueError(f"path: {path} exists and is not a regular file")
        head = read_file_head(real, 512, what="path").lstrip().lower()  # the one input policy (no /proc)
        if head and not head.startswith((b"<!doctype html", b"<html")):
            raise ValueError(f"path: {path} exists and is not an HTML file; export_html only replaces HTML")


def _script(code: str) -> str:
    return "<script>" + code.replace("</script", "<\\/script") + "</script>"


def export_html(obj, path, *, width: int = 640, height: int = 480, title: str | None = None,
                autoplay: bool = True) -> Path:
    """Write one self-contained, offline HTML page: ``obj`` (a Motion, a Session, or an editor with ``.session``
    and ``.figures()`` / ``.plots``) playing in 3D beside its plots.

    The file is written atomically (a temporary file, then a rename); ``path`` must not be the session's source
    clip, nor an existing file that is not HTML. Returns the path. Size: ~5.2 MB of scripts (plotly.js 4.6 MB,
    three.js 0.55 MB) plus the motion (4/3 × the float32 tracks; the original again when there is one).
    """
    motion, ghost, figures, pose_frames, contacts, source_path, kind = _unpack(obj)
    path = os.fspath(path)
    _refuse(path, source_path)
    import plotly.offline
    three_js = resources.files("pythreejs").joinpath("static", "three.js").read_text(encoding="utf-8")
    player_js = Path(__file__).with_name("_export_player.js").read_text(encoding="utf-8")

    pos = scene3d.world_positions(motion)
    cam = scene3d.follow_camera(pos, motion.frame_time, "follow", aspect=width / height)
    step = max(1, int(round(0.05 / motion.frame_time)))
    idx = np.unique(np.concatenate([np.arange(0, motion.num_frames, step), [motion.num_frames - 1]]))
    size = scene3d.body_size(pos)
    cell = scene3d.grid_cell(size)
    ground = scene3d.ground_segments(pos, cell, 2 * size, cam.ground)
    sk = motion.skeleton
    contact_idx = [(sk.index(j) if isinstance(j, str) else int(j), int(a), int(b)) for j, a, b in contacts]
    keys = scene3d.highlight_keys(motion.num_frames, motion.frame_time, motion.num_joints, pose_frames, contact_idx)
    data = {
        "width": int(width), "height": int(height), "num_frames": motion.num_frames,
        "frame_time": motion.frame_time, "autoplay": bool(autoplay),
        "radius": scene3d.joint_radius(motion), "side_colours": scene3d.SIDE_COLOURS, "joint_colour": _JOINT,
        "ghost_colour": _GHOST, "skeleton": _skeleton_json(motion), "motion": _motion_json(motion),
        "ghost": None if ghost is None or ghost.num_joints != motion.num_joints else _motion_json(ghost),
        "highlights": {str(j): {"times": _b64(t), "colours": _b64(_STATE_COLOURS[s])} for j, (t, s) in keys.items()},
        "camera": {"times": _b64(idx * motion.frame_time), "rig": _b64(-cam.rig[idx]), "position": list(cam.position),
                   "target": list(cam.target), "fov": cam.fov, "near": cam.near, "far": cam.far},
        "grid": {"segments": _b64(ground), "cell": cell},
    }
    title = title or f"stagger_nb: {kind} ({motion.num_frames} frames, {motion.duration:.2f} s)"
    legend = " ".join(
        f'<span><i style="background:{col}"></i>{name}</span>' for name, col in
        [("left", scene3d.SIDE_COLOURS["left"]), ("right", scene3d.SIDE_COLOURS["right"]),
         ("centre", scene3d.SIDE_COLOURS["centre"])] + ([("original (ghost)", _GHOST)] if data["ghost"] else [])
        + ([("staggered pose", "#dd6b20")] if len(pose_frames) else []) + ([("contact", "#38a169")] if contacts else []))
    data_json = json.dumps(data).replace("</", "<\\/")
    figures_json = json.dumps(figures).replace("</", "<\\/")
    plots = "".join(f'<div class="sn-plot" id="sn-plot-{i}"></div>' for i in range(len(figures)))
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>
body {{ font-family: system-ui, sans-serif; margin: 12px; color: #2d3748; }}
#sn-wrap {{ display: flex; flex-wrap: wrap; gap: 16px; align-items: flex-start; }}
#sn-view canvas {{ border: 1px solid #e2e8f0; display: block; cursor: grab; }}
#sn-bar {{ display: flex; gap: 8px; align-items: center; margin-top: 6px; }}
#sn-scrub {{ flex: 1; }}
.sn-legend span {{ margin-right: 10px; font-size: 12px; display: inline-block; white-space: nowrap; }}
.sn-legend i {{ display: inline-block; width: 14px; height: 5px; margin-right: 4px; vertical-align: middle; }}
.sn-plot {{ width: 560px; min-height: 260px; }}
</style></head>
<body><h3>{html.escape(title)}</h3>
<div id="sn-wrap"><div id="sn-view" style="width:{int(width)}px">
<div id="sn-bar"><button id="sn-play">&#9654; play</button><input id="sn-scrub" type="range" min="0" value="0" step="1">
<span id="sn-time"></span></div>
<div class="sn-legend">{legend} <span>grid square: {cell:g} units &middot; drag to orbit, wheel to zoom</span></div>
</div><div id="sn-plots">{plots}</div></div>
<script type="application/json" id="sn-data">{data_json}</script>
<script type="application/json" id="sn-figures">{figures_json}</script>
{_script(three_js)}
{_script(plotly.offline.get_plotlyjs())}
{_script(player_js)}
<script>
(function () {{
  const figs = JSON.parse(document.getElementById("sn-figures").textContent);
  figs.forEach((f, i) => Plotly.newPlot("sn-plot-" + i, f.data, f.layout, {{displaylogo: false, responsive: true}}));
}})();
</script>
</body></html>
"""
    atomic_write_bytes(path, page.encode("utf-8"))
    return Path(path)
