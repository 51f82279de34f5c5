"""Hostile and unusual input to the readers, the writer and the core (issue 13, items 1, 2, 6, 7, 8, 12):
each case reproduces a failure seen on the landed code, then checks the fix."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from io_samples import TINY, TINY_AMC, TINY_ASF

import stagger_nb as sn
from stagger_nb.core.kinematics import forward_kinematics, skeleton_height
from stagger_nb.core.motion import MIN_FRAME_TIME
from stagger_nb.core.rotations import quat_normalize
from stagger_nb.core.skeleton import Skeleton
from stagger_nb.io import MAX_INPUT_BYTES
from stagger_nb.io._common import read_regular_file
from stagger_nb.io.asfamc import AMCError, read_asf_amc
from stagger_nb.io.bvh import BVHError, format_bvh, parse_bvh

REPO = Path(__file__).resolve().parents[1]


def _line(text: str, needle: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), 1) if needle in line)


def _raises_within(limit: int, error, match: str, fn, *args) -> None:
    """``fn(*args)`` raises ``error`` matching ``match`` with at most ``limit`` bytes allocated (tracemalloc)."""
    tracemalloc.start()
    try:
        with pytest.raises(error, match=match):
            fn(*args)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < limit, peak


# ---------------------------------------------------------------- item 1: only regular files, bounded
def _in_child(code: str, timeout: float = 20.0) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter (so a blocking open cannot hang the test run)."""
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout, env=env)


@pytest.mark.parametrize("reader", ["bvh", "asf", "amc"])
def test_devices_are_refused_at_once(reader, tmp_path):
    asf = tmp_path / "t.asf"
    asf.write_text(TINY_ASF)
    # "not a regular file" is the refusal before any read (a read of /dev/zero would end in the size limit)
    if reader == "bvh":
        with pytest.raises(BVHError, match="/dev/zero.*not a regular file"):
            sn.read_bvh("/dev/zero")
    elif reader == "asf":
        with pytest.raises(AMCError, match="/dev/zero.*not a regular file"):
            read_asf_amc("/dev/zero", asf)
    else:
        with pytest.raises(AMCError, match="/dev/zero.*not a regular file"):
            read_asf_amc(asf, "/dev/zero")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "pipe.bvh"
    os.mkfifo(fifo)
    # a blocking open of a FIFO with no writer never returns: run in a child with a timeout
    r = _in_child(f"import stagger_nb as sn\ntry:\n    sn.read_bvh({str(fifo)!r})\nexcept sn.BVHError as e:\n"
                  f"    print('refused:', e)\n", timeout=30)
    assert r.returncode == 0, r.stderr
    assert "refused:" in r.stdout and "not a regular file" in r.stdout and str(fifo) in r.stdout


def test_directory_and_over_limit_file_are_refused(tmp_path):
    with pytest.raises(BVHError, match="not a regular file"):
        sn.read_bvh(tmp_path)
    big = tmp_path / "big.bvh"
    big.write_text(TINY)
    with pytest.raises(ValueError, match="over the 100-byte limit"):
        read_regular_file(big, what="clip", max_bytes=100)
    assert read_regular_file(big, max_bytes=len(TINY)) == TINY.encode()
    # the readers use the package limit: a sparse file one byte over it is refused before reading
    with open(big, "r+b") as f:
        f.truncate(MAX_INPUT_BYTES + 1)
    _raises_within(1 << 20, BVHError, "over the .*-byte limit", sn.read_bvh, big)


# ---------------------------------------------------------------- item 2: frame time bounds
@pytest.mark.parametrize("ft", ["1e-9", "1e-300", "0.00001", "5e-324"])
def test_tiny_frame_time_is_refused_by_the_reader(ft):
    text = TINY.replace("Frame Time: 0.5", f"Frame Time: {ft}")
    with pytest.raises(BVHError, match=r"clip\.bvh, line %d: .*frame time" % _line(text, "Frame Time")):
        parse_bvh(text, "clip.bvh")


def test_huge_frame_time_is_refused_by_the_reader():
    text = TINY.replace("Frame Time: 0.5", "Frame Time: 1e300")
    with pytest.raises(BVHError, match=r"line %d" % _line(text, "Frame Time")):
        parse_bvh(text, "clip.bvh")


