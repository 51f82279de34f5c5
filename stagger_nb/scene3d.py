"""What the 3D views show, as pure functions on arrays: animation tracks, bone geometry, sides (colours),
a camera that follows the root, trails and highlight keyframes. Used by :class:`stagger_nb.widgets.SkeletonView`
(pythreejs) and :func:`stagger_nb.widgets.export_html` (a standalone three.js page); no widgets here.

Glossary: F frames, J joints, B bones (one per non-root joint plus one per End Site). Positions are file units,
times seconds, quaternions (x, y, z, w) (three.js uses the same order). The vertical axis is y (BVH convention).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import fftconvolve

from .core.body import joint_sides
from .core.kinematics import forward_kinematics, skeleton_height
from .core.motion import Motion
from .core.rotations import quat_rotate

__all__ = ["Tracks", "motion_tracks", "Bone", "bones", "joint_sides", "SIDE_COLOURS", "Camera", "follow_camera",
           "frame_box", "fit_distance", "project", "look_at_quaternion", "drawn_height_fraction", "grid_cell",
           "ground_segments", "highlight_keys", "body_size",
           "skeleton_points", "segments", "MeshTemplate", "mesh_template", "joint_states",
           "trail_segments", "mesh_index", "hex_rgb", "bone_colours",
           "triangle_joints", "mesh_constants"]

SIDE_COLOURS = {"left": "#2b6cb0", "right": "#c53030", "centre": "#4a5568"}
_STATIC_TOL = 1e-6


@dataclass(frozen=True)
class Tracks:
    """Keyframe tracks of one motion for a joint hierarchy (node j = joint j).

    times : (F,) float32 seconds
    root_position : (F, 3) float32, the root node's position
    quats : dict joint -> (F, 4) float32 local rotations (x, y, z, w), only joints that move
    static_quats : (J, 4) float32 rotation of every joint at frame 0 (used for joints without a track)
    translations : dict joint -> (F, 3) float32 local translations of non-root joints that are animated
    """
    times: np.ndarray
    root_position: np.ndarray
    quats: dict
    static_quats: np.ndarray
    translations: dict

    @property
    def nbytes(self) -> int:
        """Bytes of all arrays (what goes over the wire once per motion, binary)."""
        return int(self.times.nbytes + self.root_position.nbytes + sum(a.nbytes for a in self.quats.values())
                   + sum(a.nbytes for a in self.translations.values()))


def motion_tracks(motion: Motion) -> Tracks:
    """Split ``motion`` into keyframe tracks; joints whose rotation never changes (max |Δq| ≤ 1e-6) get none."""
    q = np.asarray(motion.local_quats, dtype=np.float32)
    moving = np.abs(q - q[:1]).max(axis=(0, 2)) > _STATIC_TOL
    quats = {j: np.ascontiguousarray(q[:, j]) for j in range(motion.num_joints) if moving[j]}
    trans = {}
    if motion.local_translations is not None:
        t = np.asarray(motion.local_translations, dtype=np.float32)
        for j in range(1, motion.num_joints):
            if np.abs(t[:, j] - t[:1, j]).max() > _STATIC_TOL:
                trans[j] = np.ascontiguousarray(t[:, j])
    return Tracks(times=(np.arange(motion.num_frames) * motion.frame_time).astype(np.float32),
                  root_position=np.ascontiguousarray(motion.root_positions, dtype=np.float32),
                  quats=quats, static_quats=np.ascontiguousarray(q[0]), translations=trans)


@dataclass(frozen=True)
class Bone:
    """A bone drawn as a cylinder in its parent joint's frame: from the joint origin to ``offset``.

    parent : joint index the cylinder hangs on; child : joint index at its far end, or -1 for an End Site;
    position (3,), quaternion (4,) (x, y, z, w), length : the unit-height cylinder's placement (y axis → offset).
    """
    parent: int
    child: int
    position: tuple
    quaternion: tuple
    length: float


def _y_to(v: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) rotating +y onto the direction of ``v (3,)`` (identity for ~zero v)."""
    n = float(np.linalg.norm(v))
    if n < 1e-12:
        return np.array([0.0, 0.0, 0.0, 1.0])
    d = v / n
    c = float(d[1])                       # cos of the angle between +y and d
    if c < -1 + 1e-9:                     # antipodal: half turn about x
        return np.array([1.0, 0.0, 0.0, 0.0])
    axis = np.array([d[2], 0.0, -d[0]])   # y × d
    q = np.array([axis[0], axis[1], axis[2], 1.0 + c])
    return q / np.linalg.norm(q)


