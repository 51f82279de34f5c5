"""``export_html(obj, path)``: one self-contained HTML file that plays the (edited) motion in 3D with play / pause /
scrub, beside the editor's plots at their current state. Offline: every script is inlined from installed packages
(three.js r97 from the pythreejs package, plotly.js from the plotly package) and the page inflates them itself.

Size (the CMU 01_01 StaggerEditor: 9 MB before, ~2.5 MB now). Three blocks, each deflate-raw compressed and
base64-encoded, which the page inflates with the browser's own ``DecompressionStream("deflate-raw")`` (Chromium
80+, Firefox 113+, Safari 16.4+; an older browser shows a sentence saying so): three.js, plotly.js and one binary
*pack* of the data. The pack is a JSON header (sizes, colours, the camera, the figures with their arrays as
references) followed by typed arrays: the world points of every frame (joints then End Sites, as the 3D view
draws them) and of the original, quantised to 1/4000 of the body's height (or coarser where a 16-bit code
cannot span the clip's extent; error <= half a step: 0.02 units on CMU 01_01's 147-unit body), stored as
second differences along the frames, zigzag-coded, low bytes then high bytes (a smooth motion's steps are small:
they deflate ~4x), the camera rig path the same way, the per-frame joint states (uint8), the mesh template, the
ground segments and every array of the figures (float32, as the live plots draw them; equal arrays, e.g. the
time axis of several traces, stored once).

Safety: every data block is base64 (no ``<`` in it), so no joint name, title or label can end a script early or
open a comment (a joint named ``<!--<script>`` is legal in BVH); the title is HTML-escaped; our own scripts have
``</script`` escaped.

The 3D view is drawn by the one mesh builder of the live view (``_skeleton_mesh.js``) from the same points.
:func:`read_export` decodes a page's pack (tests, or to check what a page holds).
"""
from __future__ import annotations

import base64
import html
import json
import os
import re
import struct
import zlib
from importlib import resources
from pathlib import Path

import numpy as np

from .. import scene3d
from ..core.motion import Motion
from ..io._common import atomic_write_bytes, read_file_head
from .skeleton_view import _PALETTE, MESH_JS

__all__ = ["export_html", "read_export"]

_JOINT, _GHOST = "#2d3748", "#a0aec0"
_MAGIC = b"SNX1"
_STEPS = 4000   # positions are stored to 1/4000 of the body's height (0.04 units on a 150-unit body, ~0.1 px)


def _deflate(data: bytes) -> bytes:
    c = zlib.compressobj(9, zlib.DEFLATED, -15)   # raw deflate: what DecompressionStream("deflate-raw") reads
    return c.compress(data) + c.flush()


def _inflate(data: bytes) -> bytes:
    return zlib.decompress(data, -15)


