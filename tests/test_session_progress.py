"""Cull refits shared by kept pose set, and progress reports (fractional, tqdm bar) from edited/warm."""
from __future__ import annotations

import io

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import staggered
from stagger_nb.session import Session, progress_bar


@pytest.fixture
def session():
    s = Session(sn.data.load("walk").slice(0, 120))
    yield s
    s.close()


def _same_keep_percents(sm):
    """Two percents keeping the same poses, and one keeping a different set (brute force over a grid)."""
    by_keep = {}
    for p in np.arange(1.0, 100.0, 0.5):
        by_keep.setdefault(tuple(staggered.cull_keep(sm, float(p))), []).append(float(p))
    a, b = next(v[:2] for v in by_keep.values() if len(v) >= 2)
    c = next(v[0] for k, v in by_keep.items() if k != tuple(staggered.cull_keep(sm, a)))
    return a, b, c


def _assert_same_staggered(x, y):
    np.testing.assert_array_equal(x.pose_times, y.pose_times)
    np.testing.assert_allclose(staggered.evaluate(x).local_quats, staggered.evaluate(y).local_quats, atol=1e-12)


def test_percents_keeping_the_same_poses_share_one_cull_refit(session):
    sm = session.extraction()
    a, b, c = _same_keep_percents(sm)
    refits = []
    session.observe_busy(lambda kind, started: refits.append(kind) if started and kind == "cull" else None)
    assert session.warm(("cull", [a, b]), progress=lambda *r: None).result(120) == 2
    assert refits == ["cull"]  # one refit for both percents
    session.warm(("cull", [c])).result(120)
    assert refits == ["cull", "cull"]  # a different kept set is a new refit
    for p in (a, b, c):
        session.set_ops([{"op": "cull", "percent": p}])
        _assert_same_staggered(session.staggered(), staggered.cull(sm, p))
    n = len(staggered.cull_keep(sm, a))
    session.set_ops([{"op": "cull", "count": n}])  # the same kept set by count: no new refit
    _assert_same_staggered(session.staggered(), staggered.cull(sm, a))
    assert refits == ["cull", "cull"]


def test_edited_reports_fractional_progress_of_extract_and_cull(session):
    seen = []
    session.set_ops([{"op": "cull", "percent": 40}])
    session.edited(progress=lambda d, t, label: seen.append((d, t, label)))
    assert seen[0] == (0, 1, "cull") and seen[-1] == (1, 1, "done")
    inner = [d for d, _, _ in seen[1:-1]]
    assert inner and all(0.0 <= d <= 1.0 for d in inner)  # the extraction and refit report fractions
    assert any(0.0 < d < 1.0 for d in inner)
    assert inner == sorted(inner)  # monotone: extraction first, then the refit (one op's share)


def test_warm_reports_fractions_of_a_warp_table(session):
    seen = []
    session.warm(("warp_tables", [{"duration": 3.0, "skip": 4}]),
                 progress=lambda d, t, label: seen.append((d, label))).result(120)
    fractions = [d for d, label in seen if label == "warp tables 0"]
    assert any(0.0 < d < 1.0 for d in fractions) and seen[-1] == (1, "done")


def test_progress_bar_draws_a_tqdm_bar_and_closes_at_done(session):
    out = io.StringIO()
    bar = progress_bar("replay", file=out, mininterval=0)
    session.set_ops([{"op": "cull", "percent": 30}, {"op": "succession", "root": "Hips", "s": 0.05, "l": 1.0}])
    session.edited(progress=bar)
    assert bar.closed and bar.n == 2
    text = out.getvalue()
    assert "replay" in text and "2.0/2" in text
    with progress_bar("nothing", file=out) as idle:  # everything cached: no bar drawn, closed by the with
        session.edited(progress=idle)
    assert idle.closed and idle.n == 0