def bones(motion: Motion) -> list[Bone]:
    """One bone per non-root joint (offset from the skeleton; an animated translation uses frame 0) and one per
    End Site; zero-length bones are skipped."""
    sk = motion.skeleton
    off = np.asarray(sk.offsets, dtype=float)
    if motion.local_translations is not None:
        off = np.asarray(motion.local_translations[0], dtype=float)
    out = []
    pairs = [(int(sk.parents[j]), j, off[j]) for j in range(1, sk.num_joints)]
    pairs += [(int(j), -1, np.asarray(e, dtype=float)) for j, e in sorted(sk.end_sites.items())]
    for p, c, v in pairs:
        length = float(np.linalg.norm(v))
        if length < 1e-9:
            continue
        out.append(Bone(p, c, tuple(float(x) for x in v / 2), tuple(float(x) for x in _y_to(v)), length))
    return out


def body_size(positions: np.ndarray) -> float:
    """The character's drawn height scale, file units: the median over frames of the vertical (y) extent of
    ``positions (F, J, 3)``."""
    ext = positions[..., 1].max(axis=1) - positions[..., 1].min(axis=1)
    return float(max(np.median(ext), 1e-9))


def grid_cell(size: float) -> float:
    """A round grid spacing (1, 2 or 5 × 10^k) near a quarter of ``size`` (the body height)."""
    target = max(size / 4.0, 1e-9)
    k = np.floor(np.log10(target))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10 ** k >= target * 0.7:
            return float(m * 10 ** k)
    return float(10 ** (k + 1))


def ground_segments(positions: np.ndarray, cell: float, margin: float, ground: float,
                    max_segments: int = 40000) -> np.ndarray:
    """A ground grid as short line segments ``(2 N, 3)`` float32 (pairs of end points), one per cell edge, over
    the root's ground track (x, z) of ``positions (F, J, 3)`` plus ``margin``, at height ``ground``.

    Cell-sized segments, not lines across the whole ground: a GL line with an end behind the camera may be
    dropped entirely (seen with SwiftShader), which left the ground near a following camera blank. The cell
    grows (×2) until the grid has at most ``max_segments`` segments (:func:`ground_extent`, then
    :func:`ground_grid`)."""
    lo, hi, cell = ground_extent(positions, cell, margin, max_segments)
    return ground_grid(lo, hi, cell, ground)


def ground_extent(positions: np.ndarray, cell: float, margin: float, max_segments: int = 40000):
    """The ground grid's corners ``lo, hi`` (x, z), each (2,), multiples of the returned ``cell`` (``cell``
    doubled until at most ``max_segments`` cell edges), around the root's track of ``positions (F, J, 3)``
    plus ``margin``. Equal extents give equal grids: a view compares them before building one."""
    xz = np.asarray(positions[:, 0, [0, 2]], dtype=float)
    lo = np.floor((xz.min(axis=0) - margin) / cell) * cell
    hi = np.ceil((xz.max(axis=0) + margin) / cell) * cell
    while True:
        nx, nz = np.round((hi - lo) / cell).astype(int)
        if 2 * nx * nz + nx + nz <= max_segments:
            return lo, hi, float(cell)
        cell *= 2
        lo, hi = np.floor(lo / cell) * cell, np.ceil(hi / cell) * cell