class _Pack:
    """Typed arrays and a JSON header, written as one binary blob (see the module docstring)."""

    def __init__(self):
        self.arrays: list = []
        self.table: dict = {}
        self._seen: dict = {}
        self.size = 0

    def add(self, name: str, a, codec: str = "raw", step: float | None = None) -> str:
        """Add array ``a`` as ``name`` (``codec="q16d2"``: positions quantised to ``step``, or coarser where the
        extent needs more than 16 bits); an array equal to one already added is shared (its name returned)."""
        a = np.ascontiguousarray(a)
        key = (codec, step, a.dtype.str, a.shape, a.tobytes())
        if key in self._seen:
            return self._seen[key]
        self._seen[key] = name
        entry = {"shape": list(a.shape), "codec": codec}
        if codec == "q16d2":   # positions: 16-bit steps, second differences along axis 0, zigzag, byte planes
            x = a.astype(np.float64).reshape(a.shape[0], -1, a.shape[-1])
            lo, hi = x.min(axis=(0, 1)), x.max(axis=(0, 1))
            step = max(float(step or 0.0), float((hi - lo).max()) / 65535, 1e-12)
            q = np.round((x - lo) / step).astype(np.int64).reshape(a.shape[0], -1)
            d1 = np.diff(q, axis=0, prepend=0) % 65536
            d2 = (np.diff(d1, axis=0, prepend=0) % 65536).astype(np.int64)
            signed = np.where(d2 >= 32768, d2 - 65536, d2)
            zz = ((signed << 1) ^ (signed >> 63)).astype("<u2")
            a = np.concatenate([(zz & 255).astype(np.uint8).ravel(), (zz >> 8).astype(np.uint8).ravel()])
            entry.update(lo=lo.tolist(), step=step, dtype="u1")
        else:
            kind = {"f": "<f4", "u": "<u4", "i": "<i4", "b": "|u1"}[a.dtype.kind]
            if a.dtype == np.uint8 or a.dtype == np.uint16:
                kind = a.dtype.newbyteorder("<").str
            a = a.astype(kind)
            entry["dtype"] = np.dtype(kind).str.lstrip("<|")
        pad = (-self.size) % 8
        self.size += pad
        entry.update(offset=self.size, nbytes=a.nbytes)
        self.arrays.append((pad, a.tobytes()))
        self.size += a.nbytes
        self.table[name] = entry
        return name

    def blob(self, header: dict) -> bytes:
        head = json.dumps(dict(header, arrays=self.table), separators=(",", ":")).encode("utf-8")
        head += b" " * ((-len(head)) % 8)
        body = b"".join(b"\0" * pad + data for pad, data in self.arrays)
        return _MAGIC + struct.pack("<I", len(head)) + head + body


