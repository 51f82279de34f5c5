"""The browser half of SkeletonView, ``_conductor.js`` with the one mesh builder ``_skeleton_mesh.js``, run in node
against stand-in models (``tests/node/conductor_frame.mjs``): for a shown frame it writes spheres at the joints
and tubes along the bones, the same mesh as the naive numpy twin (``tests/mesh_reference.py``), the joints' state
colours, and puts the rig where the follow camera has it. The kernel sends only the constant parts of the mesh.
Skipped, with the reason, only when node is missing."""
from __future__ import annotations

import numpy as np
import pytest
from mesh_reference import browser_mesh, skeleton_mesh

import stagger_nb as sn
from stagger_nb import scene3d
from stagger_nb.widgets import SkeletonView

_T = scene3d.mesh_template()


@pytest.mark.parametrize("clip, frame", [("run", 77), ("cmu_01_01", 1200)])
def test_the_browser_builds_the_reference_mesh(clip, frame, tmp_path):
    m = sn.data.load(clip)
    v = SkeletonView(m)
    v.set_pose_frames([frame])                     # every joint flashes orange at this frame ...
    v.highlight_joints(["Head"])                   # ... but the selected head is red and larger
    v.frame = frame
    pos, nrm, col, info = browser_mesh(v, frame, tmp_path)
    head = m.skeleton.index("Head")
    want_pos, want_nrm = skeleton_mesh(scene3d.skeleton_points(m)[frame], scene3d.segments(m), m.num_joints,
                                       v.conductor.joint_radius, v.conductor.bone_radius, _T, [head], 1.6)
    scale = np.abs(want_pos).max()
    np.testing.assert_allclose(pos, want_pos, atol=1e-5 * scale)   # float32 rounding of the same affine maps
    np.testing.assert_allclose(nrm, want_nrm, atol=1e-5)
    vs = len(_T.sphere)
    assert col[head * vs].tolist() != col[0].tolist()              # red head, orange rest
    np.testing.assert_allclose(col[0], [0xdd / 255, 0x6b / 255, 0x20 / 255], atol=1e-6)
    np.testing.assert_allclose(info["rig"], -v.camera_framing.rig[frame], atol=1e-3)
    assert info["shown_frame"] == frame


def test_the_browser_mesh_is_spheres_at_joints_and_tubes_along_bones(tmp_path):
    m = sn.data.load("walk")
    v = SkeletonView(m)
    f = 40
    v.frame = f
    pos, nrm, _, _ = browser_mesh(v, f, tmp_path)
    pos, nrm = pos.astype(float), nrm.astype(float)
    P = scene3d.skeleton_points(m)[f].astype(float)
    vs, J = len(_T.sphere), m.num_joints
    spheres = pos[:J * vs].reshape(J, vs, 3)
    # each sphere: every vertex at the joint radius from its joint
    np.testing.assert_allclose(np.linalg.norm(spheres - P[:J, None], axis=2), v.conductor.joint_radius, rtol=1e-4)
    segs = scene3d.segments(m)
    tubes = pos[J * vs:].reshape(len(segs), -1, 3)
    tn = nrm[J * vs:].reshape(len(segs), -1, 3)
    for (a, b), t, n in zip(segs, tubes, tn):
        axis = (P[b] - P[a]) / np.linalg.norm(P[b] - P[a])
        rel = t - P[a]
        along = rel @ axis
        radial = rel - along[:, None] * axis
        # on the bone's axis segment [0, L], at the bone radius; normals unit, radial, outwards
        assert along.min() > -1e-3 and along.max() < np.linalg.norm(P[b] - P[a]) + 1e-3
        np.testing.assert_allclose(np.linalg.norm(radial, axis=1), v.conductor.bone_radius, rtol=1e-3)
        np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1, atol=1e-5)
        np.testing.assert_allclose(n, radial / np.linalg.norm(radial, axis=1, keepdims=True), atol=1e-3)
    # triangles face outwards (counter-clockwise seen from outside): the face normal agrees with the vertex normals
    tri = np.asarray(v.skeleton_mesh.geometry.index.array).reshape(-1, 3)
    fn = np.cross(pos[tri[:, 1]] - pos[tri[:, 0]], pos[tri[:, 2]] - pos[tri[:, 0]])
    ok = np.linalg.norm(fn, axis=1) > 1e-9                  # (degenerate pole triangles have no direction)
    assert np.all(np.einsum("ij,ij->i", fn[ok], nrm[tri[ok]].sum(axis=1)) > 0)


def test_a_selected_joint_is_drawn_larger_and_red(tmp_path):
    m = sn.data.load("walk")
    v = SkeletonView(m)
    v.highlight_joints([3])
    pos, _, col, _ = browser_mesh(v, 0, tmp_path)
    vs = len(_T.sphere)
    p = scene3d.skeleton_points(m)[0]
    r3 = np.linalg.norm(pos[3 * vs:4 * vs] - p[3], axis=1).max()
    r2 = np.linalg.norm(pos[2 * vs:3 * vs] - p[2], axis=1).max()
    assert r3 == pytest.approx(1.6 * r2, rel=1e-4)
    np.testing.assert_allclose(col[3 * vs], [0xe5 / 255, 0x3e / 255, 0x3e / 255], atol=1e-6)


def test_the_kernel_holds_only_the_constant_parts_of_the_mesh():
    m = sn.data.load("walk")
    v = SkeletonView(m)
    g = v.skeleton_mesh.geometry.attributes
    before = {k: np.asarray(g[k].array).copy() for k in ("position", "normal", "color")}
    v.set_motion(m.replace(local_quats=m.local_quats[::-1].copy()))
    v.highlight_joints(["Head"])
    v.frame = 100
    for k, a in before.items():   # an edit, a selection, a seek: the kernel's arrays do not change
        np.testing.assert_array_equal(np.asarray(g[k].array), a)
    assert not np.any(before["position"])
    vs = len(_T.sphere)
    np.testing.assert_allclose(before["normal"][:vs], _T.sphere[:, 3:])