def test_frame_time_bounds_at_the_motion_constructor():
    m = parse_bvh(TINY)
    for ft in (1e-9, 1e-300, MIN_FRAME_TIME / 2, 1e300):
        with pytest.raises(ValueError, match="frame_time"):
            m.replace(frame_time=ft)
    assert m.replace(frame_time=MIN_FRAME_TIME).frame_time == MIN_FRAME_TIME  # the bound itself is allowed
    with pytest.raises(ValueError, match="frame_time"):
        sn.Motion(m.skeleton, 1e-9, m.root_positions, m.local_quats)


# ---------------------------------------------------------------- item 6: size guards in core
@pytest.mark.parametrize("ft", [1e-9, 1e-6, MIN_FRAME_TIME / 10])
def test_resample_refuses_absurd_sizes_before_allocating(ft):
    _raises_within(1 << 20, ValueError, "frame_time", parse_bvh(TINY).resample, ft)


def test_resample_refuses_too_many_frames_with_a_remedy():
    m = sn.data.load("walk")
    with pytest.raises(ValueError, match=r"frame_time.*frames.*(slice|shorter)"):
        m.slice(0, 2).replace(frame_time=1000.0).resample(MIN_FRAME_TIME)
    assert m.resample(m.frame_time / 2).num_frames == 2 * m.num_frames - 1  # ordinary use unchanged


# ---------------------------------------------------------------- item 7: writer size, header memory, temp files
def _chain(depth: int) -> str:
    return ("HIERARCHY\nROOT j0\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
            + "".join(f"JOINT j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 0\n" for k in range(1, depth))
            + "}\n" * depth + "MOTION\nFrames: 1\nFrame Time: 0.1\n1 2 3\n")


def test_writer_output_grows_linearly_with_depth():
    small, large = (len(format_bvh(parse_bvh(_chain(d)))) for d in (500, 5000))
    # ten times the joints: ten times the text (a quadratic indentation gives ~100x)
    assert large < 12 * small


def test_junk_header_reports_its_line_with_small_memory():
    junk = "x " * (10 << 20)  # 20 MB of tokens on line 6
    text = TINY.replace("  JOINT Chest\n", "  JOINT Chest\n  {\n  " + junk + "\n", 1)
    raw = text.encode()
    # the header's text once; was ~45x the file (every token a tuple in a list)
    _raises_within(int(1.5 * len(raw)), BVHError, "line 8", parse_bvh, raw, "junk.bvh")


def test_junk_header_on_line_6():
    raw = ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\n" + "junk " * (4 << 20) + "\n}\nMOTION\n").encode()
    _raises_within(int(1.5 * len(raw)), BVHError, "line 6", parse_bvh, raw, "junk.bvh")


_KILL_CHILD = """
import sys, numpy as np
import stagger_nb as sn
m = sn.data.load("walk")
idx = np.arange(60000) % m.num_frames
m = m.replace(local_quats=m.local_quats[idx], root_positions=m.root_positions[idx])
print("ready", flush=True)
while True:
    sn.write_bvh(m, sys.argv[1])
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="O_TMPFILE is Linux-only")
def test_killed_write_leaves_no_hidden_temporary(tmp_path):
    out = tmp_path / "out.bvh"
    out.write_text("old")
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    for delay in (0.05, 0.2, 0.45):
        p = subprocess.Popen([sys.executable, "-c", _KILL_CHILD, str(out)], stdout=subprocess.PIPE, env=env)
        try:
            assert p.stdout.readline().strip() == b"ready"
            time.sleep(delay)
        finally:
            p.send_signal(signal.SIGKILL)
            p.wait(timeout=30)
        names = sorted(q.name for q in tmp_path.iterdir())
        assert names == ["out.bvh"], names
        body = out.read_bytes()
        assert body == b"old" or sn.read_bvh(out).num_frames == 60000  # old or complete new, never half


def test_write_fsyncs_data_then_folder(tmp_path, monkeypatch):
    calls = []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(os, "fsync", lambda fd: (calls.append(("fsync", os.path.isdir(f"/proc/self/fd/{fd}")
                                                                  if os.path.exists("/proc/self/fd") else None)),
                                                 real_fsync(fd))[1])
    monkeypatch.setattr(os, "replace",
                        lambda a, b, **kw: (calls.append(("replace", None)), real_replace(a, b, **kw))[1])
    sn.write_bvh(parse_bvh(TINY), tmp_path / "a.bvh")
    kinds = [c[0] for c in calls]
    assert kinds.index("fsync") < kinds.index("replace") < len(kinds) - 1 - kinds[::-1].index("fsync")
    if calls[0][1] is not None:
        assert calls[0] == ("fsync", False) and calls[-1] == ("fsync", True)  # the file, then the folder
    assert sn.read_bvh(tmp_path / "a.bvh").num_frames == 2


# ---------------------------------------------------------------- item 8: edits on joints with < 3 rotation channels
_PARTIAL = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Knee
  {
    OFFSET 0 -10 0
    CHANNELS 1 Xrotation
    JOINT Foot
    {
      OFFSET 0 -10 0
      CHANNELS 0
      End Site
      {
        OFFSET 0 0 5
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.1
0 20 0 0 0 0 10
0 20 0 0 0 0 20
0 20 0 0 0 0 30
"""


