"""SkeletonView without a browser: synced pythreejs arrays and what goes over the comm per frame step (counted by wrapping each widget's ``_send``)."""
from __future__ import annotations

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb.core.motion import Motion
from stagger_nb.core.skeleton import Skeleton
from stagger_nb.widgets import SkeletonView


def _record_sends(widgets_by_name):
    """Wrap ``_send`` of each widget; returns a list that collects (name, state keys, float32 count)."""
    log = []
    for name, w in widgets_by_name.items():
        orig = w._send

        def send(msg, buffers=None, _orig=orig, _name=name):
            nbytes = sum(memoryview(b).nbytes for b in (buffers or []))
            log.append((_name, tuple(msg.get("state", {})), nbytes // 4))
            return _orig(msg, buffers)

        w._send = send
    return log


def _chain_motion(J=100, F=3000, seed=0):
    """A J-joint chain waving around: big rig for the scaling check."""
    rng = np.random.default_rng(seed)
    sk = Skeleton([f"j{i}" for i in range(J)], np.arange(J) - 1, np.tile([0.0, 1.0, 0.0], (J, 1)))
    t = np.arange(F)[:, None] * 0.01
    ang = 0.05 * np.sin(t * rng.uniform(1, 3, J) + rng.uniform(0, 6, J))  # (F, J) radians about z
    q = np.zeros((F, J, 4))
    q[..., 2], q[..., 3] = np.sin(ang / 2), np.cos(ang / 2)
    return Motion(sk, 1 / 120, np.zeros((F, 3)), q)


def test_view_shows_fk_positions_and_streams_one_frame(shared_motion):  # noqa: C901
    m = shared_motion("bandai_run_cycle.bvh")
    v = SkeletonView(m, ghost=m)
    pos, _ = sn.forward_kinematics(m)
    # float32 on the wire: positions of a ~170-unit figure agree to float32 precision (~1e-5 relative)
    np.testing.assert_allclose(v.bones.geometry.attributes["position"].array, pos[0], rtol=1e-6, atol=1e-4)
    assert v.joints.geometry.attributes["position"] is v.bones.geometry.attributes["position"]  # shared
    idx = np.asarray(v.bones.geometry.index.array).reshape(-1, 2)
    assert sorted(map(tuple, idx.tolist())) == sorted((int(m.skeleton.parents[j]), j) for j in range(1, m.num_joints))

    body = np.max(pos[0].max(0) - pos[0].min(0))
    # the ghost stands beside the motion: same pose shifted along x by 0.6 of the body's extent
    np.testing.assert_allclose(v._ghost_attr.array, pos[0] + [0.6 * body, 0, 0], rtol=1e-6, atol=1e-3)
    assert SkeletonView(m, ghost=m, ghost_offset=(0, 0, 0))._ghost_pos[3].tolist() == v.positions[3].tolist()
    v.show_ghost = False
    log = _record_sends({"pos": v._attr, "ghost": v._ghost_attr, "colors": v._colors})
    v.slider.value = 7
    assert v.frame == 7 and v.play.value == 7
    np.testing.assert_allclose(v._attr.array, pos[7], rtol=1e-6, atol=1e-4)
    assert log == [("pos", ("array",), m.num_joints * 3)]  # exactly J*3 floats, nothing else
    v.play.value = 9  # the Play widget drives the same frame
    assert v.frame == 9 and v.slider.value == 9


def test_view_scales_to_100_joints_3000_frames():
    m = _chain_motion()
    v = SkeletonView(m)
    log = _record_sends({"pos": v._attr, "colors": v._colors})
    for f in range(1, 40):
        v.frame = f * 70
    floats = [n for name, keys, n in log if name == "pos"]
    assert len(floats) == 39 and set(floats) == {100 * 3}
    assert not [e for e in log if e[0] != "pos"]
    lo = np.asarray(v.camera.position)
    # camera framed to the bounds: it looks at the centre from outside the bounding box
    bmin, bmax = v.positions.reshape(-1, 3).min(0), v.positions.reshape(-1, 3).max(0)
    assert np.any(lo < bmin) or np.any(lo > bmax)
    np.testing.assert_allclose(v.controls.target, (bmin + bmax) / 2, rtol=1e-5, atol=1e-5)  # float32 bounds


def test_view_set_motion_clamps_frame_and_keeps_camera(shared_motion):
    m = shared_motion("xia_angry_run.bvh")
    v = SkeletonView(m, ghost=m)
    v.frame = 130
    cam = tuple(v.camera.position)
    short = m.slice(0, 50)
    log = _record_sends({"pos": v._attr, "ghost": v._ghost_attr})
    v.set_motion(short)
    assert v.frame == 49 and v.slider.max == 49 and v.play.max == 49
    assert tuple(v.camera.position) == cam
    p, _ = sn.forward_kinematics(short)
    np.testing.assert_allclose(v._attr.array, p[49], rtol=1e-6, atol=1e-4)  # float32 wire precision
    with pytest.raises(ValueError, match="^motion"):
        v.set_motion(_chain_motion(J=5, F=10))


def test_view_highlights_selection_contacts_and_poses(shared_motion):
    m = shared_motion("bandai_run_cycle.bvh")
    v = SkeletonView(m)
    names = m.skeleton.names
    v.highlight_joints([names[3]])
    c = np.asarray(v._colors.array)
    assert np.allclose(c[3], [0.9, 0.1, 0.1]) and np.allclose(np.delete(c, 3, axis=0), [0.15, 0.15, 0.15])
    v.set_contacts([(names[5], 4, 8)])
    log = _record_sends({"colors": v._colors, "mat": v._bone_material})
    v.frame = 4
    assert np.allclose(np.asarray(v._colors.array)[5], [0.1, 0.7, 0.2])
    v.frame = 5  # same contact set: no colour message
    v.frame = 8  # contact ended (half-open range)
    assert np.allclose(np.asarray(v._colors.array)[5], [0.15, 0.15, 0.15])
    assert [e[0] for e in log] == ["colors", "colors"]
    v.set_pose_frames([10])
    v.frame = 10
    assert v._bone_material.color == "#dd6b20"
    v.frame = 11
    assert v._bone_material.color == "#2b6cb0"
