"""SkeletonView without a browser: the state it sends (binary keyframe tracks that reproduce forward kinematics),
bytes per edit (counted on a recording comm), the playhead rules (the kernel does not follow the Play tick by tick),
picking, trails, highlights, and the camera framing math of :mod:`stagger_nb.scene3d`."""
from __future__ import annotations

import json

import numpy as np
import pytest
from ipywidgets import Widget

import stagger_nb as sn
from stagger_nb import scene3d
from stagger_nb.core.motion import Motion
from stagger_nb.core.skeleton import Skeleton
from stagger_nb.widgets import SkeletonView


class _RecordingComm:
    """Stands in for a kernel comm: keeps every message (JSON part size and binary buffer sizes)."""

    log: list = []

    def __init__(self, *args, **kwargs):
        self.comm_id = kwargs.get("comm_id") or f"c{len(_RecordingComm.log)}-{id(self)}"
        self.kernel = "recording"   # not None: ipywidgets sends state updates only through a comm with a kernel
        self.send(data=kwargs.get("data"), buffers=kwargs.get("buffers"))

    def send(self, data=None, metadata=None, buffers=None):
        js = len(json.dumps(data, default=lambda o: None)) if data is not None else 0
        _RecordingComm.log.append((js, sum(memoryview(b).nbytes for b in (buffers or []))))

    def on_msg(self, callback):
        pass

    def on_close(self, callback):
        pass

    def close(self, *args, **kwargs):
        pass

    def open(self, *args, **kwargs):
        pass


@pytest.fixture
def recording_comm(monkeypatch):
    import comm
    _RecordingComm.log = []
    monkeypatch.setattr(comm, "create_comm", lambda *a, **k: _RecordingComm(*a, **k))
    return _RecordingComm.log


def _chain_motion(J=6, F=40, seed=0, frame_time=1 / 60):
    """A J-joint chain waving about z and walking along x: small, hand-checkable."""
    rng = np.random.default_rng(seed)
    sk = Skeleton([f"j{i}" for i in range(J)], np.arange(J) - 1, np.tile([0.0, 10.0, 0.0], (J, 1)))
    t = np.arange(F)[:, None] * frame_time
    ang = 0.4 * np.sin(t * rng.uniform(1, 3, J) * 6 + rng.uniform(0, 6, J))
    q = np.zeros((F, J, 4))
    q[..., 2], q[..., 3] = np.sin(ang / 2), np.cos(ang / 2)
    root = np.stack([np.arange(F) * 0.5, np.full(F, 1.0), np.zeros(F)], axis=1)
    return Motion(sk, frame_time, root, q)


def _sent_points(v):
    c = v.conductor
    return np.frombuffer(c.points, dtype=np.float32).reshape(c.num_frames, c.num_points, 3)


def test_sent_points_reproduce_forward_kinematics_and_end_sites():
    m = sn.data.load("run")
    v = SkeletonView(m, ghost=m)
    pos, wq = sn.forward_kinematics(m)
    for f in (0, 77, m.num_frames - 1):
        # float32 on the wire: a ~170-unit figure agrees to ~1e-4
        np.testing.assert_allclose(v.shown_positions(f), pos[f], atol=2e-3)
    pts = _sent_points(v)
    assert pts.dtype == np.float32 and pts.shape == (m.num_frames, m.num_joints + len(m.skeleton.end_sites), 3)
    # End Site k hangs |offset| from its joint, in the joint's world frame (naive per-point rotation via scipy)
    from scipy.spatial.transform import Rotation
    for k, (j, off) in enumerate(sorted(m.skeleton.end_sites.items())):
        want = pos[40, j] + Rotation.from_quat(np.array(wq[40, j])).apply(np.array(off, float))
        np.testing.assert_allclose(pts[40, m.num_joints + k], want, atol=2e-3)