@settings(max_examples=20, deadline=None)
@given(st.floats(5, 170) | st.floats(-170, -5), st.floats(-170, 170), st.sampled_from(["Knee", "Foot"]))
def test_edit_on_a_joint_with_fewer_rotation_channels_is_written_faithfully(tmp_path_factory, az, ay, joint):
    m = parse_bvh(_PARTIAL)
    j = m.skeleton.index(joint)
    q = np.array(m.local_quats)
    edit = np.array([0, np.sin(np.radians(ay) / 2), 0, np.cos(np.radians(ay) / 2)])
    edit2 = np.array([0, 0, np.sin(np.radians(az) / 2), np.cos(np.radians(az) / 2)])
    from stagger_nb.core.rotations import quat_mul
    q[:, j] = quat_mul(quat_mul(q[:, j], edit), edit2)
    edited = m.replace(local_quats=q)
    out = tmp_path_factory.mktemp("x") / "edited.bvh"
    with pytest.warns(UserWarning, match=joint):
        sn.write_bvh(edited, out)
    back = sn.read_bvh(out)
    assert back.skeleton.names == m.skeleton.names
    assert len([c for c in back.skeleton.channels[j] if c.endswith("rotation")]) == 3
    p1, _ = forward_kinematics(edited)
    p2, _ = forward_kinematics(back)
    assert np.max(np.abs(p1 - p2)) <= 1e-5 * skeleton_height(m)
    # the end site too (it is what a rotation of the last joint moves)
    from stagger_nb.core.rotations import quat_angle
    assert np.max(quat_angle(edited.local_quats, back.local_quats)) < 1e-6


def test_unedited_partial_joints_are_written_as_they_are(tmp_path):
    m = parse_bvh(_PARTIAL)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sn.write_bvh(m, tmp_path / "same.bvh")
    assert sn.read_bvh(tmp_path / "same.bvh").skeleton.channels == m.skeleton.channels


def test_animated_translation_without_position_channels_is_written_faithfully(tmp_path):
    m = parse_bvh(_PARTIAL)
    t = m.translations()
    t[:, 1, 0] += np.array([0.0, 1.0, 2.0])  # the knee slides along x
    edited = m.replace(local_translations=t)
    with pytest.warns(UserWarning, match="Knee"):
        sn.write_bvh(edited, tmp_path / "t.bvh")
    back = sn.read_bvh(tmp_path / "t.bvh")
    np.testing.assert_allclose(forward_kinematics(back)[0], forward_kinematics(edited)[0],
                               atol=1e-5 * skeleton_height(m))


# ---------------------------------------------------------------- item 12: odd numbers, BOM, names, huge quaternions
@pytest.mark.parametrize("frame_no", ["\u00b9", "\u0661", "\uff11", "1_0"])
def test_amc_odd_frame_numbers_name_file_and_line(tmp_path, frame_no):
    amc = TINY_AMC.replace("\n1\n", f"\n{frame_no}\n", 1)
    (tmp_path / "t.asf").write_text(TINY_ASF)
    (tmp_path / "t.amc").write_text(amc, encoding="utf-8")
    with pytest.raises(AMCError, match=r"t\.amc, line %d" % _line(amc, frame_no)):
        read_asf_amc(tmp_path / "t.asf", tmp_path / "t.amc")


