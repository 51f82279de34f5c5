"""A corpus of hostile and odd inputs, generated here (nothing stored), and a runner that replays it.

Every *hostile* case must end in a ``ValueError`` (BVHError / AMCError / session errors included) whose
message names the file (and the line, for content errors) or the session field, within the time and memory
bounds, and must overwrite nothing. Every *odd but valid* case must read, and its exports re-read to the
edited motion within 1e-5 of the skeleton's height.

``python tests/hostile_corpus.py OUT_DIR`` runs every case in this process (tracemalloc peak and wall time
per case) and prints one JSON line per case; ``tests/test_hostile_corpus.py`` runs it in a child process
with an address-space limit and a timeout, and checks each line.
"""
from __future__ import annotations

import gzip
import json
import os
import re
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
from io_samples import ASF_ROOT, FEMUR_LIMITS, asf_bone, bvh_hierarchy

MAX_SECONDS = 10.0      # CPU seconds of one case (its cost, not how busy the machine is)
MAX_BYTES = 500 << 20

# --------------------------------------------------------------------------------------------------
# BVH material
# --------------------------------------------------------------------------------------------------
HEAD = bvh_hierarchy(("Hips", "0 0 0", [("Spine", "0 10 0", [("Head", "0 10 0", "0 5 0")])]))
ROWS = ["1 90 2 10 20 30 1 2 3 4 5 6", "1.5 91 2.5 11 21 31 2 3 4 5 6 7", "2 92 3 12 22 32 3 4 5 6 7 8"]


def bvh(head: str = HEAD, frames: str = "3", ft: str = "0.0333333", rows=ROWS, motion: str = "MOTION") -> str:
    return f"{head}{motion}\nFrames: {frames}\nFrame Time: {ft}\n" + "\n".join(rows) + "\n"


def _chain(depth: int, channels: str = "CHANNELS 3 Zrotation Xrotation Yrotation") -> tuple[str, int]:
    parts = ["HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
             "Yrotation\n"]
    for d in range(depth):
        parts.append(f"JOINT j{d}\n{{\nOFFSET 0 1 0\n{channels}\n")
    parts.append("End Site\n{\nOFFSET 0 1 0\n}\n" + "}\n" * (depth + 1))
    n = 6 + depth * (len(channels.split()) - 2)
    return "".join(parts), n


def _wide(joints: int) -> tuple[str, int]:
    parts = ["HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
             "Yrotation\n"]
    for d in range(joints):
        parts.append(f"JOINT j{d}\n{{\nOFFSET 1 0 0\nCHANNELS 6 Xposition Yposition Zposition Xrotation "
                     f"Yrotation Zrotation\n}}\n")
    parts.append("}\n")
    return "".join(parts), 6 + 6 * joints


