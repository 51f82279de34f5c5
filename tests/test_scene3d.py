"""scene3d's mesh parts that the 3D view and the exported page share: the bones' colours and the triangle ->
joint map (what a click on the merged mesh selects)."""
from __future__ import annotations

import numpy as np

from stagger_nb import data, scene3d


def test_hex_rgb_reads_each_channel():
    assert scene3d.hex_rgb("#ff8000") == [1.0, 128 / 255, 0.0]
    assert scene3d.hex_rgb("#000000") == [0.0, 0.0, 0.0]


def test_each_bone_takes_its_child_side_colour_or_its_parent_for_an_end_site():
    m = data.load("walk")
    segs = scene3d.segments(m)
    rgb = scene3d.bone_colours(m)
    J = m.num_joints
    sides = scene3d.joint_sides(m.skeleton.names)
    assert rgb.shape == (len(segs), 3) and rgb.dtype == np.float32
    for (a, b), c in zip(segs, rgb):
        side = sides[b] if b < J else sides[a]
        np.testing.assert_array_equal(c, np.float32(scene3d.hex_rgb(scene3d.SIDE_COLOURS[side])))
    # both sides and the centre appear on a walking figure
    assert {tuple(c) for c in rgb} == {tuple(np.float32(scene3d.hex_rgb(v))) for v in scene3d.SIDE_COLOURS.values()}
    np.testing.assert_array_equal(scene3d.bone_colours(m, segs[:3]), rgb[:3])


def test_triangle_joints_follow_the_mesh_index_layout():
    tpl = scene3d.mesh_template()
    J, segs = 4, np.array([[0, 1], [1, 2], [2, 3], [3, 4]])   # the last bone ends at an End Site (point 4)
    index = scene3d.mesh_index(J, len(segs), tpl)
    tri = scene3d.triangle_joints(J, segs, tpl)
    assert tri.shape == (len(index.reshape(-1, 3)),)
    # a triangle's vertices lie in its joint's sphere, or in the tube of a bone whose parent is that joint
    vs, vt = len(tpl.sphere), len(tpl.tube)
    for t, j in zip(index.reshape(-1, 3), tri):
        v = int(t[0])
        if v < J * vs:
            assert v // vs == j
        else:
            assert segs[(v - J * vs) // vt, 0] == j
