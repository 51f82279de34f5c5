"""The clip's ends after timing edits (§4.1: the first and last frames are poses; §5.2 timing tools).

Regression of the editor review: xia_angry_run culled to 60 % (3 poses) with succession from the Hips put
LeftForeArm's knot of pose 1 2 frames before the clip's end (s = 0.085 s/bone: the 0.53 s last segment
played in 2 frames, -122 -> -54 -> -81 deg) or past it (s >= 0.09: the last frame never reached the last
pose, 41 deg off). The easing is opt-in (``ease_ends=True``): by default the timing tools apply §5.2's
formula exactly (tests/test_staggered_editing.py) and timing_warnings reports the crossing.
"""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import staggered
from stagger_nb.core.rotations import quat_angle
from stagger_nb.staggered.saturation import END_FLOOR, inside_ends


def test_inside_ends_identity_c1_increasing_bounded():
    """Brute force on a dense grid of knot times for one interior knot between ends at 0 and 1 s."""
    t = np.array([0.0, 0.4, 1.0])                      # zones: below 0.2 s and above 0.7 s
    x = np.linspace(-3.0, 4.0, 70_001)
    knots = np.stack([np.zeros_like(x), x, np.ones_like(x)])          # (3, N): one column per trial
    moved = np.ones_like(knots, bool)
    e = inside_ends(knots, t, moved)[1]
    mid = (x >= 0.2) & (x <= 0.7)
    assert np.array_equal(e[mid], x[mid])                             # identity outside the end zones
    assert np.all(np.diff(e) > 0)                                     # increasing: order kept
    assert e.max() < 1.0 - END_FLOOR * 0.3 and e.min() > 0.0 + END_FLOOR * 0.2   # floors (h = 0.3, 0.2)
    slope = np.diff(e) / np.diff(x)
    assert np.abs(slope[np.searchsorted(x, 0.7) + 1] - 1.0) < 1e-3    # C1 at the zone's start (grid step 1e-4)
    assert np.abs(slope[np.searchsorted(x, 0.2) - 2] - 1.0) < 1e-3
    assert np.array_equal(inside_ends(knots, t, ~moved), knots)        # knots not moved stay
    two = np.array([[0.0], [1.0]])
    assert np.array_equal(inside_ends(two, t[[0, 2]], np.ones((2, 1), bool)), two)


@pytest.fixture(scope="module")
def culled(shared_motion):
    """The review's clip culled to 60 % (3 poses; skipped where ../shared/mocap is absent)."""
    m = shared_motion("xia_angry_run.bvh")
    return m, "LeftForeArm", staggered.cull(staggered.extract(m), 60)


@pytest.mark.parametrize("s, l", [(0.085, 1.0), (0.1, 1.0), (-0.1, 2.0), (0.1, 4.0)])
def test_succession_keeps_the_end_poses_and_no_squeeze(culled, s, l):
    m, joint, sm = culled
    out = staggered.succession(sm, root="Hips", s=s, l=l, ease_ends=True)
    T, t = out.knot_times(), out.pose_times
    hi, lo = (t[-1] - t[-2]) / 2, (t[1] - t[0]) / 2
    assert np.all(T[-1] - T[-2] >= END_FLOOR * hi - 1e-12)           # the end segments keep time
    assert np.all(T[1] - T[0] >= END_FLOOR * lo - 1e-12)
    e = staggered.evaluate(out)
    assert e.num_frames == m.num_frames
    # the clip's first and last frames are the end poses, i.e. the source frames (rounding only)
    assert quat_angle(e.local_quats[[0, -1]], m.local_quats[[0, -1]]).max() < 1e-6
    # no squeezed end: the edited joint's step per frame at the ends stays within 8x the source's largest
    # (the floor keeps >= 1/8 of the pose spacing; the unfixed s = 0.085 made a 68 deg step, 25x)
    j = m.skeleton.index(joint)
    step = quat_angle(e.local_quats[1:, j], e.local_quats[:-1, j])
    src = quat_angle(m.local_quats[1:, j], m.local_quats[:-1, j]).max()
    assert max(step[:5].max(), step[-5:].max()) < 8 * src


def test_random_timing_keeps_the_end_poses(culled):
    m, _, sm = culled
    for seed in range(4):
        out = staggered.random_timing(sm, tau=0.6, seed=seed, ease_ends=True)      # wider than the pose spacing
        T = out.knot_times()
        assert np.all(T[1:-1] > T[0]) and np.all(T[1:-1] < T[-1])
        e = staggered.evaluate(out)
        assert quat_angle(e.local_quats[[0, -1]], m.local_quats[[0, -1]]).max() < 1e-6


def test_sample_run_end_frames_after_succession():
    """The bundled run (data/run.bvh, no shared clips needed): succession from the root at the slider's end
    pushed knots past the last pose (72 deg at the last frame before the fix)."""
    from stagger_nb import data
    m = data.load("run")
    sm = staggered.cull(staggered.extract(m), 60)
    for s in (0.085, 0.1, -0.1):
        e = staggered.evaluate(staggered.succession(sm, root=m.skeleton.names[0], s=s, l=1.0, ease_ends=True))
        assert quat_angle(e.local_quats[[0, -1]], m.local_quats[[0, -1]]).max() < 1e-6