def bvh_cases() -> list[tuple[str, bytes]]:
    """(name, file bytes) of hostile BVH files: each must raise BVHError naming the file and a line."""
    c: list[tuple[str, bytes]] = []
    add = lambda name, text: c.append((name, text.encode("utf-8") if isinstance(text, str) else text))  # noqa: E731
    # numbers
    for bad in ("nan", "NaN", "inf", "-inf", "Infinity", "1e999", "-1e400", "0x1f", "1,5", "1.2.3", "--1", "+-2",
                "1e", "e3", ".", "-", "1_0", "\u0661", "\uff11", "\u00b2", "1e5e5", "'1'", "\x00", "\x7f", "1\x0c2"):
        rows = list(ROWS)
        rows[1] = rows[1].replace("21", bad, 1)
        add(f"motion value {bad!r}", bvh(rows=rows))
    for bad in ("nan", "inf", "1e999", "abc", "\u0662"):
        add(f"OFFSET value {bad!r}", bvh(HEAD.replace("OFFSET 0 10 0", f"OFFSET 0 {bad} 0", 1)))
        add(f"End Site value {bad!r}", bvh(HEAD.replace("OFFSET 0 5 0", f"OFFSET {bad} 5 0")))
    # counts and header values
    for frames in ("0", "-1", "-3", "1.5", "3.0001", "1e3", "1e12", "99999999999999999999", "abc", "", "nan",
                   "inf", "0x3", "3 3", "4", "2", "1000000"):
        add(f"Frames: {frames!r}", bvh(frames=frames))
    for ft in ("0", "-0.01", "nan", "inf", "1e-9", "1e-300", "5e-324", "1e9", "", "abc", "0.03 0.03", "-0"):
        add(f"Frame Time: {ft!r}", bvh(ft=ft))
    add("Frames line missing", bvh().replace("Frames: 3\n", ""))
    add("Frame Time line missing", bvh().replace("Frame Time: 0.0333333\n", ""))
    add("Frame Time before Frames", bvh().replace("Frames: 3\nFrame Time: 0.0333333",
                                                   "Frame Time: 0.0333333\nFrames: 3"))
    add("Frames: without a value", bvh().replace("Frames: 3", "Frames:"))
    # structure
    add("MOTION before ROOT", "MOTION\nFrames: 1\nFrame Time: 0.1\n0 0 0\n" + HEAD)
    add("MOTION first, then HIERARCHY", "MOTION\n" + HEAD + "Frames: 3\nFrame Time: 0.1\n" + "\n".join(ROWS))
    add("no HIERARCHY keyword", bvh(HEAD.replace("HIERARCHY\n", "")))
    add("no MOTION section", HEAD)
    add("no ROOT", bvh(HEAD.replace("ROOT Hips", "JOINT Hips")))
    add("two roots", bvh(HEAD + "ROOT Other\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\n"))
    add("missing closing brace", bvh(HEAD.rstrip()[:-1]))
    add("extra closing brace", bvh(HEAD + "}\n"))
    add("missing opening brace", bvh(HEAD.replace("JOINT Spine\n\t{", "JOINT Spine")))
    add("End Site with CHANNELS", bvh(HEAD.replace("OFFSET 0 5 0", "OFFSET 0 5 0\nCHANNELS 3 Xrotation Yrotation "
                                                                   "Zrotation")))
    add("End Site without OFFSET", bvh(HEAD.replace("\t\t\t\tOFFSET 0 5 0\n", "")))
    add("End Site with children", bvh(HEAD.replace("OFFSET 0 5 0", "OFFSET 0 5 0\nJOINT x\n{\nOFFSET 0 0 0\n"
                                                                   "CHANNELS 0\n}")))
    add("two End Sites", bvh(HEAD.replace("\t\t\tEnd Site", "\t\t\tEnd Site\n{\nOFFSET 0 1 0\n}\n\t\t\tEnd Site")))
    add("OFFSET with 2 numbers", bvh(HEAD.replace("OFFSET 0 10 0", "OFFSET 0 10", 1)))
    add("OFFSET with 4 numbers", bvh(HEAD.replace("OFFSET 0 10 0", "OFFSET 0 10 0 0", 1)))
    add("OFFSET missing", bvh(HEAD.replace("\t\tOFFSET 0 10 0\n", "", 1)))
    add("CHANNELS missing", bvh(HEAD.replace("\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n", "", 1)))
    for n in ("7", "-1", "1e9", "3.5", "x", "99999999999999999999999"):
        add(f"CHANNELS {n}", bvh(HEAD.replace("CHANNELS 3", f"CHANNELS {n}", 1)))
    add("CHANNELS 3 with 2 names", bvh(HEAD.replace("CHANNELS 3 Zrotation Xrotation Yrotation",
                                                    "CHANNELS 3 Zrotation Xrotation", 1)))
    add("unknown channel Wrotation", bvh(HEAD.replace("Zrotation Xrotation Yrotation", "Wrotation Xrotation "
                                                                                         "Yrotation", 1)))
    add("channel 'rotation'", bvh(HEAD.replace("Zrotation Xrotation Yrotation", "rotation Xrotation Yrotation", 1)))
    add("repeated channel", bvh(HEAD.replace("Zrotation Xrotation Yrotation", "Zrotation Zrotation Yrotation", 1)))
    add("duplicate joint names", bvh(HEAD.replace("JOINT Head", "JOINT Spine")))
    add("joint name '{'", bvh(HEAD.replace("JOINT Head\n\t\t{", "JOINT\n\t\t{")))
    # the motion block
    add("truncated last line", bvh(rows=ROWS[:2] + ["2 92 3 12 22 32 3 4"]))
    add("truncated mid-number at EOF", bvh(rows=ROWS[:2] + ["2 92 3 12 22 32 3 4 5 6 7 8"])[:-3])
    add("extra value on a line", bvh(rows=ROWS[:2] + [ROWS[2] + " 9"]))
    add("fewer lines than Frames", bvh(rows=ROWS[:2]))
    add("more lines than Frames", bvh(rows=ROWS + ROWS[:1]))
    add("blank line inside the motion", bvh(rows=ROWS[:1] + [""] + ROWS[1:]))
    add("motion split across lines", bvh(rows=[ROWS[0], "1.5 91 2.5 11 21 31", "2 3 4 5 6 7", ROWS[2]]))
    add("NUL bytes in the motion", bvh(rows=[ROWS[0], ROWS[1].replace(" ", "\x00"), ROWS[2]]))
    add("lying Frames (huge, 2 lines)", bvh(frames="9000000", rows=ROWS[:2]))
    add("lying Frames (huge x joints)", bvh(_wide(2000)[0], frames="9000000", rows=["0"] * 2))
    add("a line of a million values", bvh(rows=[ROWS[0], " ".join(["1"] * 1_000_000), ROWS[2]]))
    add("a million blank lines", bvh(rows=[ROWS[0]] + [""] * 1_000_000 + ROWS[1:]))
    add("values that are absurdly long", bvh(rows=[ROWS[0], ROWS[1].replace("21", "2" * 100_000), ROWS[2]]))
    # a long take (27,510 frames x 31 joints, ~30 MB) broken at its very end: one piece of slow parsing
    head, n = _wide(30)
    line = " ".join(["-12.345678"] * n)
    long_rows = [line] * 27_509
    add("long take, truncated last line", bvh(head, frames="27510", rows=long_rows + [line[:-30]]))
    add("long take, NaN on its last line", bvh(head, frames="27510", rows=long_rows + [line.replace("-12.345678",
                                                                                                   "nan", 1)]))
    add("long take, one line missing", bvh(head, frames="27510", rows=long_rows))
    # sizes
    head, n = _chain(12_000)
    add("12,000-level chain (over the joint limit)", bvh(head, frames="1", rows=[" ".join(["0"] * n)]))
    head, n = _wide(11_000)
    add("11,000 joints x 6 channels (over the joint limit)", bvh(head, frames="1", rows=[" ".join(["0"] * n)]))
    # encodings and garbage
    add("empty file", b"")
    add("whitespace only", b" \n\t\r\n" * 1000)
    add("a single NUL", b"\x00")
    rng = np.random.default_rng(13)
    for k in range(4):
        add(f"binary garbage {k}", rng.integers(0, 256, 4096 * (k + 1), dtype=np.uint8).tobytes())
    add("binary garbage after MOTION", bvh().encode() + rng.integers(0, 256, 8192, dtype=np.uint8).tobytes())
    add("gzip of a valid file", gzip.compress(bvh().encode()))
    add("UTF-16 encoded file", bvh().encode("utf-16"))
    add("UTF-32 encoded file", bvh().encode("utf-32"))
    add("UTF-16 BOM + UTF-8 text", b"\xff\xfe" + bvh().encode())
    add("a JSON session instead of BVH", json.dumps({"format": "stagger_nb.session", "ops": []}))
    add("a PNG header", b"\x89PNG\r\n\x1a\n" + bytes(64))
    add("HTML", "<html><body>HIERARCHY</body></html>")
    return c


