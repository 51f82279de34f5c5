"""The three editors without a browser: move controls, compare the session's edited motion and the views'
synced state (pythreejs arrays, FigureWidget data) with direct calls of the technique modules."""
from __future__ import annotations

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import staggered, timewarp, wand
from stagger_nb.session import Session, joint_rotation_degrees

RUN = "xia_angry_run.bvh"      # 140 frames @ 120 Hz, 31 joints
WALK = "xia_neutral_walk.bvh"  # 327 frames


@pytest.fixture(scope="module")
def run(shared_motion):
    return shared_motion(RUN)


@pytest.fixture(scope="module")
def stagger_editor(run):
    from stagger_nb.widgets import StaggerEditor
    e = StaggerEditor(run, precompute=False)
    yield e
    e.close()


def _view_frame_positions(editor):
    return np.asarray(editor.view._attr.array)


def _fk(m, f):
    p, _ = sn.forward_kinematics(m)
    return p[f]


def test_stagger_sliders_replay_the_technique_calls(stagger_editor, run):
    e = stagger_editor
    e.session.clear()
    e.cull.value = 50
    e.s.value = 0.04
    e.l.value = 2.0
    e.tau.value = 0.03
    e.seed.value = 7
    assert e.message.value == "" or "timing warning" in e.message.value
    ops = e.session.ops
    assert [o["op"] for o in ops] == ["cull", "succession", "random_timing"]
    root = e.root.value
    direct = staggered.evaluate(staggered.random_timing(
        staggered.succession(staggered.cull(staggered.extract(run), percent=50), root=root, s=0.04, l=2.0),
        tau=0.03, seed=7))
    edited = e.session.edited()
    # same deterministic calls in the same order: bit-for-bit
    assert np.array_equal(edited.local_quats, direct.local_quats)
    e.view.frame = 61
    # float32 over the wire
    np.testing.assert_allclose(_view_frame_positions(e), _fk(direct, 61), rtol=1e-6, atol=1e-3)
    j = run.skeleton.index(e.joint.value)
    np.testing.assert_allclose(e.curves.figure["data"][0]["y"], joint_rotation_degrees(direct, j)[:, 0], atol=1e-9)
    sm = e.session.staggered()
    assert len(e.probability.figure["data"][2]["x"]) == sm.num_poses < len(e.probability.figure["data"][1]["x"])
    np.testing.assert_allclose(e.curves.figure["data"][6]["x"][::3], sm.pose_times + sm.refinements[:, j])


def test_stagger_l_tau_cull_change_plot_and_view(stagger_editor):
    e = stagger_editor
    e.session.clear()
    e.s.value = 0.05
    e.view.frame = 70
    before_view, before_plot = _view_frame_positions(e).copy(), np.array(e.curves.figure["data"][0]["y"])
    for w, v in [(e.l, 3.0), (e.tau, 0.08), (e.cull, 40.0)]:
        w.value = v
        after_view, after_plot = _view_frame_positions(e).copy(), np.array(e.curves.figure["data"][0]["y"])
        assert np.abs(after_view - before_view).max() > 1e-3, w.description  # the skeleton moved
        assert len(after_plot) != len(before_plot) or np.abs(after_plot - before_plot).max() > 1e-6, w.description
        before_view, before_plot = after_view, after_plot


def test_stagger_undo_restores_controls_and_bad_ops_show_a_message(stagger_editor):
    e = stagger_editor
    e.session.clear()
    l0 = e.l.value
    e.s.value = 0.02
    e.l.value = l0 + 0.5
    e.session.undo()
    assert e.l.value == l0 and e.s.value == 0.02
    e.session.undo()
    assert e.s.value == 0.0
    e.session.redo()
    assert e.s.value == 0.02
    e.session.set_ops([{"op": "edit_pose", "pose": 999, "deltas": {e.joint.value: [10, 0, 0]}}])
    assert "Error" in e.message.value and "999" in e.message.value  # shown, not raised
    e.session.clear()
    assert "Error" not in e.message.value


def test_stagger_nudge_and_exaggerate_and_save(stagger_editor, run, tmp_path):
    e = stagger_editor
    e.session.clear()
    e.pose.value = 2
    e.nudge[1].value = 25.0
    e.w_r.value = 0.5
    ops = e.session.ops
    assert ops[0] == {"op": "edit_pose", "pose": 2, "deltas": {e.joint.value: [0.0, 25.0, 0.0]}, "mode": "staggered"}
    assert ops[1]["op"] == "exaggerate" and ops[1]["w_r"] == 0.5
    sm = staggered.extract(run)
    direct = staggered.evaluate(staggered.exaggerate(
        staggered.edit_pose(sm, 2, deltas={e.joint.value: np.radians([0.0, 25.0, 0.0])}),
        list(range(sm.num_poses)), 0.5))
    assert np.array_equal(e.session.edited().local_quats, direct.local_quats)
    p = tmp_path / "stagger.json"
    e.session.save(p)
    assert np.array_equal(Session.load(p).edited().local_quats, direct.local_quats)


