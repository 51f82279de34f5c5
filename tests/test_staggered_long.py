"""Bounded work at the staggered-pose public boundary (issue 13 items 2-3) and the fast paths that replace
slow ones (each checked against the slow path on small inputs). Long-take figures are in
benchmarks/bench_staggered_long.py, not here."""
from __future__ import annotations

import numpy as np
import pytest
from helpers import chain_motion

from stagger_nb import staggered
from stagger_nb.core.motion import Motion
from stagger_nb.core.rotations import quat_angle
from stagger_nb.staggered.features import laplacian_smooth


def _slow_smooth(signal, iterations, lam=0.5):
    """The original loop: one reflected 3-tap pass at a time."""
    p = np.array(signal, dtype=float)
    for _ in range(int(iterations)):
        prev = np.concatenate([p[1:2], p[:-1]])
        nxt = np.concatenate([p[1:], p[-2:-1]])
        p = p + 0.5 * lam * (prev - 2.0 * p + nxt)
    return p


@pytest.mark.parametrize("F,n,lam", [(2, 100, 0.5), (7, 65, 1.0), (60, 500, 0.5), (301, 3000, 0.3), (40, 12, 0.5)])
def test_spectral_smoothing_equals_the_pass_loop(rng, F, n, lam):
    x = rng.normal(size=(F, 4))
    np.testing.assert_allclose(laplacian_smooth(x, n, lam), _slow_smooth(x, n, lam), rtol=0, atol=1e-12)


def test_many_smoothing_passes_take_the_closed_form(rng):
    x = rng.normal(size=(5000, 8))
    y = laplacian_smooth(x, 10 ** 9, 0.5)             # the loop would take hours (CPU time: bench_staggered_long.py)
    # the limit is flat at the mean of the reflected (period 2F - 2) signal: ends count half
    mean = (x[0] / 2 + x[1:-1].sum(axis=0) + x[-1] / 2) / (x.shape[0] - 1)
    np.testing.assert_allclose(y, np.broadcast_to(mean, y.shape), rtol=0, atol=1e-12)


def _with_frame_time(m: Motion, ft: float) -> Motion:
    return Motion(m.skeleton, ft, m.root_positions, m.local_quats)


@pytest.mark.parametrize("ft", [1e-9, 1e-5, 1e-300])
def test_tiny_frame_time_is_refused_quickly_naming_frame_time_and_resample(ft):
    # Motion's own constructor now refuses such frame times (core.motion.check_frame_time); either way the
    # request ends at once in a ValueError naming frame_time, never in an endless smoothing loop
    with pytest.raises(ValueError, match=r"frame_time"):
        staggered.extract(_with_frame_time(chain_motion([0.5, 1.0, 1.5], duration=0.5), ft))


def test_a_high_but_allowed_frame_rate_extracts_exactly():
    m = chain_motion([0.2, 0.25, 0.3], duration=0.4, fps=5000.0)     # 2001 frames, 80,000 smoothing passes
    sm = staggered.extract(m)                         # (its CPU time: benchmarks/bench_staggered_long.py)
    out = staggered.evaluate(sm)
    assert quat_angle(out.local_quats, m.local_quats).max() < 1e-6


@pytest.mark.parametrize("option,value", [
    ("iterations", 1e9), ("iterations", -1), ("iterations", 2.5), ("iterations", "2"), ("iterations", True),
    ("filter_width", 1e9), ("filter_width", 0.0), ("filter_width", float("nan")), ("filter_width", "0.15"),
    ("refinement_window", -0.1), ("refinement_window", float("inf")),
    ("smoothing_iterations", 1e30), ("smoothing_iterations", -3), ("smoothing_iterations", 1.5),
    ("smoothing_lambda", 0.0), ("smoothing_lambda", 2.0),
    ("root_translation_weight", -1.0), ("contact_weight", float("nan")), ("contact_tolerance", 0.0),
    ("contact_min_duration", 1e9), ("contact_min_duration", 0.0), ("min_prominence", 5.0),
    ("continuity", "C2"), ("contacts", [("NoSuchJoint", 0, 5)]), ("contacts", [("J1", 5, 2)]),
    ("contacts", [("J1", 0, 10 ** 9)]), ("contacts", 3), ("bogus", 1),
])
def test_every_option_is_checked_with_an_error_naming_it(option, value):
    m = chain_motion([0.5, 1.0, 1.5], duration=2.0)
    with pytest.raises(ValueError, match=option):
        staggered.extract(m, **{option: value})


def test_valid_options_still_work():
    m = chain_motion([0.5, 1.0, 1.5], duration=2.0)
    sm = staggered.extract(m, iterations=0, filter_width=0.2, smoothing_iterations=3, smoothing_lambda=1.0,
                           contacts=[("J1", 10, 40)], continuity="C0", min_prominence=0.0)
    assert sm.num_poses >= 2


@pytest.mark.parametrize("kw", [{"percent": 0.0}, {"percent": 1e9}, {"percent": "50"}, {"count": 1},
                                {"count": 2.5}, {"iterations": 1e9}, {"continuity": "x"}])
def test_cull_options_are_checked(kw):
    sm = staggered.extract(chain_motion([0.5, 1.0, 1.5], duration=2.0))
    name = next(iter(kw))
    with pytest.raises(ValueError, match=name):
        staggered.cull(sm, **kw)


