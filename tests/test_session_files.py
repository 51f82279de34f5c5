"""session.files: save never replaces a non-session file; every path a session names is a regular file within
the size limit (devices and FIFOs refused at once); hostile session JSON is a ValueError naming the field."""
from __future__ import annotations

import json
import os
import threading

import pytest
from helpers import assert_load_names_the_field, assert_refuses_the_source

import stagger_nb as sn
from stagger_nb.session import Session
from stagger_nb.session.files import motion_from_json, motion_to_json


@pytest.fixture(scope="module")
def clip():
    return sn.data.load("walk").slice(0, 40)


@pytest.fixture
def src(tmp_path, clip):
    p = tmp_path / "src.bvh"
    sn.write_bvh(clip, p)
    return p


def _ops(m):
    return [{"op": "edit_frame", "frame": 2, "deltas": {m.skeleton.names[3]: [5.0, 0.0, 0.0]}}]


def test_save_refuses_the_source_and_non_session_files(tmp_path, src, clip):
    s = Session.from_bvh(src, ops=_ops(clip))
    before = src.read_bytes()
    assert_refuses_the_source(s.save, src, tmp_path)
    other = tmp_path / "notes.txt"
    other.write_text("my notes")
    with pytest.raises(ValueError, match="^path: .*not a stagger_nb session file"):
        s.save(other)
    not_ours = tmp_path / "x.json"
    not_ours.write_text(json.dumps({"format": "something else"}))
    with pytest.raises(ValueError, match="^path: .*not a stagger_nb session file"):
        s.save(not_ours)
    assert src.read_bytes() == before and other.read_text() == "my notes"
    # a session file may be replaced by a session, and a new path written
    p = tmp_path / "s.json"
    s.save(p)
    s.add({"op": "resample", "frame_time": 1 / 30})
    s.save(p)
    assert Session.load(p).ops == s.ops


def test_from_bvh_then_save_on_its_path_keeps_the_bvh(src, clip):
    before = src.read_bytes()
    with pytest.raises(ValueError):
        Session.from_bvh(src).save(src)  # issue 13 item 4
    assert src.read_bytes() == before


def _fifo(tmp_path):
    p = tmp_path / "fifo"
    os.mkfifo(p)
    return p


def _no_block(fn, timeout=10.0):
    """Run fn in a thread; fail if it blocks (a FIFO opened for reading without a writer would)."""
    out = {}

    def run():
        try:
            fn()
        except BaseException as e:
            out["e"] = e

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(timeout)
    assert not t.is_alive(), "blocked"
    return out.get("e")


@pytest.mark.parametrize("kind", ["dev_zero", "fifo", "folder"])
def test_reference_paths_must_be_regular_files(tmp_path, clip, kind):
    path = {"dev_zero": lambda: "/dev/zero", "fifo": lambda: str(_fifo(tmp_path)),
            "folder": lambda: str(tmp_path)}[kind]()
    s = Session(clip, [{"op": "guided_warp", "duration": 0.5, "reference": {"path": path}}])
    e = _no_block(s.edited)
    assert isinstance(e, ValueError) and str(e).startswith("ops[0] (guided_warp): reference.path:"), e
    assert "regular file" in str(e)


@pytest.mark.parametrize("kind", ["dev_zero", "fifo"])
def test_session_and_source_paths_must_be_regular_files(tmp_path, clip, kind):
    path = "/dev/zero" if kind == "dev_zero" else str(_fifo(tmp_path))
    e = _no_block(lambda: Session.load(path))
    assert isinstance(e, ValueError) and str(e).startswith("session:"), e
    data = Session(clip).to_json()
    data["source"] = {"path": path}
    e = _no_block(lambda: Session.from_json(data))
    assert isinstance(e, ValueError) and str(e).startswith("source.path:"), e
    e = _no_block(lambda: Session.from_bvh(path))
    assert isinstance(e, ValueError), e


@pytest.mark.parametrize("mutate, field", [
    (lambda d: d.update(extract_options={"iterations": 1e9}), r"extract_options\.iterations"),
    (lambda d: d.update(extract_options={"filter_width": 1e9}), r"extract_options\.filter_width"),
    (lambda d: d["ops"].append({"op": "cull", "keep": "all"}), r"ops\[1\]\.keep"),
    (lambda d: d["ops"].append({"op": "ik_pose", "pose": 1, "joint": "LeftHand", "target": "up"}),
     r"ops\[1\]\.target"),
    (lambda d: d["ops"].append({"op": "guided_warp", "duration": 1, "reference": {"path": 3}}),
     r"ops\[1\]\.reference\.path"),
    (lambda d: d["source"]["motion"].update(parents=[-1] + [-7] * 30), r"source\.motion\.parents\[1\]"),
])
def test_hostile_session_json_names_the_field(tmp_path, clip, mutate, field):
    p = tmp_path / "s.json"
    Session(clip, _ops(clip)).save(p)
    assert_load_names_the_field(p, mutate, field)


def test_embedded_motion_round_trip_is_exact(clip):
    back = motion_from_json(json.loads(json.dumps(motion_to_json(clip))), "m")
    assert (back.local_quats == clip.local_quats).all() and (back.root_positions == clip.root_positions).all()
    assert back.skeleton.names == clip.skeleton.names