def _unpack_blob(blob: bytes) -> tuple[dict, dict]:
    """(header, {name: ndarray}) of a pack; quantised arrays decoded to float64 (see :func:`read_export`)."""
    if blob[:4] != _MAGIC:
        raise ValueError("not a stagger_nb export pack")
    n = struct.unpack("<I", blob[4:8])[0]
    header = json.loads(blob[8:8 + n])
    body = blob[8 + n:]
    out = {}
    for name, e in header["arrays"].items():
        dt = np.dtype(e["dtype"]).newbyteorder("<")
        raw = np.frombuffer(body, dtype=dt, count=e["nbytes"] // dt.itemsize, offset=e["offset"])
        if e["codec"] == "q16d2":
            F = e["shape"][0]
            half = raw.size // 2
            zz = (raw[:half].astype(np.int64) | (raw[half:].astype(np.int64) << 8)).reshape(F, -1)
            d2 = (zz >> 1) ^ -(zz & 1)
            q = np.cumsum(np.cumsum(d2, axis=0) % 65536, axis=0) % 65536
            x = q.reshape(F, -1, e["shape"][-1]) * e["step"] + np.asarray(e["lo"])
            out[name] = x.reshape(e["shape"])
        else:
            out[name] = raw.reshape(e["shape"])
    return header, out


def _figure_arrays(value, pack: _Pack, prefix: str):
    """A figure dict with its numeric arrays moved into ``pack`` (``{"__sn__": name}`` in their place)."""
    if isinstance(value, dict):
        return {str(k): _figure_arrays(v, pack, f"{prefix}.{k}") for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        if len(value) > 16 and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            value = np.asarray(value, dtype=float)
        else:
            return [_figure_arrays(v, pack, f"{prefix}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, np.ndarray):
        if value.ndim == 1 and value.dtype.kind in "fiu" and value.size:
            return {"__sn__": pack.add(prefix, value.astype(np.float32))}
        return _figure_arrays(value.tolist(), pack, prefix)
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def _figure_dict(fig) -> dict:
    """A plotly figure dict from a dict, a plotly Figure/FigureWidget or a PlotView (``.figure``)."""
    if hasattr(fig, "figure") and not isinstance(fig, dict) and not hasattr(fig, "to_plotly_json"):
        fig = fig.figure
    if hasattr(fig, "to_plotly_json"):
        fig = fig.to_plotly_json()
    if not isinstance(fig, dict):
        raise ValueError(f"obj: a figure must be a plotly figure dict, got {type(fig).__name__}")
    return {"data": fig.get("data", []), "layout": fig.get("layout", {})}


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
    return (session.edited(), session.source, [_figure_dict(f) for f in figures], pose_frames, contacts,
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
    return "<script>" + code.replace("</script", "<\\/script").replace("<!--", "<\\!--") + "</script>"


def _block(block_id: str, data: bytes) -> str:
    """A compressed, base64 data block (its text holds only A-Z a-z 0-9 + / =)."""
    b64 = base64.b64encode(_deflate(data)).decode("ascii")
    return f'<script type="application/octet-stream" id="{block_id}">{b64}</script>'


def _pack_of(motion: Motion, ghost: Motion | None, figures: list, pose_frames, contacts, width: int, height: int,
             autoplay: bool) -> bytes:
    pack = _Pack()
    pts = scene3d.skeleton_points(motion)
    J = motion.num_joints
    cam = scene3d.follow_camera(pts[:, :J], motion.frame_time, "follow", aspect=width / height)
    size = scene3d.body_size(pts[:, :J])
    cell = scene3d.grid_cell(size)
    segs = scene3d.segments(motion)
    tpl = scene3d.mesh_template()
    sk = motion.skeleton
    contact_idx = [(sk.index(j) if isinstance(j, str) else int(j), int(a), int(b)) for j, a, b in contacts]
    step = scene3d.body_size(pts[:, :J]) / _STEPS
    pack.add("points", pts, "q16d2", step)
    pack.add("rig", -cam.rig, "q16d2", step)
    pack.add("states", scene3d.joint_states(motion.num_frames, motion.frame_time, J, pose_frames, contact_idx))
    pack.add("template", np.concatenate([tpl.sphere, tpl.tube]).astype(np.float32))
    pack.add("sphere_index", tpl.sphere_index.reshape(-1).astype(np.uint32))
    pack.add("tube_index", tpl.tube_index.reshape(-1).astype(np.uint32))
    pack.add("bone_colours", scene3d.bone_colours(motion, segs))
    pack.add("grid", scene3d.ground_segments(pts[:, :J], cell, 2 * size, cam.ground))
    has_ghost = ghost is not None and ghost.num_joints == J
    if has_ghost:
        pack.add("ghost", scene3d.skeleton_points(ghost), "q16d2", step)
    radius = scene3d.joint_radius(motion)
    header = {
        "width": int(width), "height": int(height), "num_frames": motion.num_frames, "num_points": pts.shape[1],
        "num_joints": J, "frame_time": motion.frame_time, "autoplay": bool(autoplay), "names": list(sk.names),
        "segments": [int(i) for i in segs.reshape(-1)], "sphere_vertices": len(tpl.sphere),
        "tube_vertices": len(tpl.tube), "joint_radius": radius, "bone_radius": 0.45 * radius,
        "palette": _PALETTE, "ghost_colour": _GHOST, "has_ghost": has_ghost,
        "camera": {"position": list(cam.position), "target": list(cam.target), "fov": cam.fov, "near": cam.near,
                   "far": cam.far},
        "grid_cell": cell,
        "figures": [_figure_arrays(f, pack, f"figures[{i}]") for i, f in enumerate(figures)],
    }
    return pack.blob(header)


def export_html(obj, path, *, width: int = 640, height: int = 480, title: str | None = None,
                autoplay: bool = True) -> Path:
    """Write one self-contained, offline HTML page: ``obj`` (a Motion, a Session, or an editor with ``.session``
    and ``.figures()`` / ``.plots``) playing in 3D beside its plots.

    The file is written atomically (a temporary file, then a rename); ``path`` must not be the session's source
    clip, nor an existing file that is not HTML. Returns the path. Size: ~2.1 MB of compressed scripts (plotly.js
    and three.js) plus the compressed data (~0.2 MB for CMU 01_01's 2,751 frames, ~0.4 MB with the original).
    """
    motion, ghost, figures, pose_frames, contacts, source_path, kind = _unpack(obj)
    path = os.fspath(path)
    _refuse(path, source_path)
    import plotly.offline
    three_js = resources.files("pythreejs").joinpath("static", "three.js").read_bytes()
    player_js = Path(__file__).with_name("_export_player.js").read_text(encoding="utf-8")
    blob = _pack_of(motion, ghost, figures, pose_frames, contacts, width, height, autoplay)
    title = title or f"stagger_nb: {kind} ({motion.num_frames} frames, {motion.duration:.2f} s)"
    legend = " ".join(
        f'<span><i style="background:{col}"></i>{name}</span>' for name, col in
        [("left", scene3d.SIDE_COLOURS["left"]), ("right", scene3d.SIDE_COLOURS["right"]),
         ("centre", scene3d.SIDE_COLOURS["centre"])] + ([("original (ghost)", _GHOST)] if ghost is not None else [])
        + ([("staggered pose", "#dd6b20")] if len(pose_frames) else [])
        + ([("contact", "#38a169")] if contacts else []))
    plots = "".join(f'<div class="sn-plot" id="sn-plot-{i}"></div>' for i in range(len(figures)))
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>
body {{ font-family: system-ui, sans-serif; margin: 12px; color: #2d3748; }}
#sn-wrap {{ display: flex; flex-wrap: wrap; gap: 16px; align-items: flex-start; }}
#sn-view canvas {{ border: 1px solid #e2e8f0; display: block; cursor: grab; }}
#sn-bar {{ display: flex; gap: 8px; align-items: center; margin-top: 6px; }}
#sn-scrub {{ flex: 1; }}
#sn-status {{ color: #c53030; font-size: 13px; }}
.sn-legend span {{ margin-right: 10px; font-size: 12px; display: inline-block; white-space: nowrap; }}
.sn-legend i {{ display: inline-block; width: 14px; height: 5px; margin-right: 4px; vertical-align: middle; }}
.sn-plot {{ width: 560px; min-height: 260px; }}
</style></head>
<body><h3>{html.escape(title)}</h3>
<div id="sn-status">loading&hellip;</div>
<div id="sn-wrap"><div id="sn-view" style="width:{int(width)}px">
<div id="sn-bar"><button id="sn-play">&#9654; play</button><input id="sn-scrub" type="range" min="0" value="0" step="1">
<span id="sn-time"></span></div>
<div class="sn-legend">{legend} <span id="sn-grid-note"></span></div>
</div><div id="sn-plots">{plots}</div></div>
{_block("sn-lib-three", three_js)}
{_block("sn-lib-plotly", plotly.offline.get_plotlyjs().encode("utf-8"))}
{_block("sn-data", blob)}
{_script(MESH_JS)}
{_script(player_js)}
</body></html>
"""
    atomic_write_bytes(path, page.encode("utf-8"))
    return Path(path)


_BLOCK = re.compile(r'<script type="application/octet-stream" id="(sn-[a-z-]+)">([A-Za-z0-9+/=]*)</script>')


def read_export(path) -> dict:
    """What an exported page holds: ``{"header": dict, "arrays": {name: ndarray}, "libraries": {name: bytes}}``
    (``points``, ``rig`` and ``ghost`` decoded to float64 from their quantised form; the header's ``arrays`` says
    each one's ``step``)."""
    text = Path(path).read_text(encoding="utf-8")
    blocks = {m.group(1): _inflate(base64.b64decode(m.group(2))) for m in _BLOCK.finditer(text)}
    if "sn-data" not in blocks:
        raise ValueError(f"path: {path} holds no stagger_nb export data block")
    header, arrays = _unpack_blob(blocks.pop("sn-data"))
    return {"header": header, "arrays": arrays, "libraries": blocks}