def ground_grid(lo, hi, cell: float, ground: float) -> np.ndarray:
    """Cell-edge segments ``(2 N, 3)`` float32 of the grid from ``lo`` to ``hi`` (x, z; multiples of ``cell``)
    at height ``ground``: every edge along x, then every edge along z."""
    nx, nz = np.round((np.asarray(hi) - np.asarray(lo)) / cell).astype(int)
    xs = lo[0] + cell * np.arange(nx + 1)
    zs = lo[1] + cell * np.arange(nz + 1)
    X, Z = np.meshgrid(xs[:-1], zs, indexing="ij")          # edges along x
    a = np.stack([X, Z], -1).reshape(-1, 2)
    along_x = np.stack([a, a + [cell, 0.0]], axis=1)
    X, Z = np.meshgrid(xs, zs[:-1], indexing="ij")          # edges along z
    b = np.stack([X, Z], -1).reshape(-1, 2)
    along_z = np.stack([b, b + [0.0, cell]], axis=1)
    seg = np.concatenate([along_x, along_z]).reshape(-1, 2)
    out = np.empty((len(seg), 3), dtype=np.float32)
    out[:, 0], out[:, 1], out[:, 2] = seg[:, 0], ground, seg[:, 1]
    return out


@dataclass(frozen=True)
class Camera:
    """A perspective camera riding on a rig that follows the character.

    rig : (F, 3) rig position per frame (world); position, target : (3,) camera position and look-at point
    relative to the rig (:func:`follow_camera` puts the look-at point at the rig's origin);
    fov : vertical field of view, degrees; ground : y of the ground plane;
    near, far : clip distances (file units).
    """
    rig: np.ndarray
    position: tuple
    target: tuple
    fov: float
    ground: float
    near: float
    far: float

    def world(self, frame: int):
        """World camera position and target at ``frame``, each (3,)."""
        r = self.rig[min(max(int(frame), 0), len(self.rig) - 1)]
        return np.asarray(self.position) + r, np.asarray(self.target) + r


def _smooth(x: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian smoothing (σ in samples) along axis 0 of ``x (n,)`` or ``(n, k)`` (each column alone), with the
    signal continued by point reflection at both ends (x[0] - (x[k] - x[0])), so a steady linear track comes out
    unchanged, ends included.

    The kernel is scipy's ``gaussian_filter1d`` kernel (radius ``int(4 σ + 0.5)``, beyond the reflection the
    nearest value), applied by FFT: σ is ~60 samples for a 0.5 s smoothing at 120 Hz, where the direct sum cost
    ~0.25 ms per column and the FFT ~0.05 ms (same values to ~1e-12 relative)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    pad = min(n - 1, int(np.ceil(4 * sigma)))
    if pad < 1:
        return x.copy()
    left = 2 * x[0] - x[pad:0:-1]
    right = 2 * x[-1] - x[-2:-pad - 2:-1]
    radius = int(4.0 * sigma + 0.5)
    ext = np.concatenate([left, x, right])
    ext = np.pad(ext, [(radius, radius)] + [(0, 0)] * (x.ndim - 1), mode="edge")
    k = np.arange(-radius, radius + 1, dtype=float)
    w = np.exp(-0.5 * (k / sigma) ** 2)
    w = (w / w.sum()).reshape((-1,) + (1,) * (x.ndim - 1))
    y = fftconvolve(ext, w, mode="valid", axes=0)
    return y[pad:pad + n]


_VIEW_DIR = np.array([0.62, 0.28, 0.73])   # from the target towards the camera: front-right, slightly above


