"""ISOMAP / diffusion / spline curves of §4 (Figure 3) against brute force, and the Figure 3b smoothness."""
import numpy as np
import pytest
from wand_motions import cyclic_motion

from stagger_nb import wand
from stagger_nb.wand.laplacian import pairwise_sq_distances


def test_isomap_matches_floyd_warshall():
    m = cyclic_motion(F=30, period=11, noise=0.05, seed=21)
    X = wand.pose_vectors(m)
    D = np.sqrt(pairwise_sq_distances(X))
    k = 4
    W = np.full((30, 30), np.inf)
    np.fill_diagonal(W, 0.0)
    for i in range(30):   # the kNN edges (both directions) and the temporal chain, by hand
        for j in np.argsort(D[i] + np.where(np.arange(30) == i, np.inf, 0))[:k]:
            W[i, j] = W[j, i] = D[i, j]
        if i + 1 < 30:
            W[i, i + 1] = W[i + 1, i] = D[i, i + 1]
    for via in range(30):
        W = np.minimum(W, W[:, [via]] + W[[via], :])
    for f in (0, 13, 29):
        # sums of the same edge lengths in another order: rounding only
        assert np.allclose(wand.isomap_distance(m, f, k=k), W[f], atol=1e-12)


def test_diffusion_distance_matches_matrix_powers():
    m = cyclic_motion(F=25, period=9, noise=0.05, seed=22)
    X = wand.pose_vectors(m)
    sigma, t = 0.6, 3
    K = np.exp(-pairwise_sq_distances(X) / (2 * sigma ** 2))   # plain Eq. 1 (no chain floor)
    r = K.sum(axis=1)
    Pt = np.linalg.matrix_power(K / r[:, None], t)
    pi = r / r.sum()
    f = 7
    want = np.sqrt(np.sum((Pt[f] - Pt) ** 2 / pi, axis=1))
    got = wand.diffusion_distance(m, f, steps=t, sigma=sigma)
    # the diffusion module uses the chain-floored kernel only through default_sigma; this check fixes sigma.
    # 1e-9: an eigendecomposition against three matrix products
    assert np.allclose(got, want, atol=1e-9 * want.max())
    with pytest.raises(ValueError, match="steps"):
        wand.diffusion_distance(m, f, steps=0)


def test_spline_falloff_values():
    w = wand.spline_falloff(21, 10, 8)
    assert w[10] == 1.0 and w[2] == 0.0 and w[18] == 0.0 and np.all(w[:3] == 0) and np.all(w[18:] == 0)
    assert w[6] == pytest.approx(0.5, abs=1e-15)    # smoothstep(1/2) = 1/2
    assert np.allclose(w, w[::-1], atol=0)          # symmetric about the middle frame
    a = wand.spline_falloff(21, 10, (4, 8))
    assert a[6] == 0.0 and a[14] == pytest.approx(0.5, abs=1e-15)
    assert np.allclose(wand.smoothstep([0, 0.25, 1]), [0, 0.15625, 1], atol=1e-15)
    with pytest.raises(ValueError, match="extent"):
        wand.spline_falloff(10, 3, 0)


def test_normalize_distance():
    d = np.array([2.0, 1.0, 0.0, np.inf, 4.0])
    assert np.allclose(wand.normalize_distance(d), [0.5, 0.25, 0, 1, 1], atol=0)
    assert np.allclose(wand.normalize_distance(d, (0, 3)), [1, 0.5, 0, 1, 1], atol=0)


# Figure 3b, measured on the normalised curves (0 at the frame, 1 at the farthest frame) with defaults:
# second difference d[i-1] - 2 d[i] + d[i+1] at the edited frame, Green / ISOMAP (k=8) / diffusion (10 steps)
#   xia_angry_run   i=10: 0.0023 / 0.0099 / 0.0035      i=20: 0.0047 / 0.0161 / 0.0334
#   xia_neutral     i=50: 0.0054 / 0.0245 / 0.1079      i=100: 0.0138 / 0.0306 / 0.1009 (ratio 0.45: the
#                   closest case)                       i=150: 0.0014 / 0.0184 / 0.0149
# (Eq. 3 with its self term would give 0.04-0.08 on angry_run: the spike the default drops.)
@pytest.mark.shared
@pytest.mark.parametrize("name,frames", [("xia_angry_run.bvh", (10, 20)), ("xia_neutral_walk.bvh", (50, 100, 150))])
def test_greens_falloff_is_rounded_where_isomap_has_a_corner(shared_motion, name, frames):
    m = shared_motion(name)
    basis = wand.greens_basis(m)
    for i in frames:
        g = wand.greens_distance(basis, i)
        iso = wand.normalize_distance(wand.isomap_distance(m, i))
        d2 = lambda d: d[i - 1] - 2 * d[i] + d[i + 1]   # noqa: E731
        # a corner: ISOMAP's one-frame slopes on both sides add up; the Green's curve is flat-bottomed
        assert d2(g) <= 0.5 * d2(iso), (i, d2(g), d2(iso))


def test_figure3_curves_overlay():
    m = cyclic_motion(F=90, period=30, noise=0.01, seed=23)
    basis = wand.greens_basis(m)
    c = wand.figure3_curves(m, 40, basis=basis)
    assert set(c) == {"green", "isomap", "diffusion", "spline"}
    for name, d in c.items():
        assert d.shape == (90,) and d[40] == 0.0 and np.all((d >= 0) & (d <= 1)), name
    assert np.array_equal(c["green"], wand.greens_distance(basis, 40))
    before, after = wand.falloff_extent(wand.greens_falloff(basis, 40), 40)
    # the spline reaches 1 exactly where the Green's curve has its valley bottoms
    assert c["spline"][40 - before] == 1.0 and c["spline"][40 + after] == 1.0
    assert c["spline"][40 - before + 1] < 1.0 and c["spline"][40 + after - 1] < 1.0
    # a periodic motion with period 30: the valleys are about half a period away on each side
    assert 10 <= before <= 20 and 10 <= after <= 20