def test_a_view_is_a_few_dozen_widget_models_whatever_the_skeleton():
    from collections import Counter
    counts = {}
    for name in ("walk", "cmu_01_01"):
        m = sn.data.load(name)
        n0 = len(Widget.widgets)
        v = SkeletonView(m, ghost=m, show_ghost=False)
        counts[name] = (len(Widget.widgets) - n0, v.widget_count, m.num_joints)
        kinds = Counter(type(w).__name__ for w in list(Widget.widgets.values())[n0:])
        v.show_ghost = True                  # the ghost is built when first shown: one mesh (5 models)
        counts[name + "+ghost"] = len(Widget.widgets) - n0
    print("\nwidget models per SkeletonView:", counts, dict(kinds))
    # the count does not grow with the number of joints or bones (one mesh), and stays a few dozen (was 283)
    assert counts["walk"][0] == counts["cmu_01_01"][0] <= 42
    assert counts["cmu_01_01+ghost"] - counts["cmu_01_01"][0] <= 5
    assert kinds["Mesh"] == 1 and "AnimationAction" not in kinds and "KeyframeTrack" not in str(kinds)


def test_a_new_edit_replaces_the_data_in_place_and_clamps_the_frame():
    m = _chain_motion(F=60)
    v = SkeletonView(m)
    v.frame = 55
    shorter = _chain_motion(F=30, seed=1)
    n_widgets = len(Widget.widgets)
    v.set_motion(shorter)
    assert v.frame == 29 and v.player.max == 29 and v.frame_slider.max == 29 and v.player.value == 29
    assert len(Widget.widgets) == n_widgets and v.conductor.num_frames == 30
    p, _ = sn.forward_kinematics(shorter)
    np.testing.assert_allclose(v.shown_positions(12), p[12], atol=1e-4)
    with pytest.raises(ValueError, match="^motion"):
        v.set_motion(_chain_motion(J=5, F=10))


def test_a_second_edit_of_the_same_shape_updates_the_widgets_in_place(recording_comm):
    m = _chain_motion(J=6, F=80)
    v = SkeletonView(m, ghost=m)
    v.set_motion(_chain_motion(J=6, F=80, seed=2), pose_frames=[10, 40], contacts=[("j2", 5, 30)])
    n_widgets = len(Widget.widgets)
    recording_comm.clear()
    third = _chain_motion(J=6, F=80, seed=3)
    v.set_motion(third, pose_frames=[12, 44], contacts=[("j2", 6, 31)])
    assert len(Widget.widgets) == n_widgets                 # no widget created (none closed)
    p, _ = sn.forward_kinematics(third)
    for f in (0, 17, 79):
        np.testing.assert_allclose(v.shown_positions(f), p[f], atol=1e-3)
    states = np.frombuffer(v.conductor.states, np.uint8).reshape(80, 6)
    assert states[12].tolist() == [1, 1, 2, 1, 1, 1] and states[40, 2] == 0   # pose (contact wins), plain
    assert states[20].tolist() == [0, 0, 2, 0, 0, 0]
    binary = sum(b for _, b in recording_comm)
    assert binary >= len(v.conductor.points) and v.edit_bytes == binary
    assert max(j for j, _ in recording_comm) < 1000    # no array as a JSON list


def test_bytes_per_edit_of_a_2751_by_31_clip_are_binary_and_once(recording_comm):
    m = sn.data.load("cmu_01_01")
    assert (m.num_frames, m.num_joints) == (2751, 31)
    v = SkeletonView(m)
    edited = m.replace(local_quats=m.local_quats[::-1].copy())
    recording_comm.clear()
    v.set_motion(edited)
    json_bytes = sum(j for j, _ in recording_comm)
    binary = sum(b for _, b in recording_comm)
    points = scene3d.skeleton_points(edited).nbytes
    print(f"\nbytes per edit ({m.num_frames} x {m.num_joints}): binary {binary:,}, JSON {json_bytes:,}, "
          f"messages {len(recording_comm)}")
    assert binary >= points                            # every point went, once ...
    assert binary <= 1.1 * points                      # ... and little else (states, rig path; no mesh vertices)
    assert json_bytes < 0.05 * binary                  # the arrays are buffers, not JSON lists
    assert v.edit_bytes == pytest.approx(binary, rel=0.02)
    # a frame step sends no arrays at all: the browser has the data
    recording_comm.clear()
    v.frame = 1000
    assert sum(b for _, b in recording_comm) == 0 and len(recording_comm) <= 3