def fit_distance(corners: np.ndarray, d: np.ndarray, fov: float, aspect: float, margin: float) -> float:
    """The smallest distance along the unit direction ``d`` from the origin at which a camera looking at the
    origin (up = +y, :func:`project`'s camera) sees every point of ``corners (N, 3)`` inside the canvas, ``margin``
    (a fraction of each half side) left free at the edges. Closed form: the camera's axes do not depend on the
    distance, a corner ``c`` is at depth ``dist - c·d`` and inside where ``f |c·x| / aspect <= margin (dist - c·d)``
    and ``f |c·y| <= margin (dist - c·d)``, ``f = 1 / tan(fov / 2)`` (a bisection on :func:`project` took 20 ms)."""
    x, y, z = _camera_basis(np.asarray(d, dtype=float), np.zeros(3), (0.0, 1.0, 0.0))
    c = np.asarray(corners, dtype=float)
    f = 1.0 / np.tan(np.radians(fov) / 2)
    need = np.maximum(f * np.abs(c @ x) / (aspect * margin), f * np.abs(c @ y) / margin)
    return float(max(np.max(c @ z + need), 0.0) * (1 + 1e-12) + 1e-9)


#: the view directions "frame all" chooses from: the default one turned about the vertical, 10° apart
_ALL_AZIMUTHS = np.radians(np.arange(0.0, 360.0, 10.0))


def frame_box(corners: np.ndarray, fov: float, aspect: float, margin: float = 0.94) -> tuple[np.ndarray, float]:
    """``(d, dist)``: the unit view direction (from the box's centre towards the camera) and distance at which
    ``corners (8, 3)`` of a box around the origin fill the canvas: of the default direction turned about the
    vertical in 10° steps (its elevation kept), the one that sees the whole box from nearest (a walk across
    the room is seen from its side, so the figure is as large as the whole clip allows), at
    :func:`fit_distance` (``margin`` of each half side). Ties go to the smaller turn (the default first)."""
    d0 = _VIEW_DIR / np.linalg.norm(_VIEW_DIR)
    best = None
    for a in _ALL_AZIMUTHS:
        ca, sa = np.cos(a), np.sin(a)
        d = np.array([ca * d0[0] + sa * d0[2], d0[1], -sa * d0[0] + ca * d0[2]])
        dist = fit_distance(corners, d, fov, aspect, margin)
        if best is None or dist < best[1] * (1 - 1e-9):
            best = (d, dist)
    return best


