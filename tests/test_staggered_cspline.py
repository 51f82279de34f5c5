"""The optional C kernel of ``staggered.evaluate`` (stagger_nb/staggered/_cspline.c): the same bits as the numpy
path (``STAGGER_NB_NO_ACCEL=1`` forces it) on extractions, culls, timing and pose edits, multi-block sample
counts, and displacements wide enough for qexp's wide-angle branch; skipped where it was not built."""
from __future__ import annotations

import dataclasses
import os

import numpy as np
import pytest
from references import evaluate_reference

from stagger_nb import data, staggered
from stagger_nb.staggered import _kernels as K
from stagger_nb.staggered.evaluation import evaluate_samples

needs_c = pytest.mark.skipif(K._cspline is None, reason="the C kernel was not built here (no compiler at install)")


def test_the_kernel_is_built_on_ci():
    """CI installs with a compiler: a silent fallback there must not pass as the fast path."""
    if os.environ.get("CI", "").lower() not in ("1", "true", "yes"):
        pytest.skip("not on CI (CI=true): a machine without a compiler may run the fallback")
    assert K.accelerated()


def test_the_env_var_forces_the_fallback(monkeypatch):
    monkeypatch.setenv(K.NO_ACCEL_ENV, "1")
    assert not K.accelerated()
    monkeypatch.setenv(K.NO_ACCEL_ENV, "0")
    assert K.accelerated() == (K._cspline is not None)


def _both(monkeypatch, f):
    """``f()`` with the C kernel, then with the numpy path."""
    monkeypatch.setenv(K.NO_ACCEL_ENV, "0")
    a = f()
    monkeypatch.setenv(K.NO_ACCEL_ENV, "1")
    b = f()
    monkeypatch.setenv(K.NO_ACCEL_ENV, "0")
    return a, b


@pytest.fixture(scope="module")
def edits():
    m = data.load("walk")
    sm = staggered.extract(m)
    culled = staggered.cull(sm, 50.0)
    ex = staggered.exaggerate(culled, list(range(culled.num_poses)), 0.8)
    timed = staggered.random_timing(staggered.succession(ex, root=m.skeleton.names[0], s=0.03, l=1.5),
                                    tau=0.06, seed=3)
    # displacements scaled so |d| / 2 exceeds 1 rad somewhere: qexp's wide-angle branch (cos h = sin(pi/2 - h))
    d = sm.displacements
    scale = 2.5 / max(float(np.linalg.norm(d, axis=-1).max()) / 2.0, 1e-9)
    wide = dataclasses.replace(sm, displacements=d * scale)
    return {"extraction": sm, "cull": culled, "exaggerate": ex, "succession + tau": timed, "wide displacements": wide}


@needs_c
@pytest.mark.parametrize("name", ["extraction", "cull", "exaggerate", "succession + tau", "wide displacements"])
def test_evaluate_is_bit_identical_to_the_numpy_path(monkeypatch, edits, name):
    sm = edits[name]
    if name == "wide displacements":
        assert np.linalg.norm(sm.displacements, axis=-1).max() / 2 > 1.0      # the branch is reached
    a, b = _both(monkeypatch, lambda: staggered.evaluate(sm))
    assert np.array_equal(a.local_quats, b.local_quats)
    assert np.array_equal(a.root_positions, b.root_positions)
    # and the numpy path itself still matches the per-joint reference (the kernels compute the right thing)
    ref = evaluate_reference(sm, a.times + sm.pose_times[0])
    ref /= np.linalg.norm(ref, axis=-1, keepdims=True)
    chord = np.minimum(np.linalg.norm(ref - a.local_quats, axis=-1), np.linalg.norm(ref + a.local_quats, axis=-1))
    assert chord.max() < 1e-12          # chord of unit quaternions ~ half the angle (arccos of a dot is ~1e-8 blind)


@needs_c
def test_several_blocks_and_scattered_samples(monkeypatch, edits):
    """More samples than one block (4 * CHUNK (time, joint) samples): the C kernel writes each block at its
    offset; evaluate_samples (scattered joints and times, off the knots) too."""
    sm = edits["succession + tau"]
    times = np.linspace(sm.pose_times[0] - 0.1, sm.pose_times[-1] + 0.1, 4 * K.CHUNK // sm.num_joints + 777)
    assert times.size * sm.num_joints > 4 * K.CHUNK
    a, b = _both(monkeypatch, lambda: staggered.evaluate(sm, times))
    assert np.array_equal(a.local_quats, b.local_quats)
    rng = np.random.default_rng(5)
    t = rng.uniform(sm.pose_times[0], sm.pose_times[-1], 5000)
    j = rng.integers(0, sm.num_joints, 5000)
    a, b = _both(monkeypatch, lambda: evaluate_samples(sm, t, j))
    assert np.array_equal(a, b)


@needs_c
def test_fits_and_remeasures_are_bit_identical(monkeypatch):
    """The spline-only kernel (no displacement, renormalised) serves the fit (extract, cull) and exaggerate's
    re-measured displacement maps: every array of the results equal with and without it."""
    m = data.load("walk")

    def run():
        sm = staggered.extract(m)
        c = staggered.cull(sm, 60.0)
        return [sm, c, staggered.exaggerate(c, list(range(c.num_poses)), 0.7)]

    for a, b in zip(*_both(monkeypatch, run)):
        for name in ("values", "tangents", "displacements", "root_values", "root_tangents", "root_displacements"):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name