def bvh_odd_valid() -> list[tuple[str, bytes, dict]]:
    """(name, bytes, expectations) of odd files that are valid BVH: each must read (and export faithfully)."""
    c = []
    base = bvh()
    c.append(("CRLF line breaks", base.replace("\n", "\r\n").encode(), {}))
    c.append(("CR line breaks (classic Mac)", base.replace("\n", "\r").encode(), {}))
    c.append(("tabs between values", bvh(rows=[r.replace(" ", "\t") for r in ROWS]).encode(), {}))
    c.append(("runs of blanks and trailing spaces", bvh(rows=["  " + r.replace(" ", " \t ") + "   " for r in ROWS])
              .encode(), {}))
    c.append(("UTF-8 BOM", b"\xef\xbb\xbf" + base.encode(), {}))
    odd_case = HEAD.replace("Zrotation Xrotation Yrotation", "ZROTATION xRotation yrotation")
    c.append(("channel names in odd case", bvh(odd_case).encode(), {}))
    z_only = HEAD.replace("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 1 Zrotation")
    c.append(("Zrotation-only joints", bvh(z_only, rows=["1 90 2 10 20 30 5 6", "1 90 2 10 20 30 7 8",
                                                          "1 90 2 10 20 30 9 10"]).encode(), {"edit_z_only": True}))
    xy = HEAD.replace("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 2 Yrotation Xrotation")
    c.append(("two-rotation-channel joints", bvh(xy, rows=["1 90 2 10 20 30 5 6 1 2", "1 90 2 10 20 30 7 8 3 4",
                                                            "1 90 2 10 20 30 9 10 5 6"]).encode(), {}))
    no_end = HEAD.replace("\t\t\tEnd Site\n\t\t\t{\n\t\t\t\tOFFSET 0 5 0\n\t\t\t}\n", "")
    c.append(("missing End Site", bvh(no_end).encode(), {}))
    uni = HEAD.replace("Spine", "Rücken:脊椎").replace("Head", "Кепка Голова")
    c.append(("unicode names with spaces and colons", bvh(uni).encode(), {}))
    c.append(("Latin-1 names", bvh(HEAD.replace("Spine", "R\xfccken")).encode("latin-1"), {}))
    pos_all = HEAD.replace("CHANNELS 3 Zrotation", "CHANNELS 6 Xposition Yposition Zposition Zrotation")
    c.append(("position channels on every joint", bvh(pos_all, rows=[
        "1 90 2 10 20 30 0 10 0 1 2 3 0 10 0 4 5 6", "1 90 2 10 20 30 0 11 0 1 2 3 0 9 0 4 5 6",
        "1 90 2 10 20 30 0 12 0 1 2 3 0 8 0 4 5 6"]).encode(), {}))
    c.append(("rotation before position on the root", bvh(HEAD.replace(
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
        "CHANNELS 6 Zrotation Xrotation Yrotation Xposition Yposition Zposition")).encode(), {}))
    c.append(("channel-less joint", bvh(HEAD.replace("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 0", 1),
                                        rows=[" ".join(r.split()[:6] + r.split()[9:]) for r in ROWS]).encode(), {}))
    c.append(("one frame", bvh(frames="1", rows=ROWS[:1]).encode(), {}))
    c.append(("blank lines after the motion", (base + "\n\n  \n").encode(), {}))
    c.append(("no final line break", base.rstrip("\n").encode(), {}))
    c.append(("exponents and leading dots", bvh(rows=[r.replace("20", "2e1").replace("10", ".1e2") for r in ROWS])
              .encode(), {}))
    c.append(("angles beyond 360", bvh(rows=[r.replace("30", "1110").replace("20", "-740") for r in ROWS]).encode(),
              {}))
    head, n = _chain(1000)
    c.append(("1,000-level chain", bvh(head, frames="2", rows=[" ".join(["1"] * n)] * 2).encode(), {}))
    head, n = _wide(500)
    c.append(("500 joints x 6 channels", bvh(head, frames="2", rows=[" ".join(["1"] * n)] * 2).encode(), {}))
    return c


# --------------------------------------------------------------------------------------------------
# ASF / AMC material
# --------------------------------------------------------------------------------------------------
ASF = (":version 1.10\n:name test\n:units\n  mass 1.0\n  length 1.0\n  angle deg\n:documentation\n  hostile corpus\n"
       + ASF_ROOT + ":bonedata\n"
       + asf_bone(1, "lfemur", "0 -1 0", 10, "0 0 0 XYZ", "rx ry rz", FEMUR_LIMITS)
       + asf_bone(2, "ltibia", "0 -1 0", 10, "0 0 0 XYZ", "rx", ("(-10.0 170.0)",))
       + ":hierarchy\n  begin\n    root lfemur\n    lfemur ltibia\n  end\n")
AMC = ":FULLY-SPECIFIED\n:DEGREES\n" + "".join(f"{f}\nroot 0 {f} 0 1 2 3\nlfemur 10 20 30\nltibia {f * 5}\n"
                                               for f in range(1, 4))


