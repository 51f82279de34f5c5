"""Malformed files raise one documented exception (BVHError / AMCError, both ValueError) naming the file,
the line and what was expected; random mutations of valid files give that exception or a valid Motion,
never an IndexError, a RecursionError or a hang, and absurd declared sizes allocate nothing."""
from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from io_samples import TINY, TINY_AMC, TINY_ASF, line_of

from stagger_nb.core.motion import Motion
from stagger_nb.io.asfamc import AMCError, asf_amc_to_motion, parse_amc, parse_asf
from stagger_nb.io.bvh import BVHError, parse_bvh

SRC = "clip.bvh"


BVH_CASES = [
    # (label, text, expected line (needle or int), fragment of the message)
    ("nan in data", TINY.replace("0 90 0 0", "0 nan 0 0"), "0 nan 0 0", "expected a number"),
    ("inf in data", TINY.replace("0 90 0 0", "0 1e999 0 0"), "0 1e999 0 0", "finite"),
    ("nan offset", TINY.replace("OFFSET 0 10 0", "OFFSET 0 nan 0"), "OFFSET 0 nan 0", "finite"),
    ("garbage number", TINY.replace("0 90 0 0", "0 9O 0 0"), "0 9O 0 0", "expected a number"),
    ("too few values", TINY.replace(" 0 0 0 0 0\n0 0 0", " 0 0 0 0\n0 0 0"), "1 2 3 90", "expected 15 values"),
    ("too many values", TINY.replace("0 90 0 0", "0 90 0 0 0"), "0 90 0 0", "expected 15 values"),
    ("unknown channel", TINY.replace("Zrotation Xrotation Yrotation\n    End",
                                     "Zrotation Wrotation Yrotation\n    End"), "Wrotation", "unknown channel"),
    ("repeated channel", TINY.replace("3 Zrotation Xrotation Yrotation", "3 Zrotation Zrotation Yrotation"),
     "Zrotation Zrotation", "repeated channel"),
    ("channel count", TINY.replace("CHANNELS 3", "CHANNELS 7"), "CHANNELS 7", "channel count"),
    ("missing brace", TINY.replace("  }\n  JOINT Leg", "  JOINT Leg"), "MOTION", "hierarchy ends early"),
    ("extra brace", TINY.replace("}\nMOTION", "}\n}\nMOTION"), 25, "expected 'MOTION'"),
    ("frames > data", TINY.replace("Frames: 2", "Frames: 3"), "0 0 0 0 0 0 0 90", "file ends early"),
    ("frames < data", TINY.replace("Frames: 2", "Frames: 1"), "0 0 0 0 0 0 0 90", "more frame lines"),
    ("zero frame time", TINY.replace("Frame Time: 0.5", "Frame Time: 0"), "Frame Time", "must be positive"),
    ("negative frame time", TINY.replace("Frame Time: 0.5", "Frame Time: -0.5"), "Frame Time", "positive"),
    ("bad frame time", TINY.replace("Frame Time: 0.5", "Frame Time: fast"), "Frame Time", "expected a number"),
    ("fractional frames", TINY.replace("Frames: 2", "Frames: 2.5"), "Frames:", "whole number"),
    ("absurd frames", TINY.replace("Frames: 2", "Frames: 10000000000"), "Frames:", "more than"),
    ("no motion", TINY[:TINY.index("MOTION")], 24, "no 'MOTION'"),
    ("no frames line", TINY[:TINY.index("Frames")], "MOTION", "expected 'Frames"),
    ("no frame time", TINY[:TINY.index("Frame Time")], "Frames:", "expected 'Frame Time"),
    ("truncated data", TINY[:TINY.rindex("0 0 0 0 0 0 0 90") + 5], 29, "expected 15 values"),
    ("no root", TINY.replace("ROOT Hips", "JOINT Hips"), "JOINT Hips", "expected 'ROOT'"),
    ("missing offset", TINY.replace("    OFFSET 0 10 0\n", ""), "CHANNELS 3", "expected 'OFFSET'"),
    ("unclosed end site", TINY.replace("      OFFSET 0 -8 0\n    }\n", "      OFFSET 0 -8 0\n"), "MOTION",
     "hierarchy ends early: expected 'JOINT', 'End Site' or '}'"),
    ("blank line in data", TINY.replace("0 0 0 0\n0 0 0 0 0 0 0 90", "0 0 0 0\n\n0 0 0 0 0 0 0 90"), 29,
     "expected 15 values"),
]


@pytest.mark.parametrize("label,text,where,what", BVH_CASES, ids=[c[0] for c in BVH_CASES])
def test_bvh_errors_name_file_line_and_expectation(label, text, where, what):
    with pytest.raises(BVHError) as ei:
        parse_bvh(text, SRC)
    err = ei.value
    assert isinstance(err, ValueError)
    msg = str(err)
    assert msg.startswith(f"{SRC}, line {err.line}: ") and what in msg, msg
    assert err.line == (where if isinstance(where, int) else line_of(text, where)), msg


