"""Local cull refit (``cull(..., local=True)``, :func:`stagger_nb.staggered.fitting.refit_merged`) against the
full refit (``local=False``): both reproduce the motion exactly at the frames; between frames they differ by
what the full refit's global C1 steps move away from the removed poses (bounded below); C0 fits are per
segment, so there the two agree to rounding."""
from pathlib import Path

import numpy as np
import pytest

from stagger_nb import data, read_bvh, staggered

REAL = Path(__file__).resolve().parents[1].parent / "shared" / "mocap"


def _angle(a, b):
    """Rotation angle (rad) between unit quaternions, accurate near 0 (chord form, not arccos)."""
    c = np.minimum(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))
    return 4.0 * np.arcsin(np.clip(c / 2.0, 0.0, 1.0))


def _compare(sm, percents, mid_tol):
    ref = staggered.evaluate(sm)
    for pc in percents:
        a = staggered.cull(sm, pc)
        b = staggered.cull(sm, pc, local=False)
        np.testing.assert_array_equal(staggered.cull_keep(sm, pc).size, a.num_poses)
        np.testing.assert_array_equal(a.pose_times, b.pose_times)
        ea = staggered.evaluate(a, ref.times)
        assert _angle(ea.local_quats, ref.local_quats).max() < 1e-9, pc          # exact at the frames
        np.testing.assert_allclose(ea.root_positions, ref.root_positions, atol=1e-9)
        np.testing.assert_allclose(a.root_tangents, b.root_tangents, atol=1e-9)   # root refitted whole
        mid = (ref.times[:-1] + ref.times[1:]) / 2.0
        qa, qb = staggered.evaluate(a, mid), staggered.evaluate(b, mid)
        assert _angle(qa.local_quats, qb.local_quats).max() < mid_tol, pc
        ra, rb = a.metadata["fit"]["mean_residual_rad"], b.metadata["fit"]["mean_residual_rad"]
        assert ra <= 1.1 * rb + 1e-6, (pc, ra, rb)                                # fits about as well


@pytest.fixture(scope="module")
def walk():
    return data.load("walk")


def test_local_cull_matches_full_refit_procedural(walk):
    sm = staggered.extract(walk)
    _compare(sm, (10, 25, 50, 75, 95), 2e-3)


def test_local_cull_is_c1_where_the_full_one_is():
    from stagger_nb.staggered.rotation_fit_c1 import velocity_jumps
    sm = staggered.extract(data.load("walk"))
    a = staggered.cull(sm, 50)
    jump, speed = velocity_jumps(a)
    assert jump.max() < 1e-6 * max(1.0, speed.max())


def test_local_cull_c0_equals_full_refit(walk):
    sm = staggered.extract(walk, continuity="C0")
    for pc in (20, 60):
        a = staggered.cull(sm, pc, continuity="C0")
        b = staggered.cull(sm, pc, continuity="C0", local=False)
        np.testing.assert_allclose(np.abs(np.sum(a.tangents * b.tangents, -1)), 1.0, atol=1e-9)


def test_local_cull_matches_full_refit_real_clip():
    try:
        m = data.load("cmu_01_01").slice(0, 900)
    except Exception as e:
        pytest.skip(f"cmu_01_01 not available: {e}")
    _compare(staggered.extract(m), (10, 30, 50, 70, 90), 2e-3)
    p = REAL / "cmu_131_01_walk_startstop.bvh"
    if p.is_file():
        # 1e-2 rad (0.57 deg) between frames only: both culls reproduce every frame exactly (checked above); between
        # frames they differ by how two valid spline fits bend over half a frame (5.4e-3 rad measured at 80 %)
        _compare(staggered.extract(read_bvh(p)), (20, 50, 80), 1e-2)


def test_local_cull_keeps_far_segments_verbatim(walk):
    """Segments between kept consecutive poses, not beside a merged one, keep controls and maps bit-for-bit
    (the local path ran)."""
    sm = staggered.extract(walk)
    keep = staggered.cull_keep(sm, 90)
    a = staggered.cull(sm, 90)
    merged = np.diff(keep) > 1
    near = merged | np.r_[False, merged[:-1]] | np.r_[merged[1:], False]
    far = np.flatnonzero(~near)
    assert far.size > 0
    np.testing.assert_array_equal(a.tangents[far], sm.tangents[keep[far]])
    np.testing.assert_array_equal(a.displacement_counts[far], sm.displacement_counts[keep[far]])
    M = min(a.displacements.shape[2], sm.displacements.shape[2])
    np.testing.assert_array_equal(a.displacements[far][:, :, :M], sm.displacements[keep[far]][:, :, :M])


@pytest.mark.parametrize("local", [True, False])
def test_cull_with_evaluated_source_gives_the_same_refit(walk, local):
    """``cull(sm, pc, evaluated=evaluate(sm))`` reads the source samples on frames from the given motion
    instead of evaluating them again: the same refit up to rounding, on the local and full refit paths and
    on an edited (off-grid) motion whose refit samples mostly fall between frames. Tolerances: the inputs
    differ by ~1e-16 (evaluate and evaluate_samples batch the same kernels differently); knots, editing
    knots and the root are copied or exact (1e-12); the Levenberg-Marquardt tangent fit amplifies that
    rounding to <= 5e-9 (measured), which the displacement maps absorb: frames agree to 1e-12."""
    sm = staggered.extract(walk)
    r = np.array(sm.refinements)
    r[1:-1] += 0.37 * sm.frame_time                        # knots off the frame grid: the 4x oversampled refit
    for s in (sm, staggered.StaggeredMotion(**{**sm.__dict__, "refinements": r})):
        ev = staggered.evaluate(s)
        for pc in (20, 60, 90):
            a = staggered.cull(s, pc, local=local)
            b = staggered.cull(s, pc, local=local, evaluated=ev)
            for name, tol in (("values", 1e-12), ("editing_knots", 1e-12), ("root_values", 1e-12),
                              ("tangents", 1e-8), ("displacements", 1e-8)):
                x, y = getattr(a, name), getattr(b, name)
                if name in ("values", "tangents", "editing_knots"):
                    y = y * np.sign(np.sum(x * y, axis=-1, keepdims=True))   # q ≡ -q
                np.testing.assert_allclose(y, x, rtol=0, atol=tol, err_msg=f"{name} at {pc} %")
            np.testing.assert_allclose(staggered.evaluate(b).local_quats, staggered.evaluate(a).local_quats,
                                       rtol=0, atol=1e-12)


def test_cull_rejects_an_evaluated_motion_of_another_clip(walk):
    sm = staggered.extract(walk)
    with pytest.raises(ValueError, match="evaluated"):
        staggered.cull(sm, 50, evaluated=walk.slice(0, 10))