def follow_camera(positions: np.ndarray, frame_time: float, mode: str = "follow", aspect: float = 480 / 380,
                  fov: float = 40.0, fill: float = 0.62, smooth_s: float = 0.5, pad: float = 0.0) -> Camera:
    """Camera framing for ``positions (F, P, 3)`` (joints, and the End Sites when given: the top of the head).

    ``mode="follow"``: the rig follows the root's ground track (x, z) smoothed by a Gaussian of σ = ``smooth_s``
    seconds (centred, so a steady run is tracked without lag) and the camera stands at the distance where the
    body's height (:func:`body_size`) fills ``fill`` of the canvas height, or further when the box every frame
    covers around the rig (ground to the highest point of the clip, ``pad`` added on each side: the joints'
    spheres) would not fit the canvas: nothing of the skeleton leaves the view in any frame. ``mode="all"``: a
    fixed rig at the centre of the box everything the clip covers (``pad`` added), the camera where that box
    fills the canvas (:func:`frame_box`: the side of the box it is seen from nearest, the box's corners at the
    canvas's edges less a 6 % margin).
    """
    if mode not in ("follow", "all"):
        raise ValueError(f"mode: expected 'follow' or 'all', got {mode!r}")
    P = np.asarray(positions)
    F = P.shape[0]
    # one pass over the points for each extent (float32 points: min / max are exact, then float64)
    y = P[..., 1]
    top, bottom = y.max(axis=1).astype(float), y.min(axis=1).astype(float)
    h = float(max(np.median(top - bottom), 1e-9))                 # body_size(P), from the same extents
    ground = float(bottom.min())
    # per coordinate: a (N, 3).min(axis=0) reduces ~10x slower than three strided 1-D reductions
    lo = np.array([float(P[..., 0].min()), ground, float(P[..., 2].min())])
    hi = np.array([float(P[..., 0].max()), float(top.max()), float(P[..., 2].max())])
    half = np.radians(fov) / 2
    d = _VIEW_DIR / np.linalg.norm(_VIEW_DIR)
    if mode == "follow":
        sigma = max(smooth_s / frame_time, 1e-3)
        rig = np.zeros((F, 3))
        rig[:, [0, 2]] = _smooth(P[:, 0, [0, 2]], sigma)
        rig[:, 1] = ground
        # the box of the clip around the rig: ground to the highest point of any frame (the head is never cut);
        # sideways the reach from the track of 96 % of the points (a turn the smoothed track cuts short would
        # otherwise shrink every frame's figure for the few frames it lasts)
        rel_x, rel_z = P[..., 0] - rig[:, None, 0], P[..., 2] - rig[:, None, 2]
        (x0, x1), (z0, z1) = np.percentile(rel_x, [2, 98]), np.percentile(rel_z, [2, 98])
        box_lo = np.array([float(x0) - pad, -pad, float(z0) - pad])
        box_hi = np.array([float(x1) + pad, float(top.max()) - ground + pad, float(z1) + pad])
        # its vertical centre: steady (no bobbing camera), the whole clip's box, not the median pose's
        centre_y = float(box_lo[1] + box_hi[1]) / 2
        dist = h / (2 * fill * np.tan(half))
        dist = max(dist, h * 0.5 / (fill * np.tan(half) * aspect))   # a tall narrow canvas: fit the width too
        target = np.array([0.0, centre_y, 0.0])
        corners = np.array([[x, y, z] for x in (box_lo[0], box_hi[0]) for y in (box_lo[1], box_hi[1])
                            for z in (box_lo[2], box_hi[2])]) - target
        dist = max(dist, fit_distance(corners, d, fov, aspect, margin=0.94))
    else:
        c = (lo + hi) / 2
        rig = np.tile([c[0], ground, c[2]], (F, 1))
        target = np.array([0.0, c[1] - ground, 0.0])
        corners = np.array([[x, y, z] for x in (lo[0] - pad, hi[0] + pad) for y in (lo[1] - pad, hi[1] + pad)
                            for z in (lo[2] - pad, hi[2] + pad)]) - c
        d, dist = frame_box(corners, fov, aspect)
    # the look-at point is the rig's origin (the rig carries its height): a page reload restores the pythreejs
    # camera but OrbitControls then aims it at (0, 0, 0) (seen in JupyterLab: after a reload the view looked
    # down at the feet, the head cut off), so the framing must not depend on the controls' target
    rig = rig + target
    pos = d * dist
    target = np.zeros(3)
    return Camera(rig=rig.astype(np.float32), position=tuple(float(x) for x in pos),
                  target=tuple(float(x) for x in target), fov=float(fov), ground=ground,
                  near=float(dist) * 0.01, far=float(dist) * 50 + float(hi[0] - lo[0] + hi[2] - lo[2]))


def _camera_basis(eye, target, up):
    """The camera's world axes ``(x, y, z)``, each (3,): z from ``target`` to ``eye``, x = up × z, y = z × x."""
    eye, target, up = (np.asarray(v, dtype=float) for v in (eye, target, up))
    z = eye - target
    z /= np.linalg.norm(z)
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    return x, np.cross(z, x), z