def test_playhead_follows_the_play_only_when_stopped():
    m = _chain_motion(F=120)
    v = SkeletonView(m)
    for w in (v.player, v.frame_slider):   # front-end updates are not echoed back (ipywidgets 8 would)
        assert w.trait_metadata("value", "echo_update") is False
    step, interval = v.player.step, v.player.interval
    assert abs(step * m.frame_time * 1000 - interval) <= 1 and 80 <= interval <= 120   # ~10 ticks a second
    v.player.playing = True
    v.player.value = 30          # ticks arriving from the browser while playing
    v.player.value = 36
    assert v.frame == 0          # the kernel does not follow tick by tick (no per-frame messages to plots)
    v.player.playing = False
    assert v.frame == 36         # in step once playback stops
    v.player.value = 50          # a scrub
    assert v.frame == 50
    v.frame = 7                  # a seek from Python
    assert v.player.value == 7 and v.frame_slider.value == 7
    v.frame = 10 ** 6
    assert v.frame == 119


def test_link_frame_is_a_browser_side_link():
    from stagger_nb.widgets.plots import PlotView
    m = _chain_motion()
    v = SkeletonView(m)
    p = PlotView()
    link = v.link_frame(p)
    assert link.source == (v.player, "value") and link.target == (p, "frame")


def test_picking_a_sphere_or_bone_selects_its_joint():
    m = _chain_motion()
    v = SkeletonView(m)
    t = scene3d.mesh_template()
    ts, tt = len(t.sphere_index), len(t.tube_index)
    with v.picker.hold_trait_notifications():      # as the browser sends a click: object, face, point at once
        v.picker.object, v.picker.faceIndex, v.picker.point = v.skeleton_mesh, 3 * ts + 5, (1.0, 2.0, 3.0)
    assert v.selected_joint == "j3"
    bone = [i for i, (a, b) in enumerate(scene3d.segments(m)) if a == 4][0]
    v.picker.faceIndex = 6 * ts + bone * tt + 1    # a bone belongs to the joint that rotates it
    assert v.selected_joint == "j4"
    assert v.conductor.selected == [4]   # drawn larger and red by the browser (test_skeleton_view_js.py)
    v.selected_joint = "j1"
    assert "selected: j1" in v.legend.value
    with pytest.raises(Exception, match="selected_joint"):
        v.selected_joint = "nope"


def test_trails_follow_the_joint_and_the_edits():
    m = _chain_motion(F=50)
    v = SkeletonView(m, trail_joints=["j5"], trail_seconds=0.1)
    pos, _ = sn.forward_kinematics(m)
    assert v.conductor.trail_window == 6 and v.conductor.trail_joints == [5]   # 0.1 s at 60 Hz each side
    seg = np.asarray(v.conductor.trails.geometry.attributes["position"].array).reshape(-1, 2, 3)
    assert len(seg) == 12
    # at frame 0 the window reaches back before the clip: those segments collapse onto frame 0
    for k in range(12):
        a, b = np.clip([k - 6, k - 5], 0, 49)
        np.testing.assert_allclose(seg[k], pos[[a, b], 5], atol=1e-4)
    m2 = _chain_motion(F=50, seed=3)
    v.frame = 20
    v.set_motion(m2)
    p2, _ = sn.forward_kinematics(m2)
    seg = np.asarray(v.conductor.trails.geometry.attributes["position"].array).reshape(-1, 2, 3)
    np.testing.assert_allclose(seg[:, 0], p2[14:26, 5], atol=1e-4)
    assert "trail j5" in v.legend.value
    n = len(Widget.widgets)
    v.trail_joints = []
    assert v.conductor.trails is None and v.trails_group.children == ()
    assert len(Widget.widgets) < n                      # the trail models were closed, not left behind
    with pytest.raises(Exception, match="trail_joints"):
        v.trail_joints = ["nope"]