def asf_amc_cases() -> list[tuple[str, str, str]]:
    """(name, asf text, amc text): each must raise AMCError naming the ASF or AMC file and a line."""
    c = []
    a = lambda name, asf=ASF, amc=AMC: c.append((name, asf, amc))  # noqa: E731
    for bad in ("nan", "inf", "1e999", "abc", "\u0661", "1_0"):
        a(f"ASF length {bad!r}", ASF.replace("length 10", f"length {bad}", 1))
        a(f"AMC value {bad!r}", amc=AMC.replace("lfemur 10 20 30", f"lfemur 10 {bad} 30", 1))
    a("ASF bone with unknown parent", ASF.replace("lfemur ltibia", "lknee ltibia"))
    a("ASF hierarchy cycle", ASF.replace("    lfemur ltibia\n", "    lfemur ltibia\n    ltibia lfemur\n"))
    a("ASF bone is its own parent", ASF.replace("lfemur ltibia", "ltibia ltibia"))
    a("ASF duplicate bone names", ASF.replace("name ltibia", "name lfemur"))
    a("ASF dof 'rw'", ASF.replace("dof rx\n", "dof rw\n"))
    a("ASF 7 dofs", ASF.replace("dof rx ry rz", "dof rx ry rz tx ty tz l"))
    a("ASF repeated dof", ASF.replace("dof rx ry rz", "dof rx rx rz"))
    a("ASF missing :root", ASF.replace(":root\n  order TX TY TZ RX RY RZ\n  axis XYZ\n  position 0 0 0\n"
                                       "  orientation 0 0 0\n", ""))
    a("ASF missing :bonedata", ASF.split(":bonedata")[0] + ":hierarchy\n  begin\n  end\n")
    a("ASF angle unit 'grad'", ASF.replace("angle deg", "angle grad"))
    a("ASF axis order 'XXY'", ASF.replace("axis 0 0 0 XYZ", "axis 0 0 0 XXY", 1))
    a("ASF direction with 2 numbers", ASF.replace("direction 0 -1 0", "direction 0 -1", 1))
    a("ASF unterminated begin", ASF.replace("  end\n  begin\n    id 2", "  begin\n    id 2"))
    a("ASF empty", "")
    a("ASF binary garbage", bytes(range(256)).decode("latin-1") * 8)
    a("AMC frame number '\u00b9'", amc=AMC.replace("\n2\n", "\n\u00b9\n"))
    a("AMC frame number '-1'", amc=AMC.replace("\n2\n", "\n-1\n"))
    a("AMC frames out of order", amc=AMC.replace("\n2\n", "\n3\n", 1))
    a("AMC frame 0 then a gap", amc=AMC.replace("\n1\nroot", "\n7\nroot", 1))
    a("AMC unknown bone", amc=AMC.replace("ltibia 5", "lknee 5"))
    a("AMC too many values", amc=AMC.replace("ltibia 5", "ltibia 5 6"))
    a("AMC too few values", amc=AMC.replace("lfemur 10 20 30", "lfemur 10 20", 1))
    a("AMC bone twice in a frame", amc=AMC.replace("ltibia 5\n", "ltibia 5\nltibia 5\n"))
    a("AMC no frames", amc=":FULLY-SPECIFIED\n:DEGREES\n")
    a("AMC values before the first frame number", amc=":DEGREES\nroot 0 0 0 0 0 0\n" + AMC)
    a("AMC frame number 1e9", amc=AMC.replace("\n3\n", "\n1000000000\n"))
    a("AMC huge frame number", amc=AMC.replace("\n3\n", "\n" + "9" * 5000 + "\n"))
    a("AMC binary garbage", amc=bytes(range(256)).decode("latin-1") * 8)
    a("AMC empty", amc="")
    a("AMC a line of a million values", amc=AMC.replace("ltibia 5", "ltibia " + "1 " * 1_000_000, 1))
    bones = "".join(f"  begin\n    id {k}\n    name b{k}\n    direction 0 1 0\n    length 1\n    axis 0 0 0 XYZ\n"
                    f"    dof rx\n  end\n" for k in range(3, 20_003))
    chain = "".join(f"    {'ltibia' if k == 3 else f'b{k - 1}'} b{k}\n" for k in range(3, 20_003))
    a("ASF 20,000-bone chain, AMC naming a bone it lacks",
      ASF.replace(":hierarchy", bones + ":hierarchy").replace("    lfemur ltibia\n", "    lfemur ltibia\n" + chain),
      AMC.replace("ltibia 5", "ltibia 5\nnosuchbone 1", 1))
    return c


# --------------------------------------------------------------------------------------------------
# session material
# --------------------------------------------------------------------------------------------------
def op_examples(joint: str, end: str, duration: float) -> dict:
    """A valid example of every op (its required fields): ``joint`` the joint edited (the succession's root),
    ``end`` the joint IK moves, ``duration`` the warps' output seconds."""
    return {
        "extract": {},
        "cull": {"percent": 50},
        "succession": {"root": joint, "s": 0.03, "l": 2.0},
        "random_timing": {"tau": 0.05, "seed": 0},
        "exaggerate": {"w_r": 1.5},
        "edit_pose": {"pose": 0, "deltas": {joint: [0, 0, 10]}},
        "retime": {"pose": 1, "time": 0.05},
        "insert_pose": {"time": 0.03},
        "delete_pose": {"pose": 1},
        "keep_contacts": {},
        "ik_pose": {"pose": 0, "joint": end, "target": [0, 20, 0]},
        "edit_frame": {"frame": 1, "deltas": {joint: [0, 0, 10]}},
        "propagate": {"frame": 1, "deltas": {joint: [0, 0, 10]}},
        "guided_warp": {"duration": duration},
        "linear_warp": {"duration": duration},
        "resample": {"frame_time": 0.02},
    }


OP_FIELDS = op_examples("Spine", "Head", 0.05)  # every op with a valid example; each field then gets every wrong type
WRONG = [None, True, "x", "", [], {}, [1, 2], {"a": 1}, -1, -1e308, 1e308, 0, 10 ** 30, 0.5, "\u0661", [[[]]]]