@pytest.mark.parametrize("number", ["1_000", "\u0661\u0662", "\uff11\uff12", "\u00b2"])
def test_non_ascii_or_underscored_numbers_are_refused(tmp_path, number):
    amc = TINY_AMC.replace("a 90", f"a {number}")
    (tmp_path / "t.asf").write_text(TINY_ASF)
    (tmp_path / "t.amc").write_text(amc, encoding="utf-8")
    with pytest.raises(AMCError, match=r"line %d: expected a number" % _line(amc, f"a {number}")):
        read_asf_amc(tmp_path / "t.asf", tmp_path / "t.amc")
    asf = TINY_ASF.replace("length 2", f"length {number}")
    (tmp_path / "t.asf").write_text(asf, encoding="utf-8")
    with pytest.raises(AMCError, match=r"line %d: expected a number" % _line(asf, f"length {number}")):
        read_asf_amc(tmp_path / "t.asf", tmp_path / "t.amc")
    for old in ("OFFSET 0 10 0", "Frame Time: 0.5", "Frames: 2", "1 2 3 90"):
        bvh = TINY.replace(old, old.replace(old.split()[-1], number))
        with pytest.raises(BVHError, match=r"line %d: expected" % _line(bvh, number)):
            parse_bvh(bvh.encode(), "clip.bvh")


def test_utf8_bom_is_accepted(tmp_path):
    (tmp_path / "b.bvh").write_bytes(b"\xef\xbb\xbf" + TINY.encode())
    a, b = parse_bvh(TINY), sn.read_bvh(tmp_path / "b.bvh")
    np.testing.assert_array_equal(a.local_quats, b.local_quats)
    (tmp_path / "t.asf").write_bytes(b"\xef\xbb\xbf" + TINY_ASF.encode())
    (tmp_path / "t.amc").write_bytes(b"\xef\xbb\xbf" + TINY_AMC.encode())
    assert read_asf_amc(tmp_path / "t.asf", tmp_path / "t.amc").num_frames == 2


def test_second_end_site_is_refused():
    text = TINY.replace("      OFFSET 0 5 0\n    }\n", "      OFFSET 0 5 0\n    }\n    End Site\n    {\n"
                                                       "      OFFSET 1 1 1\n    }\n", 1)
    with pytest.raises(BVHError, match=r"line %d: .*second 'End Site'.*Chest" % (_line(text, "OFFSET 1 1 1") - 2)):
        parse_bvh(text, "clip.bvh")


def test_duplicate_joint_names_are_refused():
    text = TINY.replace("JOINT Leg", "JOINT Chest")
    first, second = [i for i, ln in enumerate(text.splitlines(), 1) if "JOINT Chest" in ln]
    with pytest.raises(BVHError, match=r"line %d: .*'Chest'.*line %d" % (second, first)):
        parse_bvh(text, "clip.bvh")
    m = parse_bvh(TINY)
    with pytest.raises(ValueError, match="names.*Chest"):
        Skeleton(["Hips", "Chest", "Chest"], m.skeleton.parents, m.skeleton.offsets)


@pytest.mark.parametrize("name", ["Left\nArm", "Left\tArm", "Left  Arm", " Left", "", "a {", "}", "a\x00b"])
def test_joint_names_the_format_cannot_hold_are_refused_at_write(tmp_path, name):
    m = parse_bvh(TINY)
    names = list(m.skeleton.names)
    names[1] = name
    s = m.skeleton
    bad = m.replace(skeleton=Skeleton(names, s.parents, s.offsets, s.channels, s.end_sites))
    out = tmp_path / "n.bvh"
    with pytest.raises(ValueError, match=r"joint 1 .*name"):
        sn.write_bvh(bad, out)
    assert not out.exists()


def test_names_with_single_spaces_and_colons_round_trip(tmp_path):
    m = parse_bvh(TINY)
    s = m.skeleton
    names = ["mixamorig:Hips", "Left Arm", "x"]
    m = m.replace(skeleton=Skeleton(names, s.parents, s.offsets, s.channels, s.end_sites))
    sn.write_bvh(m, tmp_path / "n.bvh")
    assert sn.read_bvh(tmp_path / "n.bvh").skeleton.names == tuple(names)


@pytest.mark.parametrize("scale", [1e154, 1e200, 1e300, 1e-160, 1e-300])
def test_huge_and_tiny_quaternions_normalise(scale):
    q = np.array([0.1, 0.2, 0.3, 0.9]) * scale
    expect = np.array([0.1, 0.2, 0.3, 0.9]) / np.linalg.norm([0.1, 0.2, 0.3, 0.9])
    np.testing.assert_allclose(quat_normalize(q), expect, rtol=1e-14)
    m = parse_bvh(TINY)
    lq = np.array(m.local_quats)
    lq[0, 1] = q
    np.testing.assert_allclose(m.replace(local_quats=lq).local_quats[0, 1], expect, rtol=1e-14)
    np.testing.assert_array_equal(quat_normalize(np.zeros(4)), [0, 0, 0, 1])  # zero stays the identity


