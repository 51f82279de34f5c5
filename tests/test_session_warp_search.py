"""Issue 26, the session side of the warp editor: a session's guided warp searches what ``timewarp.guided_warp``
would search for the same request (keytimes that ask for slow motion upsample, as the paper's expansions do,
§4.1 V3; a free-length search at the paper's 30 Hz output step on a 120 Hz clip), and the tables it warms are
the ones the replay then uses (no second table build)."""
from __future__ import annotations

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import timewarp
from stagger_nb.session import Session
from stagger_nb.session.ops import Op
from stagger_nb.session.runners import warp_search


@pytest.fixture(scope="module")
def cmu():
    return sn.data.load("cmu_01_01")


def _op(**kw):
    return Op.from_json(dict({"op": "guided_warp"}, **kw), "op")


def test_keytime_inside_the_clip_gives_a_warp_through_it(cmu):
    """Issue 26: CMU 01_01 (22.92 s) to 22.83 s with the keytime 2 s -> 1.5 s used to fail ("2510 input frames
    ... cannot be covered in 2560 steps of 1..8 frames"): the first 2 s must play at 1.33x and the rest slower
    than real time, which a compression's search (upsample 1) cannot do."""
    s = Session(cmu, ops=[{"op": "guided_warp", "duration": 22.83, "keytimes": [[2.0, 1.5]]}])
    out = s.edited()
    warp = s.warp_curve()
    ft = cmu.frame_time
    assert out.num_frames == int(round(22.83 / ft)) + 1
    assert np.interp(1.5, np.arange(warp.size) * ft, warp) == pytest.approx(2.0, abs=ft)
    assert np.all(np.diff(warp) >= -1e-9) and warp[0] == pytest.approx(0.0) and warp[-1] == pytest.approx(
        cmu.duration, abs=1e-6)
    # the same search as the function's own default for that request
    n, u, step = warp_search(cmu, _op(duration=22.83, keytimes=[[2.0, 1.5]]))
    assert (n, step) == (out.num_frames, 1)
    assert u == timewarp.required_upsample(cmu.num_frames, n, keytimes=[[2.0, 1.5]], frame_time=ft, skip=8) > 1


def test_free_length_searches_at_the_papers_output_rate(cmu):
    """Free length on a 120 Hz clip: the search of ``guided_warp`` (``free_length_search``: the input as it is,
    output frames searched every 1/30 s), not a 4x upsampled input of 11,001 frames."""
    n, u, step = warp_search(cmu, _op(free_length=True))
    assert n is None and (u, step) == timewarp.free_length_search(cmu.frame_time) == (1, 4)
    walk = sn.data.load("walk")   # 60 Hz: (2, 2)
    assert warp_search(walk, _op(free_length=True))[1:] == timewarp.free_length_search(walk.frame_time)
    # an explicit upsample is the op's own choice
    assert warp_search(walk, _op(free_length=True, upsample=3))[1:] == (3, 1)


def test_session_free_length_equals_the_function():
    m = sn.data.load("walk")
    s = Session(m, ops=[{"op": "guided_warp", "free_length": True, "skip": 6}])
    out = s.edited()
    ref, warp = timewarp.guided_warp(m, m, None, skip=6)
    assert out.num_frames == ref.num_frames
    np.testing.assert_allclose(s.warp_curve(), warp, atol=1e-9)


def test_session_keytimes_equal_the_function():
    m = sn.data.load("walk")
    kt = [[1.0, 1.6]]   # the first 1 s played over 1.6 s: slower than real time inside a compression (6 -> 5 s)
    s = Session(m, ops=[{"op": "guided_warp", "duration": 5.0, "skip": 6, "keytimes": kt}])
    s.edited()
    n = int(round(5.0 / m.frame_time)) + 1
    assert warp_search(m, s.typed_ops[0])[1] > 1
    _, warp = timewarp.guided_warp(m, m, n, skip=6, keytimes=kt)
    np.testing.assert_allclose(s.warp_curve(), warp, atol=1e-9)


@pytest.mark.parametrize("op", [{"free_length": True, "skip": 6}, {"duration": 5.0, "skip": 6, "backward": True},
                                {"duration": 5.0, "skip": 6, "keytimes": [[1.0, 1.6]]}])
def test_warmed_tables_are_the_ones_the_replay_uses(op, monkeypatch):
    """``Session.warm(("warp_tables", [op]))`` builds the tables the replay of ``op`` then finds: replaying
    after the warm-up calls ``prepare_warp`` no more."""
    m = sn.data.load("walk")
    s = Session(m)
    s.warm(("warp_tables", [dict(op)])).result(timeout=120)
    calls = []
    real = timewarp.prepare_warp
    monkeypatch.setattr(timewarp, "prepare_warp", lambda *a, **k: calls.append(1) or real(*a, **k))
    s.set_ops([dict(op, op="guided_warp")])
    s.edited()
    assert calls == []