def session_cases(source_path: str, tmp: Path) -> list[tuple[str, object]]:
    """(name, JSON text or a Python object to dump): Session.load + edited() must raise a ValueError
    naming the field (or the file)."""
    src = {"path": source_path}
    good_ops = [{"op": "cull", "percent": 50}]
    doc = lambda ops=good_ops, **kw: {"format": "stagger_nb.session", "version": 1, "source": src,  # noqa: E731
                                      "extract_options": {}, "ops": ops, **kw}
    c: list[tuple[str, object]] = []
    c.append(("not JSON", "{ops: [}"))
    c.append(("empty file", ""))
    c.append(("JSON array", "[]"))
    c.append(("JSON string", '"session"'))
    c.append(("JSON null", "null"))
    c.append(("NaN literal", json.dumps(doc([{"op": "cull", "percent": 1}])).replace('"percent": 1', '"percent": NaN')))
    c.append(("Infinity literal", json.dumps(doc([{"op": "succession", "root": "Spine", "s": 1, "l": 2}]))
              .replace('"s": 1', '"s": Infinity')))
    c.append(("-Infinity literal", json.dumps(doc([{"op": "random_timing", "tau": 1}])).replace('"tau": 1',
                                                                                                '"tau": -Infinity')))
    c.append(("1e999 number", json.dumps(doc([{"op": "cull", "percent": 1}])).replace('"percent": 1',
                                                                                      '"percent": 1e999')))
    c.append(("5000-digit integer", json.dumps(doc([{"op": "cull", "count": 1}])).replace('"count": 1',
                                                                                          '"count": ' + "9" * 5000)))
    c.append(("deep nesting", "[" * 200_000 + "]" * 200_000))
    big = ", ".join(["0.5"] * 2_000_000)
    c.append(("session file over the size limit (40 MB)", '{"format": "stagger_nb.session", "version": 1, '
              '"ops": [{"op": "cull", "keep": [' + ", ".join([big] * 4) + "]}]}"))
    c.append(("nested huge float arrays just under the size limit", '{"format": "stagger_nb.session", "version": 1, '
              '"ops": [{"op": "cull", "keep": [[' + "], [".join([big] * 3) + "]]}]}"))
    c.append(("deep nesting in an op", json.dumps(doc([{"op": "cull", "keep": 1}])).replace(
        '"keep": 1', '"keep": ' + "[" * 100_000 + "]" * 100_000)))
    c.append(("invalid UTF-8", b'{"format": "stagger_nb.session", "x": "\xff\xfe"}'))
    c.append(("lone surrogate escape", json.dumps(doc([{"op": "succession", "root": "x", "s": 1}])).replace(
        '"root": "x"', '"root": "\\ud800"')))
    c.append(("NUL in a joint name", doc([{"op": "succession", "root": "Sp\x00ine", "s": 0.03}])))
    c.append(("format wrong", doc(format="other")))
    c.append(("version 2", doc(version=2)))
    c.append(("version '1'", doc(version="1")))
    c.append(("version true", doc(version=True)))
    c.append(("unknown top-level field", doc(extra=1)))
    c.append(("ops not a list", doc(ops={"op": "cull"})))
    c.append(("ops a string", doc(ops="cull")))
    c.append(("op not an object", doc(ops=[["cull", 50]])))
    c.append(("op without 'op'", doc(ops=[{"percent": 50}])))
    c.append(("unknown op", doc(ops=[{"op": "explode"}])))
    c.append(("op name of wrong type", doc(ops=[{"op": 7}])))
    c.append(("op name with odd case", doc(ops=[{"op": "CULL", "percent": 50}])))
    c.append(("unknown field in an op", doc(ops=[{"op": "cull", "percent": 50, "bogus": 1}])))
    c.append(("cull with two criteria", doc(ops=[{"op": "cull", "percent": 50, "count": 3}])))
    c.append(("cull percent 1e308", doc(ops=[{"op": "cull", "percent": 1e308}])))
    c.append(("cull percent -1e308", doc(ops=[{"op": "cull", "percent": -1e308}])))
    c.append(("cull keep negative", doc(ops=[{"op": "cull", "keep": [-1, 0]}])))
    c.append(("cull keep huge index", doc(ops=[{"op": "cull", "keep": [0, 10 ** 12]}])))
    c.append(("cull keep 200k items", doc(ops=[{"op": "cull", "keep": list(range(200_000))}])))
    c.append(("edit_pose negative pose", doc(ops=[{"op": "edit_pose", "pose": -1, "deltas": {"Spine": [0, 0, 1]}}])))
    c.append(("edit_pose pose beyond the last", doc(ops=[{"op": "edit_pose", "pose": 10 ** 6,
                                                          "deltas": {"Spine": [0, 0, 1]}}])))
    c.append(("edit_pose unknown joint", doc(ops=[{"op": "edit_pose", "pose": 0, "deltas": {"Tail": [0, 0, 1]}}])))
    c.append(("edit_pose 200k joints", doc(ops=[{"op": "edit_pose", "pose": 0,
                                                 "deltas": {f"j{i}": [0, 0, 1] for i in range(200_000)}}])))
    c.append(("edit_frame frame beyond the last", doc(ops=[{"op": "edit_frame", "frame": 10 ** 9,
                                                            "deltas": {"Spine": [0, 0, 1]}}])))
    c.append(("edit_frame negative frame", doc(ops=[{"op": "edit_frame", "frame": -2,
                                                     "deltas": {"Spine": [0, 0, 1]}}])))
    c.append(("propagate sigma 1e-300", doc(ops=[{"op": "propagate", "frame": 1, "sigma": 1e-300,
                                                  "deltas": {"Spine": [0, 0, 1]}}])))
    c.append(("propagate frame_range reversed", doc(ops=[{"op": "propagate", "frame": 1, "frame_range": [3, 0],
                                                          "deltas": {"Spine": [0, 0, 1]}}])))
    c.append(("propagate huge delta", doc(ops=[{"op": "propagate", "frame": 1, "deltas": {"Spine": [0, 0, 1e308]}}])))
    c.append(("guided_warp duration 1e308", doc(ops=[{"op": "guided_warp", "duration": 1e308}])))
    c.append(("guided_warp duration 1e-300", doc(ops=[{"op": "guided_warp", "duration": 1e-300}])))
    c.append(("guided_warp skip 10**9", doc(ops=[{"op": "guided_warp", "duration": 0.05, "skip": 10 ** 9}])))
    c.append(("guided_warp keytimes 200k", doc(ops=[{"op": "guided_warp", "duration": 0.05,
                                                     "keytimes": [[0.0, 0.0]] * 200_000}])))
    c.append(("guided_warp keytimes nested", doc(ops=[{"op": "guided_warp", "duration": 0.05,
                                                       "keytimes": [[[0.0, 0.0]]]}])))
    c.append(("guided_warp keytimes out of order", doc(ops=[{"op": "guided_warp", "duration": 0.05,
                                                             "keytimes": [[0.06, 0.01], [0.0, 0.03]]}])))
    c.append(("linear_warp duration 1e7", doc(ops=[{"op": "linear_warp", "duration": 1e7}])))
    c.append(("resample frame_time 1e-12", doc(ops=[{"op": "resample", "frame_time": 1e-12}])))
    c.append(("resample frame_time 1e308", doc(ops=[{"op": "resample", "frame_time": 1e308}])))
    c.append(("extract_options iterations 1e9", doc(extract_options={"iterations": 1e9})))
    c.append(("extract_options unknown", doc(extract_options={"bogus": 1})))
    c.append(("extract_options not an object", doc(extract_options=[1])))
    c.append(("extract_options filter_width 1e9", doc(extract_options={"filter_width": 1e9})))
    # every field of every op, every wrong type
    for op, fields in OP_FIELDS.items():
        for f in fields:
            for w in WRONG:
                number = isinstance(w, (int, float)) and not isinstance(w, bool)
                if w == fields[f] or (w == {} and f == "deltas") or (
                        number and isinstance(fields[f], (int, float)) and _maybe_valid(op, f, w)):
                    continue
                c.append((f"{op}.{f} = {json.dumps(w)[:20]}", doc(ops=[{"op": op, **fields, f: w}])))
    # paths
    c.append(("source path to a directory", doc(source={"path": str(tmp)})))
    c.append(("source path /dev/zero", doc(source={"path": "/dev/zero"})))
    c.append(("source path /dev/null", doc(source={"path": "/dev/null"})))
    c.append(("source path missing", doc(source={"path": str(tmp / "missing.bvh")})))
    c.append(("source path empty", doc(source={"path": ""})))
    c.append(("source path with NUL", doc(source={"path": "a\x00b.bvh"})))
    c.append(("source path 5000 chars", doc(source={"path": "/" + "a" * 5000})))
    c.append(("source path of wrong type", doc(source={"path": 3})))
    c.append(("source neither path nor motion", doc(source={"url": "http://x"})))
    c.append(("source sha256 mismatch", doc(source={"path": source_path, "sha256": "0" * 64})))
    c.append(("source sha256 of wrong type", doc(source={"path": source_path, "sha256": 5})))
    if hasattr(os, "mkfifo"):
        fifo = tmp / "fifo.bvh"
        if not fifo.exists():
            os.mkfifo(fifo)
        c.append(("source path to a FIFO", doc(source={"path": str(fifo)})))
    link = tmp / "zero.bvh"
    if not link.is_symlink():
        os.symlink("/dev/zero", link)
    c.append(("source symlink to /dev/zero", doc(source={"path": str(link)})))
    loop = tmp / "loop.bvh"
    if not loop.is_symlink():
        os.symlink(loop, loop)
    c.append(("source symlink loop", doc(source={"path": str(loop)})))
    for k, ref in enumerate([{"path": "/dev/zero"}, {"path": str(link)}, {"path": str(tmp)}, {"path": 5},
                             {"path": str(tmp / "missing.bvh")}, {"motion": {"names": []}}, {"bogus": 1}, "other",
                             ["self"], {"path": str(loop)}]):
        c.append((f"guided_warp reference {k}", doc(ops=[{"op": "guided_warp", "duration": 0.05, "reference": ref}])))
    # embedded motions
    m = {"names": ["a"], "parents": [-1], "offsets": [[0, 0, 0]], "channels": [["Zrotation"]], "end_sites": {},
         "frame_time": 0.1, "root_positions": [[0, 0, 0]] * 2, "local_quats": [[[0, 0, 0, 1]]] * 2}
    emb = lambda **kw: doc(source={"motion": {**m, **kw}})  # noqa: E731
    c.append(("embedded motion quats ragged", emb(local_quats=[[[0, 0, 0, 1]], [[0, 0, 1]]])))
    c.append(("embedded motion quats of strings", emb(local_quats=[[["0", "0", "0", "1"]]] * 2)))
    c.append(("embedded motion zero quaternion", emb(local_quats=[[[0, 0, 0, 0]]] * 2)))
    c.append(("embedded motion 1e308 quaternion", emb(local_quats=[[[1e308, 1e308, 0, 1]]] * 2)))
    c.append(("embedded motion frames disagree", emb(root_positions=[[0, 0, 0]] * 3)))
    c.append(("embedded motion frame_time 1e-9", emb(frame_time=1e-9)))
    c.append(("embedded motion frame_time 0", emb(frame_time=0)))
    c.append(("embedded motion parent cycle", emb(names=["a", "b"], parents=[1, 0], offsets=[[0, 0, 0]] * 2,
                                                  channels=[[], []], local_quats=[[[0, 0, 0, 1]] * 2] * 2)))
    c.append(("embedded motion parent out of range", emb(names=["a", "b"], parents=[-1, 7], offsets=[[0, 0, 0]] * 2,
                                                         channels=[[], []], local_quats=[[[0, 0, 0, 1]] * 2] * 2)))
    c.append(("embedded motion two roots", emb(names=["a", "b"], parents=[-1, -1], offsets=[[0, 0, 0]] * 2,
                                               channels=[[], []], local_quats=[[[0, 0, 0, 1]] * 2] * 2)))
    c.append(("embedded motion duplicate names", emb(names=["a", "a"], parents=[-1, 0], offsets=[[0, 0, 0]] * 2,
                                                     channels=[[], []], local_quats=[[[0, 0, 0, 1]] * 2] * 2)))
    c.append(("embedded motion no joints", emb(names=[], parents=[], offsets=[], channels=[], local_quats=[])))
    c.append(("embedded motion bad channel", emb(channels=[["Wrotation"]])))
    c.append(("embedded motion end_sites key -1", emb(end_sites={"-1": [0, 0, 0]})))
    c.append(("embedded motion end_sites key '\u0661'", emb(end_sites={"\u0661": [0, 0, 0]})))
    c.append(("embedded motion nested huge arrays", emb(root_positions=[[[0] * 1000] * 1000])))
    c.append(("embedded motion 2M frames x 1 joint declared by data", emb(
        root_positions=[[0, 0, 0]] * 2, local_quats=[[[0, 0, 0, 1]]] * 3)))
    c.append(("embedded motion names of wrong type", emb(names="a")))
    c.append(("embedded motion missing field", {"format": "stagger_nb.session", "version": 1, "ops": [],
                                                "source": {"motion": {"names": ["a"]}}}))
    return c


