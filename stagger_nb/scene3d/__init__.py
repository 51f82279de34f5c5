"""What the 3D views show, as pure functions on arrays: animation tracks, bone geometry, sides (colours),
a camera that follows the root, trails and highlight keyframes. Used by :class:`stagger_nb.widgets.SkeletonView`
(pythreejs) and :func:`stagger_nb.widgets.export_html` (a standalone three.js page); no widgets here.

Glossary: F frames, J joints, B bones (one per non-root joint plus one per End Site). Positions are file units,
times seconds, quaternions (x, y, z, w) (three.js uses the same order). The vertical axis is y (BVH convention).

One module per job: :mod:`.skeleton` (tracks, bones, world points, sizes), :mod:`.ground` (the grid),
:mod:`.camera` (follow / frame-all camera, projection), :mod:`.mesh` (the merged skeleton mesh's constant parts
and the bones' colours), :mod:`.highlights` (joint states, trails). Every name is importable from here.
"""
from __future__ import annotations

from ..core.body import joint_sides
from .camera import Camera, drawn_height_fraction, fit_distance, follow_camera, frame_box, look_at_quaternion, project
from .camera import _smooth as _smooth
from .ground import grid_cell, ground_segments
from .ground import ground_extent as ground_extent
from .ground import ground_grid as ground_grid
from .highlights import highlight_keys, joint_states, trail_segments
from .mesh import (
    SIDE_COLOURS,
    MeshTemplate,
    bone_colours,
    hex_rgb,
    mesh_constants,
    mesh_index,
    mesh_template,
    triangle_joints,
)
from .skeleton import Bone, Tracks, body_size, bones, motion_tracks, segments, skeleton_points
from .skeleton import joint_radius as joint_radius
from .skeleton import world_positions as world_positions

__all__ = ["Tracks", "motion_tracks", "Bone", "bones", "joint_sides", "SIDE_COLOURS", "Camera", "follow_camera",
           "frame_box", "fit_distance", "project", "look_at_quaternion", "drawn_height_fraction", "grid_cell",
           "ground_segments", "highlight_keys", "body_size",
           "skeleton_points", "segments", "MeshTemplate", "mesh_template", "joint_states",
           "trail_segments", "mesh_index", "hex_rgb", "bone_colours",
           "triangle_joints", "mesh_constants"]