@pytest.mark.parametrize("F,width,ft", [(50, 1.0, 0.004), (400, 2.0, 1 / 240), (30, 3.0, 1 / 120), (3000, 0.5, 1e-3)])
def test_long_tent_kernels_by_fft_equal_direct_convolution(rng, F, width, ft):
    from scipy.ndimage import convolve1d

    from stagger_nb.staggered.extraction import tent_filter
    x = rng.uniform(size=F)
    R = width / ft
    n = int(np.floor(R))
    k = np.maximum(0.0, 1.0 - np.abs(np.arange(-n, n + 1)) / R)
    assert k.size > 255
    np.testing.assert_allclose(tent_filter(x, ft, width), convolve1d(x, k / k.sum(), mode="nearest"),
                               rtol=0, atol=1e-12)


def _slow_contacts(motion, tolerance, min_duration=0.25):
    """Appendix B the straightforward way (the previous loop): for each effector, grow a still window
    frame by frame while the bounding box of its positions stays within ``tolerance``."""
    from stagger_nb.core.kinematics import forward_kinematics
    from stagger_nb.staggered.contacts import end_effectors
    sk = motion.skeleton
    pos, _ = forward_kinematics(motion)
    F = motion.num_frames
    L = max(int(np.ceil(min_duration / motion.frame_time - 1e-9)) + 1, 2)
    out = []
    for j in [sk.index(n) if isinstance(n, str) else int(n) for n in end_effectors(sk)]:
        p = pos[:, j]
        s = 0
        while s <= F - L:
            lo, hi = p[s:s + L].min(axis=0), p[s:s + L].max(axis=0)
            if np.linalg.norm(hi - lo) > tolerance:
                s += 1
                continue
            e = s + L
            while e < F and np.linalg.norm(np.maximum(hi, p[e]) - np.minimum(lo, p[e])) <= tolerance:
                lo, hi = np.minimum(lo, p[e]), np.maximum(hi, p[e])
                e += 1
            out.append((sk.names[j], s, e))
            s = e
    return sorted(out, key=lambda c: (c[1], c[0]))


@pytest.mark.parametrize("name,tol", [("walk", 2.0), ("run", 4.0), ("jump", 1.0)])
def test_contact_detection_in_blocks_equals_the_frame_by_frame_loop(name, tol):
    from stagger_nb import data
    m = data.load(name)
    got = staggered.detect_contacts(m, tol, hand_support=None)
    assert got == _slow_contacts(m, tol) and len(got) > 0


def test_cull_keep_names_the_poses_cull_keeps():
    sm = staggered.extract(chain_motion([0.3, 0.6, 0.9, 1.2, 1.5], duration=2.0))
    for pc in (1, 30, 50, 80, 100):
        keep = staggered.cull_keep(sm, pc)
        out = staggered.cull(sm, pc)
        np.testing.assert_array_equal(sm.pose_times[keep], out.pose_times)
        assert keep[0] == 0 and keep[-1] == sm.num_poses - 1


@pytest.mark.parametrize("fit_samples", [4, 8, 12])
def test_subsampled_fit_equals_the_full_fit_where_pairs_are_short(fit_samples):
    """Pairs with at most fit_samples samples are fitted from exactly the same samples: same result."""
    m = chain_motion([0.3, 0.6, 0.9, 1.2, 1.5], duration=2.0, fps=30.0)
    sm = staggered.extract(m, fit_samples=None)
    short = int(sm.displacement_counts.max())
    a = staggered.extract(m, fit_samples=max(short, fit_samples))
    np.testing.assert_array_equal(a.tangents, sm.tangents)
    np.testing.assert_array_equal(a.displacements, sm.displacements)


def test_subsampled_fit_stays_exact_and_close_to_the_full_fit():
    from stagger_nb import data
    m = data.load("walk")
    full = staggered.extract(m, fit_samples=None)
    sub = staggered.extract(m, fit_samples=12)
    assert int(full.displacement_counts.max()) > 12                  # the subsample is really used
    assert quat_angle(staggered.evaluate(sub).local_quats, m.local_quats).max() < 1e-9
    rf, rs = full.metadata["fit"]["mean_residual_rad"], sub.metadata["fit"]["mean_residual_rad"]
    assert rs < 1.05 * rf                  # within 5 % of the fit to every sample


def test_progress_reports_increasing_fractions_to_one():
    m = chain_motion([0.3, 0.6, 0.9, 1.2, 1.5], duration=2.0)
    seen = []
    sm = staggered.extract(m, progress=seen.append)
    assert seen[0] == 0.0 and seen[-1] == 1.0 and all(b >= a for a, b in zip(seen, seen[1:]))
    seen.clear()
    staggered.cull(sm, 50, progress=seen.append)
    assert seen and seen[-1] == 1.0


def test_evaluate_and_cull_refuse_work_a_tiny_frame_time_would_ask_for():
    import dataclasses
    sm = staggered.extract(chain_motion([0.5, 1.0, 1.5], duration=2.0))
    tiny = dataclasses.replace(sm, frame_time=1e-9)                 # 2e9 default frames
    with pytest.raises(ValueError, match="evaluate: .*times"):
        staggered.evaluate(tiny)
    with pytest.raises(ValueError, match="frame_time"):
        staggered.cull(tiny, 50)
    with pytest.raises(ValueError, match="evaluate: .*times"):
        staggered.evaluate(sm, np.linspace(0, 2, 10 ** 7))
