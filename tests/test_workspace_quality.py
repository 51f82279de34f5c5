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
