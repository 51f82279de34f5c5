"""export_html without a browser: one self-contained file (no http(s) script sources, the libraries inlined, the
motion embedded and decodable back to the tracks), written atomically, never over the source clip or a
non-HTML file. The browser side (it plays offline) is in tests/test_browser_view3d.py."""
from __future__ import annotations

import base64
import json
import re
from html.parser import HTMLParser

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import scene3d
from stagger_nb.session import Session
from stagger_nb.widgets import export_html


class _Scripts(HTMLParser):
    def __init__(self):
        super().__init__()
        self.scripts, self._cur = [], None

    def handle_starttag(self, tag, attrs):
        if tag == "script":
            self._cur = [dict(attrs), ""]
        for k, v in attrs:
            if k in ("src", "href") and v and re.match(r"(https?:)?//", v):
                raise AssertionError(f"external {k}: {v}")

    def handle_data(self, data):
        if self._cur is not None:
            self._cur[1] += data

    def handle_endtag(self, tag):
        if tag == "script" and self._cur is not None:
            self.scripts.append(tuple(self._cur))
            self._cur = None


def _parse(path):
    p = _Scripts()
    p.feed(path.read_text(encoding="utf-8"))
    return p.scripts


def _f32(b64):
    return np.frombuffer(base64.b64decode(b64), dtype="<f4")


def test_motion_page_is_self_contained_and_embeds_the_tracks(tmp_path):
    m = sn.data.load("run")
    out = export_html(m, tmp_path / "run.html")
    scripts = _parse(out)
    assert all("src" not in attrs for attrs, _ in scripts)               # every script inline
    code = "".join(body for attrs, body in scripts if not attrs.get("type"))
    assert 'REVISION="97"' in code                                          # three.js from pythreejs
    assert "plotly.js v" in code or "Plotly" in code                        # plotly.js from plotly
    data = json.loads(next(body for attrs, body in scripts if attrs.get("id") == "sn-data"))
    tr = scene3d.motion_tracks(m)
    np.testing.assert_array_equal(_f32(data["motion"]["times"]), tr.times)
    np.testing.assert_array_equal(_f32(data["motion"]["root_position"]).reshape(-1, 3), tr.root_position)
    assert set(data["motion"]["quats"]) == {str(j) for j in tr.quats}
    for j, q in tr.quats.items():
        np.testing.assert_array_equal(_f32(data["motion"]["quats"][str(j)]).reshape(-1, 4), q)
    assert data["ghost"] is None and data["num_frames"] == m.num_frames
    assert not list(tmp_path.glob(".tmp-*"))                                # atomic: no temporary left


def test_session_page_has_the_edit_and_the_original(tmp_path):
    m = sn.data.load("walk")
    s = Session(m, ops=[{"op": "linear_warp", "duration": 4.0}])
    out = export_html(s, tmp_path / "walk.html")
    data = json.loads(next(b for a, b in _parse(out) if a.get("id") == "sn-data"))
    edited = s.edited()
    assert data["num_frames"] == edited.num_frames != m.num_frames
    assert len(_f32(data["ghost"]["times"])) == m.num_frames
    np.testing.assert_array_equal(_f32(data["motion"]["root_position"]).reshape(-1, 3),
                                  edited.root_positions.astype(np.float32))


def test_editor_page_draws_its_figures(tmp_path):
    from stagger_nb.widgets import StaggerEditor
    e = StaggerEditor(sn.data.load("run"), precompute=False)
    try:
        out = export_html(e, tmp_path / "editor.html")
        figs = json.loads(next(b for a, b in _parse(out) if a.get("id") == "sn-figures"))
        expected = e.figures() if hasattr(e, "figures") else [p.figure for p in e.plots]
        assert len(figs) == len(expected) > 0
        assert [len(f["data"]) for f in figs] == [len(f["data"]) for f in expected]
    finally:
        e.close()


def test_refuses_the_source_clip_and_non_html_files(tmp_path):
    src = tmp_path / "clip.bvh"
    m = sn.data.load("run")
    sn.write_bvh(m, src)
    before = src.read_bytes()
    s = Session(sn.read_bvh(src), source_path=src)
    with pytest.raises(ValueError, match="^path: .*source clip"):
        export_html(s, src)
    other = tmp_path / "notes.txt"
    other.write_text("keep me")
    with pytest.raises(ValueError, match="^path: .*not an HTML file"):
        export_html(m, other)
    assert src.read_bytes() == before and other.read_text() == "keep me"
    page = export_html(m, tmp_path / "again.html")
    export_html(m, page)                       # an earlier export may be replaced
    with pytest.raises(ValueError, match="^obj"):
        export_html(42, tmp_path / "x.html")


def test_cmu_01_01_page_size(tmp_path):
    m = sn.data.load("cmu_01_01")
    size = export_html(m, tmp_path / "cmu.html").stat().st_size
    tracks = scene3d.motion_tracks(m).nbytes
    print(f"\nexport_html(CMU 01_01 Motion): {size:,} bytes (tracks {tracks:,} bytes as float32)")
    # the scripts (plotly.js ~4.6 MB, three.js ~0.55 MB) plus the tracks in base64 (4/3) and small change
    assert 4 / 3 * tracks < size < 4 / 3 * tracks + 6.5e6
