"""The WarpEditor given a reference (``WarpEditor(cmu, cmu)``, as issue 26 opened it) starts on the warp guided by
that reference with nothing to undo: the first warp is the editor's opening state, not a step the user made.
Before, its guided_warp op was an undo step as soon as the editor opened (undo enabled, undoing it dropped the
reference the user asked for). A session the user hands in keeps its own history."""
from __future__ import annotations

import pytest

from stagger_nb import data
from stagger_nb.session import Session
from stagger_nb.widgets import WarpEditor


@pytest.fixture
def clip():
    return data.load("cmu_01_01").slice(0, 480)


def test_a_reference_given_to_the_constructor_opens_with_nothing_to_undo(clip):
    ed = WarpEditor(clip, clip)
    assert [op["op"] for op in ed.session.ops] == ["guided_warp"]
    assert not ed.session.can_undo and not ed.session.can_redo
    opened = ed.session.ops
    ed.model.duration = round(clip.duration * 0.8, 3)        # the user's first change is the first undo step
    assert ed.session.can_undo and ed.session.ops != opened
    assert ed.session.undo() and ed.session.ops == opened and not ed.session.can_undo


def test_a_given_session_keeps_its_history(clip):
    s = Session(clip, ops=[])
    s.add({"op": "resample", "frame_time": 1 / 60})
    ed = WarpEditor(s, clip)
    assert [op["op"] for op in s.ops] == ["resample", "guided_warp"] and s.can_undo
    ed.close()