def test_absurd_frame_count_allocates_nothing():
    # under the caps (frames, and frames x joints <= MAX_FRAME_JOINTS), but the data has 2 lines
    from stagger_nb.core.motion import MAX_FRAME_JOINTS
    text = TINY.replace("Frames: 2", f"Frames: {MAX_FRAME_JOINTS // 3}")  # TINY has 3 joints
    tracemalloc.start()
    try:
        with pytest.raises(BVHError, match="file ends early"):
            parse_bvh(text, SRC)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5_000_000  # 1.3e6 x 15 doubles would be 160 MB; parsing 2 lines needs kilobytes


def test_deep_hierarchy_is_not_a_recursion_error():
    depth = 5000  # deeper than Python's recursion limit
    head = "HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
    body = "".join(f"JOINT j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 0\n" for k in range(1, depth))
    text = head + body + "}\n" * depth + "MOTION\nFrames: 1\nFrame Time: 0.1\n1 2 3\n"
    m = parse_bvh(text)
    assert m.num_joints == depth and m.skeleton.parents[-1] == depth - 2
    with pytest.raises(BVHError, match="hierarchy ends early"):
        parse_bvh(head + body + "MOTION\nFrames: 1\nFrame Time: 0.1\n1 2 3\n")


def test_bvh_error_is_the_only_exception_on_a_directory(tmp_path):
    from stagger_nb.io.bvh import read_bvh
    with pytest.raises(BVHError, match="not a regular file"):
        read_bvh(tmp_path)


# ---------------------------------------------------------------- random mutations
def _mutate(text: str, data) -> str:
    """Apply 1-3 random edits: delete / duplicate / alter a line, truncate, swap tokens, insert garbage."""
    for _ in range(data.draw(st.integers(1, 3), label="edits")):
        lines = text.split("\n")
        kind = data.draw(st.sampled_from(["delete", "duplicate", "alter", "truncate", "swap", "garbage"]),
                         label="kind")
        i = data.draw(st.integers(0, len(lines) - 1), label="line")
        if kind == "delete":
            del lines[i]
        elif kind == "duplicate":
            lines.insert(i, lines[i])
        elif kind == "alter":
            toks = lines[i].split() or [""]
            k = data.draw(st.integers(0, len(toks) - 1), label="token")
            toks[k] = data.draw(st.sampled_from(["", "nan", "-inf", "1e400", "{", "}", "x", "-", ".", "1e",
                                                 "End", "JOINT", "CHANNELS", "0", "-1", "1e10", "99999999999",
                                                 "Zrotation", "Frames:", "1.5", "MOTION", "\t", "\r"]),
                                label="new")
            lines[i] = " ".join(toks)
        elif kind == "swap":
            toks = text.split(" ")
            a, b = data.draw(st.integers(0, len(toks) - 1)), data.draw(st.integers(0, len(toks) - 1))
            toks[a], toks[b] = toks[b], toks[a]
            text = " ".join(toks)
            continue
        elif kind == "truncate":
            text = text[:data.draw(st.integers(0, len(text)), label="cut")]
            continue
        else:
            pos = data.draw(st.integers(0, len(text)), label="at")
            junk = data.draw(st.text(alphabet=st.characters(codec="latin-1"), max_size=8), label="junk")
            text = text[:pos] + junk + text[pos:]
            continue
        text = "\n".join(lines)
    return text


def _check_motion(m: Motion):
    assert isinstance(m, Motion)
    F, J = m.num_frames, m.num_joints
    assert F >= 1 and m.local_quats.shape == (F, J, 4) and m.root_positions.shape == (F, 3)
    assert np.all(np.isfinite(m.local_quats)) and np.all(np.isfinite(m.root_positions))
    assert m.frame_time > 0


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_mutated_bvh_gives_bvh_error_or_a_valid_motion(data):
    text = _mutate(TINY, data)
    try:
        m = parse_bvh(text, SRC)
    except BVHError as e:
        assert str(e).startswith(SRC) and (e.line is None or e.line >= 1)
        return
    _check_motion(m)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_mutated_bvh_bytes_give_bvh_error_or_a_valid_motion(data):
    raw = bytearray(TINY.replace("\n", "\r\n").encode())
    for _ in range(data.draw(st.integers(1, 4))):
        pos = data.draw(st.integers(0, len(raw) - 1))
        raw[pos] = data.draw(st.integers(0, 255))
    try:
        m = parse_bvh(bytes(raw), SRC)
    except BVHError:
        return
    _check_motion(m)


@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data(), st.booleans())
def test_mutated_asf_amc_give_amc_error_or_a_valid_motion(data, mutate_asf):
    asf, amc = (_mutate(TINY_ASF, data), TINY_AMC) if mutate_asf else (TINY_ASF, _mutate(TINY_AMC, data))
    try:
        skel = parse_asf(asf, "t.asf")
        root, dofs = parse_amc(amc, skel, "t.amc")
        m = asf_amc_to_motion(skel, root, dofs, 1 / 120)
    except AMCError as e:
        assert str(e).startswith(("t.asf", "t.amc"))
        return
    _check_motion(m)
