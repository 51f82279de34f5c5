"""SkeletonView without a browser: the state it sends (binary keyframe tracks that reproduce forward kinematics),
bytes per edit (counted on a recording comm), the playhead rules (the kernel does not follow the Play tick by tick),
picking, trails, highlights, and the camera framing math of :mod:`stagger_nb.scene3d`."""
from __future__ import annotations

import json

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import scene3d
from stagger_nb.core.motion import Motion
from stagger_nb.core.skeleton import Skeleton
from stagger_nb.widgets import SkeletonView
from ipywidgets import Widget


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


def test_sent_tracks_reproduce_forward_kinematics():
    m = sn.data.load("run")
    v = SkeletonView(m, ghost=m)
    pos, _ = sn.forward_kinematics(m)
    for f in (0, 77, m.num_frames - 1):
        # float32 on the wire: a ~170-unit figure agrees to ~1e-4
        np.testing.assert_allclose(v.shown_positions(f), pos[f], atol=2e-3)
    times = v.motion_tracks[0].times            # one times array shared by all tracks (sent once)
    assert all(tr.times is times for tr in v.motion_tracks) and times.array.dtype == np.float32
    for tr in v.motion_tracks:                  # binary float32 arrays, not lists
        assert isinstance(tr.values, np.ndarray) and tr.values.dtype == np.float32
    # the hierarchy: each joint's group hangs under its parent's group, at its offset
    g = v.joint_groups
    for j in range(1, m.num_joints):
        assert g[j] in g[int(m.skeleton.parents[j])].children
        np.testing.assert_allclose(g[j].position, m.skeleton.offsets[j], atol=1e-9)


def test_a_new_edit_replaces_the_tracks_in_place_and_clamps_the_frame():
    m = _chain_motion(F=60)
    v = SkeletonView(m)
    v.frame = 55
    shorter = _chain_motion(F=30, seed=1)
    before = v.motion_tracks
    v.set_motion(shorter)
    assert v.frame == 29 and v.player.max == 29 and v.frame_slider.max == 29 and v.player.value == 29
    after = v.motion_tracks
    # updated in place: a joint still animated keeps its track widget; a dropped track is closed, not left behind
    assert all((t in after and t.comm is not None) or t.comm is None for t in before)
    assert len({id(t.times) for t in after}) == 1 and after[0].times.array.shape == (30,)
    p, _ = sn.forward_kinematics(shorter)
    np.testing.assert_allclose(v.shown_positions(12), p[12], atol=1e-4)
    with pytest.raises(ValueError, match="^motion"):
        v.set_motion(_chain_motion(J=5, F=10))


def test_a_second_edit_of_the_same_shape_updates_the_widgets_in_place(recording_comm):
    m = _chain_motion(J=6, F=80)
    v = SkeletonView(m, ghost=m)
    v.set_motion(_chain_motion(J=6, F=80, seed=2), pose_frames=[10, 40], contacts=[("j2", 5, 30)])
    tracks, actions = v.motion_tracks, list(v.conductor.actions)
    n_widgets, version = len(Widget.widgets), v.conductor.data_version
    recording_comm.clear()
    third = _chain_motion(J=6, F=80, seed=3)
    v.set_motion(third, pose_frames=[12, 44], contacts=[("j2", 6, 31)])
    assert len(Widget.widgets) == n_widgets                 # no widget created (none closed)
    assert v.motion_tracks == tracks and all(t.comm is not None for t in tracks)
    assert list(v.conductor.actions) == actions and v.conductor.data_version == version + 1
    # the sent state is the new motion: the tracks (float32) posed by forward kinematics
    p, _ = sn.forward_kinematics(third)
    for f in (0, 17, 79):
        np.testing.assert_allclose(v.shown_positions(f), p[f], atol=1e-3)
    # bytes: every changed array once, binary; the unchanged times are not re-sent
    binary = sum(b for _, b in recording_comm)
    tr = scene3d.motion_tracks(third)
    changed = sum(a.nbytes for a in tr.quats.values())     # same root path and times: those are not re-sent
    assert changed <= binary <= 1.15 * tr.nbytes and v.edit_bytes == binary
    assert max(j for j, _ in recording_comm) < 1000    # no array as a JSON list (one track's would be ~3 kB)


