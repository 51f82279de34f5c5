"""The one merged skeleton mesh's constant parts: the bones' colours by body side, the unit sphere and tube it
is made of, its triangles and the joint each belongs to, its attribute arrays that do not change with the frame.

The 3D view draws the whole skeleton as ONE indexed triangle mesh (a sphere per joint, an open tube per bone)
whose vertices the browser computes for each shown frame from the world points of that frame (the one builder:
``widgets/_skeleton_mesh.js``; ``tests/mesh_reference.py`` is its naive twin for the tests). A handful of widget
models instead of one per bone, joint, material and keyframe track: what JupyterLab restores quickly after a page
reload.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.body import joint_sides
from ..core.motion import Motion
from .skeleton import segments

SIDE_COLOURS = {"left": "#2b6cb0", "right": "#c53030", "centre": "#4a5568"}


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