def _maybe_valid(op: str, f: str, w) -> bool:
    """Numbers that may be valid for a numeric field are covered by the targeted cases above."""
    return (w in (0, 0.5) or (w == 10 ** 30 and f in ("seed",))
            or (w == -1 and f in ("s", "w_r")))  # a reversed succession, an exaggeration collapsing the pose


# --------------------------------------------------------------------------------------------------
# an independent glTF re-reader (pygltflib for the container, scipy for the rotations)
# --------------------------------------------------------------------------------------------------
def gltf_positions(path) -> tuple[list[str], float, np.ndarray]:
    """``(joint names, metres per file unit, world positions (F, J, 3) in metres)`` of the skin's joints
    in a ``.glb`` written by ``write_gltf``, sampled at its animation's keys."""
    import pygltflib
    from scipy.spatial.transform import Rotation
    g = pygltflib.GLTF2().load(str(path))
    blob = g.binary_blob()
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}
    dtype = {5126: np.float32, 5121: np.uint8, 5123: np.uint16}

    def read(i):
        a = g.accessors[i]
        bv = g.bufferViews[a.bufferView]
        n = width[a.type]
        out = np.frombuffer(blob, dtype[a.componentType], count=a.count * n,
                            offset=(bv.byteOffset or 0) + (a.byteOffset or 0))
        return out.reshape(a.count, n).astype(float)
    joints = g.skins[0].joints
    parent = {c: i for i, nd in enumerate(g.nodes) for c in (nd.children or [])}
    anim = g.animations[0]
    F = g.accessors[anim.samplers[0].input].count
    rot = {j: np.tile([0.0, 0.0, 0.0, 1.0], (F, 1)) for j in joints}
    trans = {j: np.tile(np.asarray(g.nodes[j].translation or [0.0, 0.0, 0.0], float), (F, 1)) for j in joints}
    for ch in anim.channels:
        values = read(anim.samplers[ch.sampler].output)
        (rot if ch.target.path == "rotation" else trans)[ch.target.node] = values
    world_r, world_p = {}, {}
    for j in joints:  # parents come first in write_gltf's node order
        r = Rotation.from_quat(rot[j])
        if j in parent:
            pr = world_r[parent[j]]
            world_p[j] = world_p[parent[j]] + pr.apply(trans[j])
            world_r[j] = pr * r
        else:
            world_p[j], world_r[j] = trans[j], r
    pos = np.stack([world_p[j] for j in joints], axis=1)
    return [g.nodes[j].name for j in joints], float(g.asset.extras["metres_per_unit"]), pos