def test_wand_sigma_and_propagate(shared_motion):
    from stagger_nb.widgets import WandEditor
    m = shared_motion(RUN)
    e = WandEditor(m, frame=40, joint=m.skeleton.names[2], rotation=(25.0, 0.0, 0.0))
    try:
        q = m.local_quats[40].copy()
        from stagger_nb.session import apply_pose_deltas
        edited_pose = apply_pose_deltas(q, m.skeleton, {m.skeleton.names[2]: [25.0, 0.0, 0.0]})
        for sigma in (e.sigma.value, e.sigma.value * 1.5):
            e.sigma.value = sigma
            sigma = e.session.ops[0]["sigma"]  # the slider snaps to its precomputed grid
            assert sigma == pytest.approx(e.sigma.value, rel=0.05)  # within half a slider step (10**0.02)
            direct = wand.propagate(m, 40, edited_pose, sigma=sigma)
            # same basis computation via the cached pose graph: equal to round-off
            np.testing.assert_allclose(e.session.edited().local_quats, direct.local_quats, atol=1e-12)
            np.testing.assert_allclose(e.falloff_plot.figure["data"][0]["y"], wand.falloff(m, 40, sigma=sigma), atol=1e-12)
        assert e.message.value == ""
        y0 = np.array(e.falloff_plot.figure["data"][0]["y"])
        v0 = _view_frame_positions(e).copy()
        e.sigma.value = e.sigma.value / 2.5
        assert np.abs(np.array(e.falloff_plot.figure["data"][0]["y"]) - y0).max() > 1e-3
        assert np.abs(_view_frame_positions(e) - v0).max() > 1e-3  # view is off the edited frame: it moves
        e.compare["isomap"].value = True
        e.compare["spline"].value = True
        assert len(e.falloff_plot.figure["data"][1]["y"]) == m.num_frames and len(e.falloff_plot.figure["data"][2]["y"]) == m.num_frames
        e.propagate.value = False
        assert e.session.ops[0]["op"] == "edit_frame"
        diff = np.abs(e.session.edited().local_quats - m.local_quats).max(axis=(1, 2))
        assert np.flatnonzero(diff > 1e-9).tolist() == [40]
        e.falloff_plot.click_time(0.25)
        assert e.view.frame == 30
    finally:
        e.close()


def test_warp_editor_guided_linear_and_errors(shared_motion):
    from stagger_nb.widgets import WarpEditor
    m = shared_motion(WALK)
    e = WarpEditor(m)
    try:
        e.duration.value = 1.8
        n = int(round(1.8 / m.frame_time)) + 1
        out, warp = timewarp.guided_warp(m, m, n, skip=8)
        assert e.view.motion.num_frames == n
        np.testing.assert_allclose(e.warp_plot.figure["data"][1]["y"], warp, atol=1e-12)  # same tables, same DP
        np.testing.assert_allclose(e.session.edited().local_quats, out.local_quats, atol=1e-12)
        speed = np.array(e.warp_plot.figure["data"][3]["y"])
        np.testing.assert_allclose(speed, np.clip(timewarp.warp_speed(warp, m.frame_time), 0.1, 10), atol=1e-12)
        e.mode.value = "linear"
        y = np.array(e.warp_plot.figure["data"][1]["y"])
        np.testing.assert_allclose(np.diff(y, 2), 0.0, atol=1e-9)  # a straight line
        e.keytimes.value = "1.0:0.4"
        assert e.session.ops[0]["keytimes"] == [[1.0, 0.4]]
        e.keytimes.value = "1.0-0.4"
        assert "keytimes" in e.message.value and "Error" in e.message.value
        e.keytimes.value = "5.0:0.4"      # outside the input: the technique module refuses, shown as a message
        assert "Error" in e.message.value
        e.keytimes.value = ""
        e.mode.value = "guided"
        e.reference.value = "segment"
        assert e.session.ops[0]["reference"] == {"segment": list(e.segment.value)}
        assert "Error" not in e.message.value
    finally:
        e.close()


def test_warm_up_failure_is_kept_and_logged(run, monkeypatch, caplog):
    from stagger_nb.widgets import StaggerEditor

    def fail(self, percents, stop=None):
        raise RuntimeError("refit failed")

    monkeypatch.setattr(Session, "precompute_cull", fail)
    e = StaggerEditor(run)  # precompute=True: the warm-up thread runs (and fails) at once
    try:
        e.warm_thread.join(60)
        assert e.warm_thread.daemon and not e.warm_thread.is_alive()
        assert isinstance(e.warm_error, RuntimeError)
        assert "cache warm-up stopped: RuntimeError: refit failed" in caplog.text
    finally:
        e.close()


def test_progress_bar_shows_foreground_work_only(stagger_editor):
    """The warm-up's cache fills do not flash the progress bar (nor hide it under foreground work)."""
    import threading
    e = stagger_editor
    saved = e.warm_thread
    try:
        e._on_busy("cull", True)   # foreground: shown
        assert e.progress.layout.visibility == "visible"
        e.warm_thread = threading.Thread(target=lambda: e._on_busy("cull", False))
        e.warm_thread.start()
        e.warm_thread.join()
        assert e.progress.layout.visibility == "visible"  # the warm-up finishing did not hide it
        e._on_busy("cull", False)
        assert e.progress.layout.visibility == "hidden"
    finally:
        e.warm_thread = saved
