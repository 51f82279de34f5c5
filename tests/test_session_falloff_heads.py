"""Issue 26, the session side of the wand editor's comparison curves: the frame-independent heads (ISOMAP's
graph, the diffusion coordinates per sigma) are computed once and warmed in the background, so ticking
"compare diffusion" after the warm-up, or moving the edited frame with a comparison shown, costs a Dijkstra
or a norm; the curves equal the wand package's own functions."""
from __future__ import annotations

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import wand
from stagger_nb.session import Session


@pytest.fixture(scope="module")
def run():
    return sn.data.load("run")


def test_comparison_curves_equal_the_wand_functions(run):
    s = Session(run)
    sigma = 0.9 * float(s.wand_graph().default_sigma)
    for f, fr in ((40, None), (100, (20, 160))):
        c = s.falloff_curves(f, sigma, fr, compare=["isomap", "diffusion", "spline"])
        np.testing.assert_allclose(c["isomap"], 1 - wand.normalize_distance(wand.isomap_distance(run, f), fr),
                                   atol=1e-12)
        want = 1 - wand.normalize_distance(wand.diffusion_distance(run, f, sigma=sigma), fr)
        # the coordinates weighted below heads.DIFFUSION_TOL (1e-8) are left out: distances within that fraction
        np.testing.assert_allclose(c["diffusion"], want, atol=1e-9)   # measured: 4e-15
        assert c["green"][f] == pytest.approx(1.0)


def test_diffusion_coordinates_with_a_tolerance_match_matrix_powers(run):
    """Brute force: D_t(i, j)^2 = sum_l (P^t_il - P^t_jl)^2 / pi_l with P = D^-1 K (Coifman & Lafon 2006)."""
    from stagger_nb.wand.laplacian import dense_kernel, pairwise_sq_distances
    m = run.slice(0, 90)
    X = wand.pose_vectors(m)
    sigma, t, f = 0.8 * float(wand.default_sigma(X)), 4, 30
    K = dense_kernel(pairwise_sq_distances(X), sigma)
    r = K.sum(axis=1)
    Pt = np.linalg.matrix_power(K / r[:, None], t)
    want = np.sqrt(np.sum((Pt[f] - Pt) ** 2 / (r / r.sum()), axis=1))
    full = wand.diffusion_coordinates(m, t, sigma)
    cut = wand.diffusion_coordinates(m, t, sigma, tol=1e-6)
    assert cut.shape[1] < full.shape[1] == m.num_frames
    for c in (full, cut):
        got = np.linalg.norm(c - c[f], axis=1)
        assert np.allclose(got, want, atol=1e-5 * want.max())
    with pytest.raises(ValueError, match="tol"):
        wand.diffusion_coordinates(m, t, sigma, tol=1.0)


def test_ready_says_what_is_cached_and_warm_fills_it(run, monkeypatch):
    s = Session(run)
    sigma = float(s.wand_graph().default_sigma)
    assert s.falloff_ready(sigma, ["isomap", "diffusion", "spline"]) == ["spline"]
    n = s.warm(("wand_basis", [sigma]), ("compare", [("isomap", None), ("diffusion", sigma)])).result(timeout=300)
    assert n == 4   # graph, basis, isomap graph, diffusion coordinates
    assert s.falloff_ready(sigma, ["isomap", "diffusion", "spline"]) == ["green", "isomap", "diffusion", "spline"]
    assert s.falloff_ready(1.5 * sigma, ["diffusion"]) == []   # another sigma: not computed
    # after the warm-up a new frame's curves compute no head again
    calls = []
    for name in ("isomap_graph", "diffusion_coordinates"):
        real = getattr(wand, name)
        monkeypatch.setattr(wand, name, lambda *a, _r=real, _n=name, **k: calls.append(_n) or _r(*a, **k))
    for f in (10, 50, 120):
        s.falloff_curves(f, sigma, compare=["isomap", "diffusion"])
    assert calls == []


def test_warm_refuses_bad_compare_jobs_naming_them(run):
    s = Session(run)
    with pytest.raises(ValueError, match=r"jobs\[0\]\[1\]\[0\]"):
        s.warm(("compare", [("pca", None)]))
    with pytest.raises(ValueError, match=r"jobs\[0\]\[1\]\[0\]\[1\]"):
        s.warm(("compare", [("diffusion", -1.0)]))


def test_diffusion_on_a_long_clip_is_refused_in_plain_words():
    from stagger_nb.session import heads
    s = Session(sn.data.load("walk"))   # any clip: the limit is lowered for the check
    old = heads.DIFFUSION_MAX_FRAMES
    try:
        heads.DIFFUSION_MAX_FRAMES = 10
        with pytest.raises(ValueError, match="diffusion comparison builds a dense"):
            s.falloff_curves(0, None, compare=["diffusion"])
    finally:
        heads.DIFFUSION_MAX_FRAMES = old
