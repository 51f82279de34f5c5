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


def test_mesh_constants_colour_each_sphere_and_tube_vertex_by_its_owner():
    tpl = scene3d.mesh_template()
    J, segs = 3, np.array([[0, 1], [1, 2], [2, 3]])
    bone_rgb = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    pos, nrm, col = scene3d.mesh_constants(J, segs, tpl, [0.5, 0.5, 0.5], bone_rgb)
    vs, vt = len(tpl.sphere), len(tpl.tube)
    V = J * vs + len(segs) * vt
    assert pos.shape == nrm.shape == col.shape == (V, 3) and not pos.any()
    assert int(scene3d.mesh_index(J, len(segs), tpl).max()) == V - 1          # the index addresses every vertex
    for v in range(V):                                                        # vertex by vertex
        if v < J * vs:
            np.testing.assert_array_equal(nrm[v], tpl.sphere[v % vs, 3:].astype(np.float32))
            np.testing.assert_array_equal(col[v], np.float32([0.5, 0.5, 0.5]))
        else:
            assert not nrm[v].any()
            np.testing.assert_array_equal(col[v], bone_rgb[(v - J * vs) // vt])


def _fits(corners, d, dist, fov, aspect, margin):
    """Brute force: every corner projects inside the canvas (``margin`` of each half side) at this distance."""
    eye = d * dist
    if np.any((corners - eye) @ (-d) <= 1e-9):
        return False
    px = scene3d.project(corners, eye, np.zeros(3), fov, 1000.0 * aspect, 1000.0)
    return bool(np.all(np.abs(px[:, 0] - 500.0 * aspect) <= 500.0 * aspect * margin + 1e-6)
                and np.all(np.abs(px[:, 1] - 500.0) <= 500.0 * margin + 1e-6))


def test_fit_distance_is_the_smallest_distance_at_which_every_corner_is_inside_the_canvas():
    rng = np.random.default_rng(3)
    for _ in range(40):
        d = rng.normal(size=3)
        d[1] = abs(d[1]) * 0.5          # a camera above or beside the subject, never straight overhead
        d /= np.linalg.norm(d)
        corners = rng.normal(size=(8, 3)) * rng.uniform(0.1, 3.0, size=3)
        fov, aspect, margin = rng.uniform(20, 70), rng.uniform(0.5, 2.5), rng.uniform(0.7, 1.0)
        dist = scene3d.fit_distance(corners, d, fov, aspect, margin)
        assert _fits(corners, d, dist, fov, aspect, margin)
        assert not _fits(corners, d, dist * (1 - 1e-6) - 1e-9, fov, aspect, margin)   # and no nearer one
