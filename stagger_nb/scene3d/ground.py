"""The ground grid of a 3D view: a round cell size from the body height and the cell-edge segments over the
root's ground track."""
from __future__ import annotations

import numpy as np


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
