"""session.history: the op list with undo/redo and observers."""
from __future__ import annotations

from stagger_nb.session.history import Flag, History


def test_commit_undo_redo_and_observers():
    seen = []
    h = History((), owner="me")
    h.observe(lambda owner: seen.append((owner, h.ops)))
    assert h.commit(("a",)) and h.commit(("a", "b"))
    assert not h.commit(("a", "b"))            # equal: no step, no notification
    assert h.undo() and h.ops == ("a",)
    assert h.redo() and h.ops == ("a", "b")
    assert h.undo() and h.commit(("c",))       # a new change drops the redo branch
    assert not h.can_redo and not h.redo()
    assert seen == [("me", ("a",)), ("me", ("a", "b")), ("me", ("a",)), ("me", ("a", "b")), ("me", ("a",)),
                    ("me", ("c",))]
    while h.undo():
        pass
    assert h.ops == () and not h.can_undo


def test_flag_is_a_bool_and_a_method():
    t, f = Flag(True), Flag(False)
    assert t and not f and t() is True and f() is False
    assert t == True and f == False  # noqa: E712 (the comparison is what is tested)
