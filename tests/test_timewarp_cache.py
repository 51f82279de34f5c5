"""guided_warp reuses the tables of an earlier call with the same content (cached_prepare_warp): same results,
never stale ones after the input, the reference or an option changes."""
from __future__ import annotations

import numpy as np
import pytest

from stagger_nb import data, timewarp


@pytest.fixture(scope="module")
def walk():
    return data.load("walk").slice(0, 120)


def test_cached_call_gives_the_uncached_result(walk):
    timewarp.clear_tables_cache()
    out1, w1 = timewarp.guided_warp(walk, walk, 80)
    tables = timewarp.prepare_warp(walk, walk, 8)            # the uncached head
    out0, w0 = timewarp.guided_warp(walk, walk, 80, tables=tables)
    out2, w2 = timewarp.guided_warp(walk, walk, 80)          # served from the cache
    np.testing.assert_array_equal(w1, w0)
    np.testing.assert_array_equal(w2, w0)
    np.testing.assert_array_equal(out2.local_quats, out0.local_quats)


def test_cache_is_keyed_by_content_not_identity(walk):
    timewarp.clear_tables_cache()
    a = timewarp.cached_prepare_warp(walk, walk, 8)
    copy = walk.replace(local_quats=walk.local_quats.copy())
    assert timewarp.cached_prepare_warp(copy, copy, 8) is a          # equal content: reused
    q = walk.local_quats.copy()
    q[40, 3] = q[41, 3]
    changed = walk.replace(local_quats=q)
    b = timewarp.cached_prepare_warp(changed, changed, 8)
    assert b is not a and not np.array_equal(b.X, a.X)                # one frame changed: recomputed
    assert timewarp.cached_prepare_warp(walk, changed, 8) is not a    # another reference
    assert timewarp.cached_prepare_warp(walk, walk, 6) is not a       # another skip
    assert timewarp.cached_prepare_warp(walk, walk, 8, k=1) is not a  # another objective option
    with pytest.raises(ValueError, match="read-only"):
        a.scores[0, 0, 0] = 0.0                                        # shared tables cannot be corrupted
    timewarp.clear_tables_cache()
    assert timewarp.cached_prepare_warp(walk, walk, 8) is not a


def test_self_reference_features_are_the_reference_features(walk):
    """prepare_warp computes the features once for a self reference; they equal a separate computation."""
    t = timewarp.prepare_warp(walk, walk, 8)
    np.testing.assert_array_equal(t.R, timewarp.pose_features(walk))
    other = walk.replace(root_positions=walk.root_positions + 1.0)   # same poses in the torso frame
    t2 = timewarp.prepare_warp(walk, other, 8)
    np.testing.assert_allclose(t2.R, t.R, atol=1e-9)
    np.testing.assert_allclose(t2.scores, t.scores, rtol=1e-5, atol=1e-5)