@pytest.mark.parametrize("unnamed", [True, False])
def test_atomic_write_both_ways_leaves_old_or_new(tmp_path, monkeypatch, unnamed):
    """With unnamed files (O_TMPFILE) and without (a named hidden temporary): a failed rename keeps the old
    file and leaves no temporary; a good write replaces the file and keeps its mode."""
    from stagger_nb.io import _output
    monkeypatch.setattr(_output, "_UNNAMED_OK", unnamed)
    out = tmp_path / "x.bvh"
    out.write_text("previous")
    os.chmod(out, 0o640)
    real_replace = os.replace

    def boom(src, dst, **dir_fds):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError, match="disk full"):
        sn.write_bvh(parse_bvh(TINY), out)
    assert out.read_text() == "previous" and [q.name for q in tmp_path.iterdir()] == ["x.bvh"]
    monkeypatch.setattr(os, "replace", real_replace)
    sn.write_bvh(parse_bvh(TINY), out)
    assert sn.read_bvh(out).num_frames == 2 and [q.name for q in tmp_path.iterdir()] == ["x.bvh"]
    assert out.stat().st_mode & 0o777 == 0o640


def test_many_frames_of_many_channel_less_joints_refused_before_allocating():
    """10,000 joints without channels cost no text but 32 bytes a frame each: the header is refused."""
    J = 5000
    text = ("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 1 Xrotation\n"
            + "".join(f"JOINT j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 0\n" for k in range(1, J))
            + "}\n" * J + "MOTION\nFrames: 100000\nFrame Time: 0.01\n" + "0\n" * 100000)
    _raises_within(64 << 20, BVHError, r"line %d: declared 100000 frames x 5000 joints" % _line(text, "Frames:"),
                   parse_bvh, text.encode(), "wide.bvh")
    asf = TINY_ASF.replace(":hierarchy", "".join(f"  begin\n     name x{k}\n     direction 0 1 0\n     length 1\n"
                                                   f"  end\n" for k in range(2000)) + ":hierarchy")
    asf = asf.replace("    a b\n", "    a b " + " ".join(f"x{k}" for k in range(2000)) + "\n")
    amc = ":DEGREES\n" + "".join(f"{f}\nroot 0 0 0 0 0 0\na 0\nb 0\n" for f in range(1, 6001))
    from stagger_nb.io.asfamc import parse_amc, parse_asf
    skel = parse_asf(asf)
    with pytest.raises(AMCError, match=r"line \d+: more than \d+ frames of 2003 joints"):
        parse_amc(amc, skel, "wide.amc")


@pytest.mark.parametrize("body", [b"0 0 0\n" + b"\n" * (8 << 20) + b"0 0 0\n",  # 8 M blank lines
                                  b"0 " * (8 << 20) + b"\n0 0 0\n"])  # one line of 8 M values
def test_hostile_motion_blocks_cost_no_more_than_the_file(body):
    head = b"HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n}\nMOTION\n"
    raw = head + b"Frames: 2\nFrame Time: 0.1\n" + body
    _raises_within(len(raw) // 2, BVHError, r"line 11: expected 3 values on frame 1, found 0|line 10: expected 3 "
                   r"values on frame 0, found more than 3", parse_bvh, raw, "hostile.bvh")


@pytest.mark.parametrize("junk", ["\n" * (1 << 16), "root " + "0 " * (4 << 20) + "\n"])
def test_hostile_amc_costs_little_memory(tmp_path, junk):
    """Millions of empty lines (once a list of lines) or a line of millions of values (once a list of tokens)."""
    amc = TINY_AMC.replace("root 1 2 3 0 0 0\n", "root 1 2 3 0 0 0\n" + junk if junk[0] == "\n" else junk)
    from stagger_nb.io.asfamc import parse_amc, parse_asf
    skel = parse_asf(TINY_ASF)
    match = "frame 1 has no line|expected 6 values for 'root', found more than 6"
    if junk[0] == "\n":  # the blank lines are skipped: the motion is read
        tracemalloc.start()
        parse_amc(amc, skel, "t.amc")
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < len(amc)  # a list of the lines alone would be 8 bytes a line, 8x the file
    else:
        _raises_within(len(amc), AMCError, match, parse_amc, amc, skel, "t.amc")
