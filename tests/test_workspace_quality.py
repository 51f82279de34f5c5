"""The StaggerEditor's quality line (issue 22): the session's one-line summary, each part red where it is out of
bounds, following edits and undo (outside a kernel the line is computed at once)."""
import re

from stagger_nb import data
from stagger_nb.widgets import StaggerEditor


def _parts(value: str) -> list:
    return re.findall(r'<span style="color:(#[0-9a-f]{6})">([^<]*)</span>', value)

def test_the_quality_line_is_the_sessions_summary_red_where_out_of_bounds_and_follows_undo():
    e = StaggerEditor(data.load("walk"), precompute=False)
    try:
        q = e.session.quality()
        assert " · ".join(t for _, t in _parts(e.quality.value)) == q.summary == e.model.quality["text"]
        assert q.ok and all(c == "#2f855a" for c, _ in _parts(e.quality.value))
        e.model.w_r = 2.0   # a strong exaggeration: out of the mild bounds
        q = e.session.quality()
        parts = _parts(e.quality.value)
        assert not q.ok and [t for _, t in parts] == [i.text for i in q.items]
        assert [c == "#c53030" for c, _ in parts] == [not i.ok for i in q.items] and any(not i.ok for i in q.items)
        e.session.undo()
        assert e.model.quality["ok"] and all(c == "#2f855a" for c, _ in _parts(e.quality.value))
    finally:
        e.close()


def test_sliding_feet_with_the_contact_layer_off_say_how_to_hold_them():
    """A timing edit that slides the feet while "keep foot contacts" is off (the default) gets the model's hint,
    shown in blue under the editor (a suggestion, not a refusal: the message stays empty); ticking it holds the
    feet and the hint goes."""
    from stagger_nb.session.models.binding import CONTACTS_HINT
    e = StaggerEditor(data.load("walk"), precompute=False)
    try:
        assert e.model.hint == "" and "sn-hint" not in e.message.value
        e.model.s = 0.095                  # the drag of the browser test: "right foot slides 68 cm"
        q = e.session.quality()
        assert any(not i.ok and i.figure.startswith("foot") for i in q.items), q.summary
        assert e.model.hint == CONTACTS_HINT and not e.model.message
        assert "sn-hint" in e.message.value and "keep foot contacts" in e.message.value
        e.model.keep_contacts = True
        assert not any(i.figure.startswith("foot") and not i.ok for i in e.session.quality().items)
        assert e.model.hint == "" and "sn-hint" not in e.message.value
    finally:
        e.close()