def test_bytes_per_edit_of_a_2751_by_31_clip_are_binary_and_once(recording_comm):
    m = sn.data.load("cmu_01_01")
    assert (m.num_frames, m.num_joints) == (2751, 31)
    v = SkeletonView(m)
    edited = m.replace(local_quats=m.local_quats[::-1].copy())
    recording_comm.clear()
    v.set_motion(edited)
    json_bytes = sum(j for j, _ in recording_comm)
    binary = sum(b for _, b in recording_comm)
    tracks = scene3d.motion_tracks(edited)
    print(f"\nbytes per edit ({m.num_frames} x {m.num_joints}): binary {binary:,}, JSON {json_bytes:,}, "
          f"messages {len(recording_comm)}")
    assert binary >= sum(a.nbytes for a in tracks.quats.values())   # every changed float went, once (the
    # unchanged times and root path are not re-sent) ...
    assert binary <= 1.15 * tracks.nbytes             # ... and little else (camera path, highlights)
    assert json_bytes < 0.05 * binary                 # the arrays are buffers, not JSON lists
    assert v.edit_bytes == pytest.approx(binary, rel=0.02)
    # a frame step sends no arrays at all: the browser has the clip
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
    v.picker.object = v.spheres[3]
    v.picker.point = (1.0, 2.0, 3.0)
    assert v.selected_joint == "j3"
    bone = next(c for c in v.joint_groups[4].children if c not in v.joint_groups and c is not v.spheres[4])
    v.picker.object = bone        # a bone belongs to the joint that rotates it
    assert v.selected_joint == "j4"
    v.selected_joint = "j1"
    assert "selected: j1" in v.legend.value
    with pytest.raises(Exception, match="selected_joint"):
        v.selected_joint = "nope"


def test_trails_follow_the_joint_and_the_edits():
    m = _chain_motion(F=50)
    v = SkeletonView(m, trail_joints=["j5"], trail_seconds=0.1)
    pos, _ = sn.forward_kinematics(m)
    line = v.conductor.trails[0]
    np.testing.assert_allclose(np.asarray(line.geometry.attributes["position"].array), pos[:, 5], atol=1e-4)
    assert v.conductor.trail_window == 6   # 0.1 s at 60 Hz each side of the playhead
    m2 = _chain_motion(F=50, seed=3)
    v.set_motion(m2)
    p2, _ = sn.forward_kinematics(m2)
    np.testing.assert_allclose(np.asarray(v.conductor.trails[0].geometry.attributes["position"].array),
                               p2[:, 5], atol=1e-4)
    assert "trail j5" in v.legend.value
    v.trail_joints = []
    assert v.conductor.trails == []
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
    q = scene3d._y_to(np.array([1.0, 0.0, 0.0]))     # +y onto +x: -90 degrees about z
    np.testing.assert_allclose(q, [0, 0, -np.sqrt(0.5), np.sqrt(0.5)], atol=1e-12)


def test_ghost_is_the_original_overlaid_and_toggles():
    m = _chain_motion(F=30)
    edited = _chain_motion(F=30, seed=5)
    v = SkeletonView(edited, ghost=m, show_ghost=False)
    ghost_group = next(c for c in v.rig.children if getattr(c, "name", "") == "g0")
    assert not ghost_group.visible
    v.show_ghost = True
    assert ghost_group.visible and v.ghost_toggle.value
    assert "original (ghost)" in v.legend.value
    ghost_action = v.conductor.actions[-1]
    root = next(t for t in ghost_action.clip.tracks if t.name == "g0.position")
    np.testing.assert_allclose(np.asarray(root.values).reshape(-1, 3), m.root_positions, atol=1e-5)
    v.set_motion(edited.slice(0, 20))          # the ghost stays (not re-sent) when not given
    assert v.conductor.actions[-1] is ghost_action