# --------------------------------------------------------------------------------------------------
# the runner
# --------------------------------------------------------------------------------------------------
def _names_where(msg: str, path: str | None, kind: str) -> bool:
    """Does the error message name the file (and a line) or the session field?"""
    if kind in ("bvh", "amc"):
        return path is not None and os.path.basename(path) in msg
    # session: a field path first ("ops[0] (cull): percent: ...", "source.path: ...", "session: ...")
    return bool(re.match(r"^[A-Za-z_][\w.\[\]]*( \(\w+\))?( key)?: ", msg))


def _rss_kib(key: str) -> int:
    with open("/proc/self/status") as f:
        return int(next(line for line in f if line.startswith(key)).split()[1])


def _hwm_resettable() -> bool:
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


_HWM = _hwm_resettable()  # Linux: the peak RSS of each case, cheaply; elsewhere tracemalloc (slow)


def _run_case(kind: str, name: str, fn) -> dict:
    """Run ``fn`` and record how it ended, its CPU time (``time.process_time``: the cost of the case, the same
    on a loaded machine) and its peak memory (bytes above the RSS before it, or the tracemalloc peak where the
    peak RSS cannot be reset)."""
    if _HWM:
        _hwm_resettable()
        base = _rss_kib("VmRSS")
    else:
        tracemalloc.start()
    t0 = time.process_time()
    out = {"kind": kind, "name": name}
    try:
        fn()
        out["result"] = "no error"
    except ValueError as e:
        out["result"] = "ValueError"
        out["type"] = type(e).__name__
        out["message"] = str(e)[:400]
    except Exception as e:
        out["result"] = type(e).__name__
        out["message"] = str(e)[:400]
    out["seconds"] = time.process_time() - t0
    if _HWM:
        out["peak"] = max(0, _rss_kib("VmHWM") - base) * 1024
    else:
        out["peak"] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return out