def project(points: np.ndarray, eye, target, fov: float, width: int, height: int, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """Pixel coordinates ``(N, 2)`` (x right, y down, origin top-left) of world ``points (N, 3)`` seen by a
    perspective camera at ``eye`` looking at ``target`` (three.js ``lookAt`` + ``PerspectiveCamera``)."""
    x, y, z = _camera_basis(eye, target, up)
    rel = np.asarray(points, dtype=float) - np.asarray(eye, dtype=float)
    cx, cy, cz = rel @ x, rel @ y, rel @ z
    f = 1.0 / np.tan(np.radians(fov) / 2)
    aspect = width / height
    ndc_x = f / aspect * cx / -cz
    ndc_y = f * cy / -cz
    return np.stack([(ndc_x + 1) / 2 * width, (1 - ndc_y) / 2 * height], axis=1)


def look_at_quaternion(eye, target, up=(0.0, 1.0, 0.0)) -> tuple:
    """Rotation (x, y, z, w) of a camera at ``eye`` looking at ``target`` (its -z axis towards the target, +y
    towards ``up``), as three.js ``Object3D.lookAt`` sets it for a camera without a parent."""
    from scipy.spatial.transform import Rotation
    x, y, z = _camera_basis(eye, target, up)
    return tuple(float(c) for c in Rotation.from_matrix(np.stack([x, y, z], axis=1)).as_quat())


def drawn_height_fraction(points: np.ndarray, camera: Camera, frame: int, width: int, height: int) -> float:
    """Vertical extent on the canvas of ``points (J, 3)`` (the pose at ``frame``), as a fraction of ``height``."""
    eye, target = camera.world(frame)
    px = project(points, eye, target, camera.fov, width, height)
    return float((px[:, 1].max() - px[:, 1].min()) / height)


def highlight_keys(num_frames: int, frame_time: float, num_joints: int, pose_frames=(), contacts=(),
                   pose_window_s: float = 0.05):
    """Per-joint state over time for the sphere colours (:func:`joint_states`) as step keys: returns
    ``{joint: (times (K,) float32, states (K,) uint8)}`` for joints whose state ever changes or is not 0."""
    state = joint_states(num_frames, frame_time, num_joints, pose_frames, contacts, pose_window_s)
    out = {}
    for j in range(num_joints):
        s = state[:, j]
        if np.any(s != s[0]) or s[0] != 0:
            idx = np.concatenate([[0], np.flatnonzero(s[1:] != s[:-1]) + 1])
            out[j] = ((idx * frame_time).astype(np.float32), s[idx])
    return out


def world_positions(motion: Motion) -> np.ndarray:
    """(F, J, 3) float32 world joint positions (forward kinematics), for trails and framing."""
    p, _ = forward_kinematics(motion)
    return np.ascontiguousarray(p, dtype=np.float32)


def joint_radius(motion: Motion) -> float:
    """Sphere radius for joints: 2.2 % of the skeleton's rest extent."""
    return 0.022 * skeleton_height(motion)


# -- one merged skeleton mesh ----------------------------------------------------------------------------------
# The 3D view draws the whole skeleton as ONE indexed triangle mesh (a sphere per joint, an open tube per bone)
# whose vertices the browser computes for each shown frame from the world points of that frame (the one builder:
# ``widgets/_skeleton_mesh.js``; ``tests/mesh_reference.py`` is its naive twin for the tests). A handful of widget
# models instead of one per bone, joint, material and keyframe track: what JupyterLab restores quickly after a page
# reload.

def skeleton_points(motion: Motion) -> np.ndarray:
    """World positions of the joints and then the End Sites, ``(F, J + E, 3)`` float32, file units.

    End Site k (the k-th of ``sorted(skeleton.end_sites.items())``) is point ``J + k``: its joint's world
    position plus the joint's world rotation applied to the End Site offset."""
    p, wq = forward_kinematics(motion)
    ends = sorted(motion.skeleton.end_sites.items())
    if not ends:
        return np.ascontiguousarray(p, dtype=np.float32)
    idx = np.array([j for j, _ in ends], dtype=int)
    off = np.array([e for _, e in ends], dtype=float)
    out = np.empty((p.shape[0], p.shape[1] + len(ends), 3), dtype=np.float32)   # written once, as float32
    out[:, :p.shape[1]] = p
    out[:, p.shape[1]:] = p[:, idx] + quat_rotate(wq[:, idx], off)
    return out


def segments(motion: Motion) -> np.ndarray:
    """Bones as point-index pairs ``(B, 2)`` int (parent joint, child joint or End Site point ``J + k``), the
    order of :func:`bones` (non-root joints, then End Sites; zero-length ones skipped)."""
    sk = motion.skeleton
    J = sk.num_joints
    off = np.asarray(sk.offsets if motion.local_translations is None else motion.local_translations[0], float)
    pairs = [(int(sk.parents[j]), j, off[j]) for j in range(1, J)]
    pairs += [(int(j), J + k, np.asarray(e, float)) for k, (j, e) in enumerate(sorted(sk.end_sites.items()))]
    out = [(a, b) for a, b, v in pairs if np.linalg.norm(v) >= 1e-9]
    return np.array(out, dtype=int).reshape(-1, 2)


def hex_rgb(colour: str) -> list:
    """``"#rrggbb"`` -> ``[r, g, b]`` in [0, 1]."""
    return [int(colour[i:i + 2], 16) / 255 for i in (1, 3, 5)]


def bone_colours(motion: Motion, segs: np.ndarray | None = None) -> np.ndarray:
    """``(B, 3)`` float32 RGB in [0, 1] of each bone of ``segs`` (default :func:`segments`): the
    :data:`SIDE_COLOURS` of its child joint's body side (of its parent's for an End Site). The one definition
    the 3D view and the exported page both draw."""
    segs = segments(motion) if segs is None else segs
    J = motion.num_joints
    sides = joint_sides(motion.skeleton.names)
    rgb = [hex_rgb(SIDE_COLOURS[sides[b] if b < J else sides[a]]) for a, b in segs]
    return np.asarray(rgb, np.float32).reshape(-1, 3)


@dataclass(frozen=True)
class MeshTemplate:
    """Unit shapes the skeleton mesh is made of, each vertex a row ``(x, y, z, nx, ny, nz)`` float32.

    sphere : (Vs, 6) unit sphere (radius 1, centre 0); sphere_index : (Ts, 3) triangles (counter-clockwise
    seen from outside); tube : (Vt, 6) open cylinder of radius 1 from y = 0 to y = 1; tube_index : (Tt, 3).
    """
    sphere: np.ndarray
    sphere_index: np.ndarray
    tube: np.ndarray
    tube_index: np.ndarray


def _grid_index(rows: int, cols: int) -> np.ndarray:
    """Triangles of a (rows + 1) x (cols + 1) vertex grid, row-major, two per cell."""
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    a = (r * (cols + 1) + c).ravel()
    b, d = a + cols + 1, a + 1
    return np.stack([np.stack([a, b, d], 1), np.stack([b, b + 1, d], 1)], 1).reshape(-1, 3)


def mesh_template(radial: int = 8, rings: int = 6) -> MeshTemplate:
    """A lat-long unit sphere (``2 radial`` around, ``rings`` from pole to pole) and an open unit tube
    (``radial`` sides)."""
    th = np.linspace(0, np.pi, rings + 1)[:, None]                 # from +y down
    ph = np.linspace(0, 2 * np.pi, 2 * radial + 1)[None, :]
    n = np.stack([np.sin(th) * np.sin(ph), np.cos(th) * np.ones_like(ph), np.sin(th) * np.cos(ph)], -1)
    sphere = np.concatenate([n, n], -1).reshape(-1, 6)
    ph = np.linspace(0, 2 * np.pi, radial + 1)
    ring = np.stack([np.sin(ph), np.zeros_like(ph), np.cos(ph)], -1)
    tube = np.concatenate([np.concatenate([ring + [0, y, 0], ring], -1) for y in (1.0, 0.0)])
    return MeshTemplate(sphere.astype(np.float32), _grid_index(rings, 2 * radial).astype(np.uint32),
                        tube.astype(np.float32), _grid_index(1, radial).astype(np.uint32))


def mesh_index(num_joints: int, num_bones: int, template: MeshTemplate):
    """Triangles of the merged mesh ``(T, 3)`` uint32 and, for picking, the joint each triangle belongs to
    ``(T,)`` int (a bone belongs to its parent joint, the one that rotates it: pass ``segs[:, 0]``)."""
    vs, vt = len(template.sphere), len(template.tube)
    sph = template.sphere_index[None] + (vs * np.arange(num_joints))[:, None, None]
    tub = template.tube_index[None] + (num_joints * vs + vt * np.arange(num_bones))[:, None, None]
    return np.concatenate([sph.reshape(-1, 3), tub.reshape(-1, 3)]).astype(np.uint32)


def triangle_joints(num_joints: int, segs: np.ndarray, template: MeshTemplate) -> np.ndarray:
    """``(T,)`` int: the joint each triangle of the merged mesh (:func:`mesh_index`'s order: the spheres, then
    the bones' tubes) belongs to, a bone's being its parent joint (what a click on it selects)."""
    return np.concatenate([np.repeat(np.arange(num_joints), len(template.sphere_index)),
                           np.repeat(np.asarray(segs, int).reshape(-1, 2)[:, 0], len(template.tube_index))])


def mesh_constants(num_joints: int, segs: np.ndarray, template: MeshTemplate, joint_rgb, bone_rgb: np.ndarray):
    """The merged mesh's attribute arrays that do not change with the frame, ``(V, 3)`` float32 each
    (:func:`mesh_index`'s vertex order: ``num_joints`` spheres, then one tube per bone of ``segs``): positions
    zero (the browser writes every shown frame's, ``_skeleton_mesh.js``), the spheres' normals (the unit
    sphere's; the tubes' are per frame too) and the colours (``joint_rgb`` on every sphere, each bone's row of
    ``bone_rgb (B, 3)`` on its tube)."""
    J, vs, vt = num_joints, len(template.sphere), len(template.tube)
    V = J * vs + len(segs) * vt
    nrm = np.zeros((V, 3), np.float32)
    nrm[:J * vs] = np.tile(template.sphere[:, 3:], (J, 1))
    col = np.empty((V, 3), np.float32)
    col[:J * vs] = np.asarray(joint_rgb, np.float32)
    col[J * vs:] = np.repeat(np.asarray(bone_rgb, np.float32).reshape(-1, 3), vt, axis=0)
    return np.zeros((V, 3), np.float32), nrm, col


def joint_states(num_frames: int, frame_time: float, num_joints: int, pose_frames=(), contacts=(),
                 pose_window_s: float = 0.05) -> np.ndarray:
    """Per-frame joint state ``(F, J)`` uint8 for the sphere colours: 0 plain, 1 at a staggered-pose frame
    (± ``pose_window_s`` so it is seen while playing), 2 in contact (wins over 1). ``contacts``:
    ``[(joint_index, start, end), ...]`` half-open frame ranges."""
    F = int(num_frames)
    pose = np.zeros(F, dtype=bool)
    w = max(1, int(round(pose_window_s / frame_time)))
    for p in np.asarray(pose_frames, dtype=int).reshape(-1):
        if 0 <= p < F:
            pose[max(0, p - w):min(F, p + w + 1)] = True
    state = np.zeros((F, int(num_joints)), dtype=np.uint8)
    state[pose] = 1
    for j, a, b in contacts:
        state[max(0, int(a)):min(F, int(b)), int(j)] = 2
    return state


def trail_segments(points: np.ndarray, joints, frame: int, window: int) -> np.ndarray:
    """Line-segment end points ``(len(joints) * 2 window * 2, 3)`` float32 of the trails of ``joints`` (point
    indices into ``points (F, P, 3)``) over frames ``frame - window .. frame + window``: segment k of a joint
    joins frames ``a = frame - window + k`` and ``a + 1``, both clamped to the clip (outside it: a point)."""
    F = points.shape[0]
    a = np.clip(int(frame) - int(window) + np.arange(2 * int(window)), 0, F - 1)
    b = np.clip(int(frame) - int(window) + np.arange(2 * int(window)) + 1, 0, F - 1)
    out = [np.stack([points[a, j], points[b, j]], 1).reshape(-1, 3) for j in joints]
    return np.concatenate(out).astype(np.float32) if out else np.zeros((0, 3), np.float32)