def test_highlight_keys_mark_contacts_and_pose_frames():
    keys = scene3d.highlight_keys(20, 0.01, 3, pose_frames=[10], contacts=[(1, 2, 6)], pose_window_s=0.02)
    t, s = keys[1]
    state = np.zeros(20, int)
    for k in range(len(t)):   # expand the step function back to frames
        state[int(round(t[k] / 0.01)):] = s[k]
    expected = np.zeros(20, int)
    expected[8:13] = 1        # pose frame 10 ± 2 frames
    expected[2:6] = 2         # contact, half-open
    assert state.tolist() == expected.tolist()
    assert 0 in keys and 2 in keys   # every joint flashes at the pose
    m = _chain_motion(F=30)
    v = SkeletonView(m)
    v.set_motion(m, pose_frames=[10], contacts=[("j2", 0, 5)])
    assert "staggered pose" in v.legend.value and "contact" in v.legend.value
    w = SkeletonView(m, pose_label="edited frame")   # the wand's word for its marked frames
    w.set_motion(m, pose_frames=[10, 20])
    assert "edited frame (2)" in w.legend.value and "staggered pose" not in w.legend.value


@pytest.mark.parametrize("name", ["run", "cmu_01_01", "walk", "jump"])
def test_follow_camera_keeps_the_character_readable(name):
    m = sn.data.load(name)
    P = scene3d.world_positions(m)
    cam = scene3d.follow_camera(P, m.frame_time, "follow", aspect=480 / 380)
    for f in (0, m.num_frames // 2, m.num_frames - 1):
        assert scene3d.drawn_height_fraction(P[f], cam, f, 480, 380) >= 0.45
        eye, target = cam.world(f)
        px = scene3d.project(P[f], eye, target, cam.fov, 480, 380)
        assert px.min() > 0 and px[:, 0].max() < 480 and px[:, 1].max() < 380   # inside the canvas
    # smooth: a Gaussian average of the root's ground track is never faster than the root's fastest step
    step = np.linalg.norm(np.diff(cam.rig, axis=0), axis=1)
    root_step = np.linalg.norm(np.diff(P[:, 0, [0, 2]], axis=0), axis=1)
    assert step.max() <= root_step.max() * (1 + 1e-4)
    whole = scene3d.follow_camera(P, m.frame_time, "all", aspect=480 / 380)
    eye, target = whole.world(0)
    px = scene3d.project(P.reshape(-1, 3), eye, target, whole.fov, 480, 380)
    assert px.min() >= 0 and px[:, 0].max() <= 480 and px[:, 1].max() <= 380   # every frame in view
    # the look-at point is the rig's origin: a reloaded page's OrbitControls aim the camera at (0, 0, 0)
    for c in (cam, whole):
        assert c.target == (0.0, 0.0, 0.0)
        assert np.allclose(scene3d.look_at_quaternion(c.position, (0, 0, 0)),
                           scene3d.look_at_quaternion(c.position, c.target))


def test_project_matches_the_pinhole_closed_form():
    # a vertical segment of height h at distance d straight ahead: h / (2 d tan(fov/2)) of the canvas height
    h, d, fov = 1.7, 5.0, 40.0
    px = scene3d.project(np.array([[0, 0, 0], [0, h, 0]]), eye=(0, h / 2, d), target=(0, h / 2, 0), fov=fov,
                         width=400, height=300)
    assert np.allclose(px[:, 0], 200)
    assert abs((px[0, 1] - px[1, 1]) / 300 - h / (2 * d * np.tan(np.radians(fov / 2)))) < 1e-9


def test_look_at_quaternion_points_the_camera_at_the_target():
    from scipy.spatial.transform import Rotation
    eye, target = np.array([3.0, 2.0, 5.0]), np.array([0.5, 1.0, -1.0])
    q = scene3d.look_at_quaternion(eye, target)
    forward = Rotation.from_quat(q).apply([0, 0, -1])     # a three.js camera looks down its -z axis
    np.testing.assert_allclose(forward, (target - eye) / np.linalg.norm(target - eye), atol=1e-12)
    assert Rotation.from_quat(q).apply([1, 0, 0])[1] == pytest.approx(0, abs=1e-12)   # no roll: x stays level


def test_view_framing_and_joint_pixels():
    m = sn.data.load("run")
    v = SkeletonView(m)
    for f in (0, 150, 300):
        assert v.drawn_height(f) >= 0.45
    assert v.controls.enableKeys is False     # arrow keys move sliders, not the camera of every view
    np.testing.assert_allclose(v.three_camera.quaternion,
                               scene3d.look_at_quaternion(v.three_camera.position, v.controls.target), atol=1e-12)
    x, y = v.joint_pixel("Head", 0)
    assert 0 < x < v.width and 0 < y < v.height / 2   # the head is in the upper half
    v.camera = "all"
    assert v.drawn_height(0) < 0.45                   # the whole track in view: a smaller figure


def test_joint_sides_and_bones():
    assert scene3d.joint_sides(["LeftArm", "RHipJoint", "lfemur", "Spine", "hand_r", "Head"]) == \
        ["left", "right", "left", "centre", "right", "centre"]
    m = _chain_motion(J=3)
    bs = scene3d.bones(m)
    assert [(b.parent, b.child) for b in bs] == [(0, 1), (1, 2)]
    assert all(abs(b.length - 10) < 1e-12 and np.allclose(b.position, (0, 5, 0)) for b in bs)
    assert all(np.allclose(b.quaternion, (0, 0, 0, 1)) for b in bs)   # bones along +y: the cylinder as it is
    # a bone's cylinder (unit height along +y) turned onto its offset: +x is -90 degrees about z, -y a half turn
    sk = Skeleton(["a", "b", "c"], np.array([-1, 0, 0]), np.array([[0.0, 0, 0], [10.0, 0, 0], [0.0, -4.0, 0]]))
    turned = scene3d.bones(Motion(sk, 1 / 60, np.zeros((1, 3)), np.tile([0.0, 0, 0, 1], (1, 3, 1))))
    np.testing.assert_allclose(turned[0].quaternion, [0, 0, -np.sqrt(0.5), np.sqrt(0.5)], atol=1e-12)
    np.testing.assert_allclose(turned[1].quaternion, [1, 0, 0, 0], atol=1e-12)
    assert turned[0].position == (5.0, 0.0, 0.0) and turned[1].length == 4.0


def test_ghost_is_built_when_first_shown_and_toggles():
    m = _chain_motion(F=30)
    edited = _chain_motion(F=30, seed=5)
    v = SkeletonView(edited, ghost=m, show_ghost=False)
    assert v.ghost_mesh is None and v.conductor.ghost is None and v.conductor.ghost_points == b""
    v.show_ghost = True
    assert v.ghost_mesh is not None and v.ghost_mesh.visible and v.ghost_toggle.value
    assert v.conductor.ghost is v.ghost_mesh and v.ghost_mesh in v.rig.children
    assert "original (ghost)" in v.legend.value
    gp = np.frombuffer(v.conductor.ghost_points, np.float32).reshape(30, -1, 3)
    p, _ = sn.forward_kinematics(m)
    np.testing.assert_allclose(gp[:, :6], p, atol=1e-4)
    mesh, sent = v.ghost_mesh, v.conductor.ghost_points
    v.set_motion(edited.slice(0, 20))          # the ghost stays (not re-sent) when not given
    assert v.ghost_mesh is mesh and v.conductor.ghost_points is sent
    v.show_ghost = False
    assert not v.ghost_mesh.visible
    v.set_motion(edited, ghost=edited)         # a new ghost while hidden: sent only once shown again
    assert v.conductor.ghost_points is sent
    v.show_ghost = True
    gp = np.frombuffer(v.conductor.ghost_points, np.float32).reshape(30, -1, 3)
    np.testing.assert_allclose(gp[:, :6], sn.forward_kinematics(edited)[0], atol=1e-4)


def test_the_ghost_checkbox_says_why_it_is_greyed_out():
    m = sn.data.load("walk")
    v = SkeletonView(m)
    try:
        assert v.ghost_toggle.disabled and "no original" in v.ghost_toggle.tooltip
        v.set_motion(m, ghost=m)
        assert not v.ghost_toggle.disabled and "no original" not in v.ghost_toggle.tooltip
    finally:
        v.close()


def test_follow_smoothing_matches_the_direct_gaussian_filter():
    # the FFT smoothing is scipy's gaussian_filter1d (mode "nearest") of the point-reflected signal, column by
    # column, for sigmas with the reflection shorter than the kernel (a short clip) and longer
    from scipy.ndimage import gaussian_filter1d
    rng = np.random.default_rng(4)
    for n, sigma in [(900, 60.0), (40, 60.0), (25, 3.2), (2, 5.0)]:
        x = np.cumsum(rng.standard_normal((n, 2)), axis=0)
        pad = min(n - 1, int(np.ceil(4 * sigma)))
        got = scene3d._smooth(x, sigma)
        for c in range(2):
            ext = np.concatenate([2 * x[0, c] - x[pad:0:-1, c], x[:, c], 2 * x[-1, c] - x[-2:-pad - 2:-1, c]])
            want = gaussian_filter1d(ext, sigma, mode="nearest")[pad:pad + n]
            np.testing.assert_allclose(got[:, c], want, rtol=0, atol=1e-9 * np.abs(x).max())   # FFT rounding
            np.testing.assert_allclose(scene3d._smooth(x[:, c], sigma), got[:, c], rtol=0, atol=1e-12)
    line = np.linspace(0.0, 5.0, 300)   # a steady track comes out unchanged, ends included
    np.testing.assert_allclose(scene3d._smooth(line, 20.0), line, atol=1e-9)


def test_follow_camera_extents_match_a_naive_reference():
    m = sn.data.load("walk")
    P = scene3d.skeleton_points(m)[:, :m.num_joints]       # float32, as the view passes them
    P64 = P.astype(float)
    h = scene3d.body_size(P64)
    ground = P64[..., 1].min()
    cam = scene3d.follow_camera(P, m.frame_time, "follow")
    assert cam.ground == ground
    dist = np.linalg.norm(cam.position)
    # at least where the median body fills 0.62 of the height; further only as far as the clip's box needs
    assert dist >= max(h / (2 * 0.62 * np.tan(np.radians(20))),
                       h * 0.5 / (0.62 * np.tan(np.radians(20)) * 480 / 380)) * (1 - 1e-12)
    assert cam.far == pytest.approx(dist * 50 + np.ptp(P64[..., 0]) + np.ptp(P64[..., 2]), rel=1e-12)
    centre = (P64[..., 1].max() + ground) / 2   # the box of the clip: ground to the highest point of any frame
    np.testing.assert_allclose(cam.rig[:, 1], centre, rtol=1e-6)   # float32 rig
    # brute force: every point of every frame, the End Sites (the top of the head) included, inside the canvas
    allp = scene3d.skeleton_points(m)
    framed = scene3d.follow_camera(allp, m.frame_time, "follow", pad=scene3d.joint_radius(m))   # as the view
    for f in range(m.num_frames):
        eye, target = framed.world(f)
        px = scene3d.project(allp[f], eye, target, framed.fov, 480, 380)
        assert px.min() > 0 and px[:, 0].max() < 480 and px[:, 1].max() < 380, f
    whole = scene3d.follow_camera(P, m.frame_time, "all")
    lo, hi = P64.reshape(-1, 3).min(axis=0), P64.reshape(-1, 3).max(axis=0)
    np.testing.assert_allclose(whole.rig[0], [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2],
                               rtol=1e-6)


def test_ground_extent_then_grid_is_the_ground_segments():
    m = sn.data.load("walk")
    P = scene3d.world_positions(m)
    for cell, cap in [(10.0, 40000), (1.0, 500)]:   # the second doubles the cell until it fits
        lo, hi, c = scene3d.ground_extent(P, cell, 30.0, cap)
        seg = scene3d.ground_grid(lo, hi, c, -1.5)
        np.testing.assert_array_equal(seg, scene3d.ground_segments(P, cell, 30.0, -1.5, cap))
        assert len(seg) // 2 <= cap and (c == cell) == (cap == 40000)
        assert seg[:, 0].min() == pytest.approx(lo[0]) and seg[:, 2].max() == pytest.approx(hi[1])
        assert np.all(seg[:, 1] == -1.5)


def test_the_same_selection_again_sends_nothing(recording_comm):
    m = _chain_motion(J=6, F=40)
    v = SkeletonView(m)
    v.highlight_joints(["j2"])
    recording_comm.clear()
    v.highlight_joints(["j2"])           # an editor redraw with the joint unchanged
    assert recording_comm == [] and v.selected_joint == "j2"
    v.highlight_joints(["j3"])           # a new one is sent (the browser draws it red and larger)
    assert v.conductor.selected == [3] and v.selected_joint == "j3" and recording_comm


def test_the_ground_follows_an_edit_by_its_position_and_stays_under_the_feet(recording_comm):
    # an edit that lowers the lowest point moves the grid (its position, a small JSON message); the segments
    # (binary) are sent again only when the extent over the ground track changes
    m = _chain_motion(J=6, F=60)
    v = SkeletonView(m)
    lower = m.replace(root_positions=m.root_positions - [0.0, 0.5, 0.0])
    recording_comm.clear()
    v.set_motion(lower)
    p, _ = sn.forward_kinematics(lower)
    seg = np.asarray(v.grid.geometry.attributes["position"].array)
    assert np.all(seg[:, 1] == 0.0) and v.grid.position[1] == pytest.approx(p[..., 1].min(), abs=1e-6)
    assert v.grid.position[1] == v.camera_framing.ground
    assert sum(b for _, b in recording_comm) < len(v.conductor.points) + seg.nbytes   # the segments not resent
    far = m.replace(root_positions=m.root_positions + [500.0, 0.0, 0.0])   # the track moves: a new grid under it
    v.set_motion(far)
    seg = np.asarray(v.grid.geometry.attributes["position"].array)
    assert seg[:, 0].min() <= 500.0 and seg[:, 0].max() >= 500.0 + m.root_positions[:, 0].max()


def test_preview_sends_the_shown_frame_of_an_edit_as_the_whole_clip_would_draw_it():
    """SkeletonView.preview (what a slider move sends the 3D view at once): the points of one frame, equal to
    that frame of the whole clip's points (what set_motion sends later), a few hundred bytes."""
    m = sn.data.load("walk")
    v = SkeletonView(m)
    edited = m.slice(m.num_frames // 2)   # another motion of the same skeleton: frame 7 is another pose
    v.frame = 7
    nbytes = v.preview(edited)
    whole = scene3d.skeleton_points(edited)
    got = np.frombuffer(v.conductor.preview, dtype=np.float32).reshape(-1, 3)
    np.testing.assert_allclose(got, whole[7], atol=1e-5)
    assert np.abs(got - scene3d.skeleton_points(m)[7]).max() > 1.0   # not the shown clip's frame
    assert v.conductor.preview_frame == 7 and nbytes == whole[7].nbytes == len(v.conductor.preview)
    assert nbytes * 50 < whole.nbytes
    assert v.motion is m   # the clip itself is sent by set_motion, not by the preview
    v.preview(edited, frame=10 ** 6)   # clamped to the edit's last frame
    assert v.conductor.preview_frame == edited.num_frames - 1
