"""The camera of a 3D view: a rig that follows the root's smoothed ground track (or frames the whole clip), the
distance at which a box fits the canvas, and the projection three.js does (to check what is drawn where)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import fftconvolve


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
