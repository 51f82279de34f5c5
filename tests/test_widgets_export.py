"""export_html without a browser: one self-contained file (no http(s) script sources, the libraries inlined, the
motion embedded and decodable back to the tracks), written atomically, never over the source clip or a
non-HTML file. The browser side (it plays offline) is in tests/test_browser_view3d.py."""
from __future__ import annotations

import re
from html.parser import HTMLParser

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb import scene3d
from stagger_nb.session import Session
from stagger_nb.widgets import export_html
from stagger_nb.widgets.export import read_export


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


def _points_close(decoded, motion, entry):
    """Decoded points equal the view's points to half a quantisation step (and float rounding)."""
    want = scene3d.skeleton_points(motion).astype(float)
    assert decoded.shape == want.shape
    err = np.abs(decoded - want).max()
    # half a step, plus the float64 -> float32 rounding of the reference points
    assert err <= entry["step"] / 2 + 1e-6 * np.abs(want).max(), (err, entry["step"])
    return err


def test_motion_page_is_self_contained_and_embeds_the_points(tmp_path):
    m = sn.data.load("run")
    out = export_html(m, tmp_path / "run.html")
    scripts = _parse(out)
    assert all("src" not in attrs for attrs, _ in scripts)               # every script inline
    blocks = {attrs["id"]: body for attrs, body in scripts if attrs.get("type") == "application/octet-stream"}
    assert set(blocks) == {"sn-lib-three", "sn-lib-plotly", "sn-data"}
    assert all(re.fullmatch(r"[A-Za-z0-9+/=]+", b) for b in blocks.values())   # base64 only: nothing to escape
    page = read_export(out)
    assert b'REVISION="97"' in page["libraries"]["sn-lib-three"]            # three.js from pythreejs
    assert b"plotly.js v" in page["libraries"]["sn-lib-plotly"][:2000]      # plotly.js from plotly
    h, arr = page["header"], page["arrays"]
    assert h["num_frames"] == m.num_frames and not h["has_ghost"] and h["names"] == list(m.skeleton.names)
    _points_close(arr["points"], m, h["arrays"]["points"])
    assert h["arrays"]["points"]["step"] == pytest.approx(scene3d.body_size(scene3d.world_positions(m)) / 4000)
    code = "".join(body for attrs, body in scripts if not attrs.get("type"))
    assert "snMeshVertices" in code and "DecompressionStream" in code      # the live view's mesh builder
    assert not list(tmp_path.glob(".tmp-*"))                                # atomic: no temporary left


def test_session_page_has_the_edit_and_the_original(tmp_path):
    m = sn.data.load("walk")
    s = Session(m, ops=[{"op": "linear_warp", "duration": 4.0}])
    page = read_export(export_html(s, tmp_path / "walk.html"))
    edited = s.edited()
    h, arr = page["header"], page["arrays"]
    assert h["num_frames"] == edited.num_frames != m.num_frames and h["has_ghost"]
    _points_close(arr["points"], edited, h["arrays"]["points"])
    _points_close(arr["ghost"], m, h["arrays"]["ghost"])


def test_a_long_walk_keeps_sixteen_bits_by_a_coarser_step(tmp_path):
    """Travel far beyond 4000 body steps: the step grows to span the extent, the error stays half a step."""
    m = sn.data.load("walk")
    far = m.replace(root_positions=m.root_positions + np.outer(np.arange(m.num_frames), [60.0, 0.0, 0.0]))
    page = read_export(export_html(far, tmp_path / "far.html"))
    e = page["header"]["arrays"]["points"]
    extent = np.ptp(scene3d.skeleton_points(far).reshape(-1, 3), axis=0).max()
    assert e["step"] == pytest.approx(extent / 65535) and e["step"] > scene3d.body_size(
        scene3d.world_positions(far)) / 4000
    _points_close(page["arrays"]["points"], far, e)


def test_editor_page_draws_its_figures(tmp_path):
    from stagger_nb.widgets import StaggerEditor
    e = StaggerEditor(sn.data.load("run"), precompute=False)
    try:
        page = read_export(export_html(e, tmp_path / "editor.html"))
        figs, expected = page["header"]["figures"], e.figures()
        assert len(figs) == len(expected) > 0
        assert [len(f["data"]) for f in figs] == [len(f["data"]) for f in expected]
        for f, want in zip(figs, expected):
            assert f["layout"]["title"]["text"] == want["layout"]["title"]["text"]
            for t, w in zip(f["data"], want["data"]):
                for k in ("x", "y"):
                    ref = t.get(k)
                    if isinstance(ref, dict):                  # an array, stored once in the pack (float32)
                        np.testing.assert_array_equal(page["arrays"][ref["__sn__"]],
                                                      np.asarray(w[k], dtype=np.float32))
        shared = {t["x"]["__sn__"] for t in figs[0]["data"][:6]}
        assert len(shared) == 1                                # the six curves share one time axis
    finally:
        e.close()


def test_a_hostile_joint_name_and_title_cannot_break_the_page(tmp_path):
    """``<!--<script>`` is a legal BVH joint name: no joint name, title or label reaches the page's text."""
    m = sn.data.load("run")
    names = list(m.skeleton.names)
    names[3] = "<!--<script>"
    names[4] = "</script><b>x"
    sk = sn.Skeleton(tuple(names), m.skeleton.parents, m.skeleton.offsets, channels=m.skeleton.channels,
                     end_sites=m.skeleton.end_sites)
    hostile = m.replace(skeleton=sk)
    out = export_html(hostile, tmp_path / "hostile.html", title="</script><!-- a <script> title")
    text = out.read_text(encoding="utf-8")
    assert "<!--" not in text
    assert text.count("<script") == len(_parse(out)) == 5   # our five scripts, nothing else opens one
    assert read_export(out)["header"]["names"][3:5] == ["<!--<script>", "</script><b>x"]
    assert "&lt;/script&gt;&lt;!-- a &lt;script&gt; title" in text


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


def test_cmu_01_01_pages_are_at_most_3_mb(tmp_path):
    from stagger_nb.widgets import StaggerEditor
    m = sn.data.load("cmu_01_01")
    motion_size = export_html(m, tmp_path / "cmu.html").stat().st_size
    e = StaggerEditor(m, precompute=False)
    try:
        e.model.s = 0.02
        size = export_html(e, tmp_path / "cmu_editor.html").stat().st_size
    finally:
        e.close()
    points = scene3d.skeleton_points(m).nbytes
    print(f"\nexport_html CMU 01_01: Motion {motion_size:,} bytes, StaggerEditor {size:,} bytes "
          f"(points {points:,} bytes as float32, twice with the original)")
    assert size <= 3_000_000 and motion_size < size