def run(out_dir: Path, only: str | None = None):
    import stagger_nb as sn
    from stagger_nb.core.kinematics import forward_kinematics, skeleton_height
    from stagger_nb.session import Session

    out_dir.mkdir(parents=True, exist_ok=True)
    results = []

    def emit(r):
        results.append(r)
        print(json.dumps(r), flush=True)

    if only in (None, "bvh"):
        for k, (name, raw) in enumerate(bvh_cases()):
            p = out_dir / f"hostile_{k}.bvh"
            p.write_bytes(raw)
            r = _run_case("bvh", name, lambda: sn.read_bvh(p))
            r["named"] = r["result"] == "ValueError" and _names_where(r["message"], str(p), "bvh")
            r["line"] = r["result"] == "ValueError" and bool(re.search(r"line \d+", r["message"]))
            emit(r)
    if only in (None, "amc"):
        for k, (name, asf, amc) in enumerate(asf_amc_cases()):
            pa, pm = out_dir / f"hostile_{k}.asf", out_dir / f"hostile_{k}.amc"
            pa.write_text(asf, encoding="utf-8", errors="surrogateescape")
            pm.write_text(amc, encoding="utf-8", errors="surrogateescape")
            r = _run_case("amc", name, lambda: sn.read_asf_amc(pa, pm))
            r["named"] = r["result"] == "ValueError" and (pa.name in r["message"] or pm.name in r["message"])
            r["line"] = r["result"] == "ValueError" and bool(re.search(r"line \d+", r["message"]))
            emit(r)
    if only in (None, "session"):
        src = out_dir / "source.bvh"
        src.write_text(bvh(frames="30", rows=[f"{f * 0.1} 90 0 {f} {2 * f} {3 * f} {f} 2 3 4 {f} 6"
                                              for f in range(30)]))
        src_bytes = src.read_bytes()
        for k, (name, d) in enumerate(session_cases(str(src), out_dir)):
            p = out_dir / f"session_{k}.json"
            p.write_bytes(d if isinstance(d, bytes) else (d if isinstance(d, str) else json.dumps(d)).encode(
                "utf-8", "surrogatepass"))
            before = p.read_bytes()

            def load_and_replay(p=p):
                s = Session.load(p)
                s.edited()
                s.export_bvh(out_dir / "export.bvh")
            r = _run_case("session", name, load_and_replay)
            r["named"] = r["result"] == "ValueError" and _names_where(r["message"], str(p), "session")
            r["untouched"] = p.read_bytes() == before and src.read_bytes() == src_bytes
            emit(r)
        # saving never overwrites a source clip or a file that is not a session
        s = Session.from_bvh(src)
        for target in (src, out_dir / "hostile_0.bvh", out_dir / "notes.txt"):
            if not target.exists():
                target.write_text("not a session")
            before = target.read_bytes()
            r = _run_case("session", f"save over {target.name}", lambda t=target: s.save(t))
            r["named"] = r["result"] == "ValueError" and target.name in r.get("message", "")
            r["untouched"] = target.read_bytes() == before
            emit(r)
        r = _run_case("session", "export over the source", lambda: s.export_bvh(src))
        r["named"] = r["result"] == "ValueError" and src.name in r.get("message", "")
        r["untouched"] = src.read_bytes() == src_bytes
        emit(r)
        # write targets that must not be replaced, or cannot be written: named ValueErrors, nothing replaced
        link = out_dir / "link_to_source.bvh"
        if not link.is_symlink():
            os.symlink(src, link)
        hard = out_dir / "hard_link_to_source.bvh"
        if not hard.exists():
            os.link(src, hard)
        fifo = out_dir / "fifo.out"
        if hasattr(os, "mkfifo") and not fifo.exists():
            os.mkfifo(fifo)
        dangling = out_dir / "dangling.bvh"
        if not dangling.is_symlink():
            os.symlink(out_dir / "nowhere" / "x.bvh", dangling)
        targets = [("a folder", out_dir, None), ("/dev/null", Path("/dev/null"), None),
                   ("a FIFO", fifo, None), ("a missing folder", out_dir / "missing" / "x.bvh", None),
                   ("a dangling symlink", dangling, None), ("a symlink to the source", link, "source"),
                   ("a hard link to the source", hard, "source")]
        for what, target, kind in targets:
            for how, fn in (("export_bvh", s.export_bvh), ("export_gltf", s.export_gltf), ("save", s.save),
                            ("write_bvh", lambda t: sn.write_bvh(s.source, t))):
                if kind == "source" and how == "write_bvh":
                    continue  # write_bvh knows no source: replacing a link to it is an ordinary write
                stat_before = os.lstat(target) if os.path.lexists(target) else None
                r = _run_case("session", f"{how} to {what}", lambda fn=fn, t=target: fn(t))
                r["named"] = r["result"] == "ValueError" and str(target.name) in r.get("message", "")
                after = os.lstat(target) if os.path.lexists(target) else None
                r["untouched"] = ((stat_before is None) == (after is None) and (
                    after is None or (after.st_ino, after.st_mode) == (stat_before.st_ino, stat_before.st_mode))
                    and src.read_bytes() == src_bytes)
                emit(r)
    if only in (None, "odd"):
        for k, (name, raw, expect) in enumerate(bvh_odd_valid()):
            p = out_dir / f"odd_{k}.bvh"
            p.write_bytes(raw)

            def read_edit_export(p=p, k=k, expect=expect):
                m = sn.read_bvh(p)
                s = Session(m, source_path=str(p))
                J = m.num_joints
                joint = m.skeleton.names[min(1, J - 1)]
                s.add({"op": "edit_frame", "frame": 0, "deltas": {joint: [5.0, -7.0, 11.0]}})
                edited = s.edited()
                out = out_dir / f"odd_{k}_export.bvh"
                import warnings
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # channels added to partial joints are said in a warning
                    s.export_bvh(out)
                back = sn.read_bvh(out)
                p1, _ = forward_kinematics(edited)
                p2, _ = forward_kinematics(back)
                h = max(skeleton_height(edited), 1e-9)
                err = float(np.max(np.abs(p1 - p2))) / h
                if not err <= 1e-5:
                    raise AssertionError(f"export re-reads {err:.3g} x height away from the edited motion")
                glb = out_dir / f"odd_{k}.glb"
                sn.write_gltf(edited, glb)
                names, scale, pos = gltf_positions(glb)
                if list(names) != list(edited.skeleton.names):
                    raise AssertionError("glTF joint names differ")
                err = float(np.max(np.abs(pos - p1 * scale))) / (h * scale)
                if not err <= 1e-5:
                    raise AssertionError(f"glTF re-reads {err:.3g} x height away from the edited motion")
            r = _run_case("odd", name, read_edit_export)
            emit(r)
    return results


if __name__ == "__main__":
    sys.exit(run(Path(sys.argv[1]), sys.argv[2] if len(sys.argv) > 2 else None) and 0)
