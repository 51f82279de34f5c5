"""A second, independent hostile set (issue 13's held-out check, played from the outside): new BVH, ASF/AMC
and session files, hostile parameters for the public technique functions, and odd rigs round-tripped
through export. None of these cases is in ``tests/hostile_corpus.py``.

Each case runs in its own forked child (the parent imports stagger_nb once and builds the inputs): the child
gets an address-space limit, the parent waits at most ``--seconds`` (10 s) and reads the child's peak RSS
above its start (``ru_maxrss`` of ``wait4`` minus the RSS at the fork) against 500 MB.  A case passes when it
ends in

- ``hostile``: a ValueError naming the file and a line (files), the field (sessions: the message starts
  ``field: ``) or the parameter (functions: the parameter's name is in the message); nothing overwritten;
- ``either``: that, or a clean result that is checked (a file that reads must write and re-read to the same
  positions within 1e-5 of height; a function result must be finite and of the documented shape);
- ``odd``: a clean read, an edit, and an export re-read within 1e-5 of height (BVH and glTF).

Usage::

    PYTHONPATH=$PWD OPENBLAS_NUM_THREADS=1 nice python benchmarks/hostile_heldout.py [--only KIND] [--match TEXT]

Prints one line per failing case and a summary (cases, failures by kind, the slowest and largest cases);
exit status 1 when any case fails.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import signal
import socket
import sys
import tempfile
import time
import traceback
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the hand-written rigs' builders
from hostile_corpus import op_examples
from io_samples import ASF_ROOT, FEMUR_LIMITS, asf_bone, bvh_hierarchy

MAX_SECONDS = 10.0
MAX_BYTES = 500 << 20
AS_LIMIT = 6 << 30  # numpy / pyarrow thread arenas reserve address space: the RSS check is the 500 MB bound

# --------------------------------------------------------------------------------------------------
# BVH material
# --------------------------------------------------------------------------------------------------
HEAD = bvh_hierarchy(("Hips", "0 0 0", [("Chest", "0 12 0", [("Neck", "0 8 1", "0 4 0")]),
                                        ("Leg", "3 -2 0", "0 -15 0")]))
NCH = 15
ROWS = ["1 90 2 10 20 30 1 2 3 4 5 6 7 8 9", "1.5 91 2.5 11 21 31 2 3 4 5 6 7 8 9 10",
        "2 92 3 12 22 32 3 4 5 6 7 8 9 10 11", "2.5 93 3.5 13 23 33 4 5 6 7 8 9 10 11 12"]


def bvh(head=HEAD, frames="4", ft="0.04", rows=ROWS, motion="MOTION", fr="Frames:", ftk="Frame Time:", nl="\n"):
    return nl.join(head.split("\n")) + f"{motion}{nl}{fr} {frames}{nl}{ftk} {ft}{nl}" + nl.join(rows) + nl


def rows_with(value, index=4, row=1):
    r = [x.split() for x in ROWS]
    r[row][index] = value
    return [" ".join(x) for x in r]


def bvh_cases():
    """(name, bytes, mode) with mode 'hostile' (must fail naming file+line) or 'either'."""
    c = []

    def add(name, text, mode="hostile"):
        c.append((name, text.encode("utf-8", "surrogatepass") if isinstance(text, str) else text, mode))
    # numbers in every odd form, in a motion value, an OFFSET, Frames and Frame Time
    odd_numbers = {
        "hex float 0x1p3": "0x1p3", "hex int 0x10": "0x10", "1e+": "1e+", "1e-": "1e-", "+.": "+.", "-.": "-.",
        "1..2": "1..2", "1.2.": "1.2.", "..1": "..1", "1ee2": "1ee2", "1e2.5": "1e2.5", "1e400": "1e400",
        "-1e400": "-1e400", "400-digit integer": "1" * 400, "400-digit fraction": "0." + "1" * 400,
        "310 zeros then 1": "0." + "0" * 310 + "1", "U+2212 minus": "\u22121", "U+2013 dash": "\u20131",
        "full-width minus": "\uff0d1", "Arabic-Indic 5": "\u0665", "Devanagari 3": "\u0969",
        "mathematical bold 1": "\U0001d7cf", "superscript 2": "\u00b2", "fraction 1/2": "\u00bd",
        "roman numeral": "\u2167", "NBSP inside": "1\u00a02", "thin space inside": "1\u20092",
        "ideographic space inside": "1\u30002", "zero-width space": "1\u200b2", "soft hyphen": "1\u00ad",
        "BOM inside": "\ufeff1", "NaN with sign": "-nan", "nan(123)": "nan(123)", "snan": "snan",
        "INF mixed case": "iNf", "infinity word": "+Infinity", "1#INF (MSVC)": "1.#INF", "1.#QNAN": "1.#QNAN",
        "percent": "5%", "comma thousands": "1,000", "underscore": "1_000.5", "trailing d": "1.5d0",
        "Fortran D exponent": "1.5D3", "trailing f": "1.5f", "parenthesised": "(1)", "quoted": '"1"',
        "lone e": "e", "lone E5": "E5", "+e": "+e", "only sign +": "+", "two signs -+1": "-+1",
        "leading zeros 0001": "0001", "-0": "-0", "4e-400": "4e-400", "denormal 4e-320": "4e-320",
        "1e308": "1e308", "-1.7e308": "-1.7e308", "1e-5 exponent huge": "1e-99999999999999999999",
        "exponent 99999999999999999999": "1e99999999999999999999", "control char \\x1b": "1\x1b",
        "vertical tab": "1\x0b2", "NUL after": "1\x00", "surrogate": "\udc80",
    }
    accepted_anyway = {"leading zeros 0001", "-0", "4e-400", "denormal 4e-320", "310 zeros then 1",
                       "400-digit fraction", "1e308", "-1.7e308", "1e-5 exponent huge"}
    for name, v in odd_numbers.items():
        mode = "either" if name in accepted_anyway else "hostile"
        add(f"motion value {name}", bvh(rows=rows_with(v)), mode)
        add(f"root position value {name}", bvh(rows=rows_with(v, 0, 2)), mode)
        add(f"OFFSET {name}", bvh(HEAD.replace("OFFSET 3 -2 0", f"OFFSET 3 {v} 0")), mode)
        add(f"Frames: {name}", bvh(frames=v), "hostile" if name not in ("leading zeros 0001",) else "hostile")
        add(f"Frame Time: {name}", bvh(ft=v), "either" if name in accepted_anyway | {"400-digit fraction"}
            else "hostile")
    add("Frames: 0004", bvh(frames="0004"), "either")
    add("Frames: +4", bvh(frames="+4"), "either")
    add("Frames: 4.0", bvh(frames="4.0"), "either")
    add("Frames: 4e0", bvh(frames="4e0"), "either")
    add("Frames: full-width 4", bvh(frames="\uff14"))
    add("Frames: 2**63", bvh(frames=str(2 ** 63)))
    add("Frames: 2**64+4", bvh(frames=str(2 ** 64 + 4)))
    add("Frames: -0", bvh(frames="-0"))
    add("Frame Time: 0.04s", bvh(ft="0.04s"))
    add("Frame Time: 1/25", bvh(ft="1/25"))
    add("Frame Time: 25 (fps?)", bvh(ft="25"), "either")
    add("Frame Time: 1e-7", bvh(ft="1e-7"))
    add("Frame Time: 1e308", bvh(ft="1e308"))
    add("Frame Time: 2e-5", bvh(ft="2e-5"), "either")
    # header keywords misspelled / missing / repeated / out of order / odd case
    for wrong, right in [("HIERACHY", "HIERARCHY"), ("HIERARCHY:", "HIERARCHY"), ("hierarchy", "HIERARCHY"),
                         ("ROOTS Hips", "ROOT Hips"), ("Root Hips", "ROOT Hips"), ("JOINTS Chest", "JOINT Chest"),
                         ("Joint Chest", "JOINT Chest"), ("OFFSETS 0 12 0", "OFFSET 0 12 0"),
                         ("offset 0 12 0", "OFFSET 0 12 0"), ("CHANNEL 3", "CHANNELS 3"), ("channels 3", "CHANNELS 3"),
                         ("EndSite", "End Site"), ("End site", "End Site"), ("END SITE", "End Site"),
                         ("End  Site", "End Site"), ("End", "End Site"), ("Site", "End Site"),
                         ("End Sites", "End Site"), ("Zrot", "Zrotation"), ("Z_rotation", "Zrotation"),
                         ("Zrotations", "Zrotation"), ("Xpos", "Xposition"), ("rotationZ", "Zrotation")]:
        add(f"keyword {right!r} as {wrong!r}", bvh(HEAD.replace(right, wrong, 1)), "either")
    for wrong in ("MOTIONS", "Motion", "MOTION:", "MOTION 4"):
        add(f"keyword MOTION as {wrong!r}", bvh(motion=wrong), "either")
    for wrong in ("Frames", "Frames=", "Frame:", "frames:", "FRAMES:", "Frames :", "NumFrames:", "Frames::"):
        add(f"Frames: as {wrong!r}", bvh(fr=wrong), "either")
    for wrong in ("Frame Time", "FrameTime:", "Frame time:", "frame time:", "Frame  Time:", "Frame Time=",
                  "Frame Rate:", "Frame_Time:", "Frame Time::"):
        add(f"Frame Time: as {wrong!r}", bvh(ftk=wrong), "either")
    add("two HIERARCHY lines", bvh("HIERARCHY\n" + HEAD))
    add("HIERARCHY missing and ROOT first", bvh(HEAD.replace("HIERARCHY\n", "")), "either")
    add("two MOTION lines", bvh(motion="MOTION\nMOTION"))
    add("two Frames lines", bvh(fr="Frames: 4\nFrames:"))
    add("two Frame Time lines", bvh(ftk="Frame Time: 0.04\nFrame Time:"))
    add("Frames and Frame Time on one line", HEAD + "MOTION\nFrames: 4 Frame Time: 0.04\n" + "\n".join(ROWS) + "\n")
    add("MOTION, Frames on one line", HEAD + "MOTION Frames: 4\nFrame Time: 0.04\n" + "\n".join(ROWS) + "\n")
    add("first motion row on the Frame Time line", bvh(ft="0.04 " + ROWS[0], rows=ROWS[1:]))
    add("two OFFSETs in a joint", bvh(HEAD.replace("OFFSET 0 12 0", "OFFSET 0 12 0\n\t\tOFFSET 0 1 0")))
    add("two CHANNELS in a joint", bvh(HEAD.replace("CHANNELS 3 Zrotation Xrotation Yrotation\n\t\tJOINT Neck",
                                                    "CHANNELS 3 Zrotation Xrotation Yrotation\n"
                                                    "CHANNELS 3 Zrotation Xrotation Yrotation\n\t\tJOINT Neck")))
    add("CHANNELS before OFFSET", bvh(HEAD.replace("\t\tOFFSET 0 12 0\n\t\tCHANNELS 3 Zrotation Xrotation Yrotation",
                                                   "\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n\t\tOFFSET 0 12 0")),
        "either")
    add("OFFSET after the child joint", bvh(HEAD.replace("\t\tOFFSET 0 12 0\n", "").replace(
        "\t\t\tEnd Site\n\t\t\t{\n\t\t\t\tOFFSET 0 4 0\n\t\t\t}\n\t\t}\n",
        "\t\t\tEnd Site\n\t\t\t{\n\t\t\t\tOFFSET 0 4 0\n\t\t\t}\n\t\t}\n\t\tOFFSET 0 12 0\n")), "either")
    add("CHANNELS after the child joint", bvh(HEAD.replace("\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n\t\tJOINT",
                                                           "\t\tJOINT").replace(
        "\t\t\t}\n\t\t}\n\t}\n\tJOINT Leg",
        "\t\t\t}\n\t\t}\n\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n\t}\n\tJOINT Leg")),
        "either")
    add("OFFSET on the ROOT line", bvh(HEAD.replace("ROOT Hips\n{\n\tOFFSET 0 0 0", "ROOT Hips OFFSET 0 0 0\n{")))
    add("brace on the JOINT line", bvh(HEAD.replace("JOINT Chest\n\t{", "JOINT Chest {")), "either")
    add("all on one line", bvh(" ".join(HEAD.split()) + "\n"), "either")
    add("closing brace on the OFFSET line", bvh(HEAD.replace("\t\t\t\tOFFSET 0 4 0\n\t\t\t}", "OFFSET 0 4 0 }")),
        "either")
    add("brace and joint on one line '}JOINT'", bvh(HEAD.replace("\t}\n\tJOINT Leg", "\t}JOINT Leg")))
    # the header is read as a stream of tokens (as most BVH readers do): line breaks inside a statement are fine
    add("OFFSET values on the next line", bvh(HEAD.replace("OFFSET 0 12 0", "OFFSET\n0 12 0")), "either")
    add("CHANNELS names on the next line", bvh(HEAD.replace("CHANNELS 3 Zrotation", "CHANNELS 3\nZrotation", 1)),
        "either")
    add("CHANNELS split over two lines", bvh(HEAD.replace("CHANNELS 3 Zrotation Xrotation Yrotation",
                                                          "CHANNELS 3 Zrotation\nXrotation Yrotation", 1)), "either")
    add("keyword HIERARCHY inside motion", bvh(rows=ROWS[:2] + ["HIERARCHY"] + ROWS[2:]))
    add("comment lines (#) in header", bvh(HEAD.replace("\tJOINT Chest", "# a comment\n\tJOINT Chest")))
    add("comment lines (//) in header", bvh(HEAD.replace("\tJOINT Chest", "// a comment\n\tJOINT Chest")))
    add("keyword in a name 'JOINT OFFSET'", bvh(HEAD.replace("JOINT Chest", "JOINT OFFSET")), "either")
    add("name '}'", bvh(HEAD.replace("JOINT Chest", "JOINT }")))
    add("name 'End'", bvh(HEAD.replace("JOINT Chest", "JOINT End")), "either")
    add("name 'Site'", bvh(HEAD.replace("JOINT Chest", "JOINT Site")), "either")
    add("name with multiple spaces", bvh(HEAD.replace("JOINT Chest", "JOINT Upper   Chest  Left")), "either")
    add("ROOT without name", bvh(HEAD.replace("ROOT Hips", "ROOT")))
    add("name 10,000 characters", bvh(HEAD.replace("JOINT Chest", "JOINT " + "C" * 10_000)), "either")
    add("name 2,000,000 characters", bvh(HEAD.replace("JOINT Chest", "JOINT " + "C" * 2_000_000)), "either")
    add("duplicate names in different branches", bvh(HEAD.replace("JOINT Leg", "JOINT Neck")))
    add("name equals End Site-ish 'End Site'", bvh(HEAD.replace("JOINT Leg", "JOINT End Site")), "either")
    add("joint name with a tab", bvh(HEAD.replace("JOINT Chest", "JOINT Ch\test")), "either")
    add("joint name with CR", bvh(HEAD.replace("JOINT Chest", "JOINT Ch\rest")), "either")
    add("joint name NUL", bvh(HEAD.replace("JOINT Chest", "JOINT Ch\x00est")))
    add("joint name with a quote and backslash", bvh(HEAD.replace("JOINT Chest", 'JOINT C"h\\est')), "either")
    # channels
    for spec, mode in [("CHANNELS 0", "either"), ("CHANNELS 7 Xposition Yposition Zposition Zrotation Xrotation "
                                                  "Yrotation Wrotation", "hostile"),
                       ("CHANNELS 4 Zrotation Xrotation Yrotation Xrotation", "hostile"),
                       ("CHANNELS 3 Xrotation Yrotation Xrotation", "either"),
                       ("CHANNELS 3 Zrotation Zrotation Zrotation", "hostile"),
                       ("CHANNELS 2 Zrotation Xrotation Yrotation", "hostile"),
                       ("CHANNELS 4 Zrotation Xrotation Yrotation", "hostile"),
                       ("CHANNELS 3 Xposition Xposition Yrotation", "hostile"),
                       ("CHANNELS 6 Zrotation Xrotation Yrotation Zrotation Xrotation Yrotation", "hostile"),
                       ("CHANNELS 12 " + " ".join(["Xrotation", "Yrotation", "Zrotation"] * 4), "hostile"),
                       ("CHANNELS 9999999 Zrotation Xrotation Yrotation", "hostile"),
                       ("CHANNELS -3 Zrotation Xrotation Yrotation", "hostile"),
                       ("CHANNELS 03 Zrotation Xrotation Yrotation", "either"),
                       ("CHANNELS 3.0 Zrotation Xrotation Yrotation", "either"),
                       ("CHANNELS \u0663 Zrotation Xrotation Yrotation", "hostile"),
                       ("CHANNELS Zrotation Xrotation Yrotation", "hostile"),
                       ("CHANNELS 3 Zrotation, Xrotation, Yrotation", "hostile"),
                       ("CHANNELS 3 Zrotation Xrotation Yposition", "either"),
                       ("CHANNELS 3 Zrotation Xrotation 3", "hostile"),
                       ("CHANNELS 3 Zrotation Xrotation Yrotation Extra", "hostile")]:
        add(f"Chest {spec[:60]}", bvh(HEAD.replace("CHANNELS 3 Zrotation Xrotation Yrotation", spec, 1)), mode)
    add("root CHANNELS 3 Xposition Yposition Zposition (no rotation)", bvh(HEAD.replace(
        "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
        "CHANNELS 3 Xposition Yposition Zposition"), rows=[" ".join(r.split()[:3] + r.split()[6:]) for r in ROWS]),
        "either")
    add("root CHANNELS 0", bvh(HEAD.replace("CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation",
                                            "CHANNELS 0"), rows=[" ".join(r.split()[6:]) for r in ROWS]), "either")
    add("every joint CHANNELS 0 and no values", bvh(re.sub(r"CHANNELS \d+[^\n]*", "CHANNELS 0", HEAD),
                                                    rows=[""] * 4), "either")
    # structure
    add("End Site with a JOINT inside", bvh(HEAD.replace("\t\t\t\tOFFSET 0 4 0\n", "\t\t\t\tOFFSET 0 4 0\n"
                                                         "JOINT x\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation "
                                                         "Yrotation\n}\n")))
    add("End Site with an End Site inside", bvh(HEAD.replace("\t\t\t\tOFFSET 0 4 0\n", "\t\t\t\tOFFSET 0 4 0\n"
                                                             "End Site\n{\nOFFSET 0 1 0\n}\n")))
    add("End Site named", bvh(HEAD.replace("End Site\n\t\t\t{", "End Site Tip\n\t\t\t{")), "either")
    add("End Site as the root", "HIERARCHY\nEnd Site\n{\nOFFSET 0 0 0\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n\n")
    add("root with only an End Site, no channels", "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\nEnd Site\n{\n"
        "OFFSET 0 1 0\n}\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n\n\n", "either")
    add("End Site before CHANNELS", bvh(HEAD.replace(
        "\t\tOFFSET 3 -2 0\n\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 -15 0\n"
        "\t\t}\n", "\t\tOFFSET 3 -2 0\n\t\tEnd Site\n\t\t{\n\t\t\tOFFSET 0 -15 0\n\t\t}\n"
        "\t\tCHANNELS 3 Zrotation Xrotation Yrotation\n")), "either")
    add("OFFSET with 1 number", bvh(HEAD.replace("OFFSET 3 -2 0", "OFFSET 3")))
    add("OFFSET with 0 numbers", bvh(HEAD.replace("OFFSET 3 -2 0", "OFFSET")))
    add("OFFSET with 6 numbers", bvh(HEAD.replace("OFFSET 3 -2 0", "OFFSET 3 -2 0 1 1 1")))
    add("End Site OFFSET with 2 numbers", bvh(HEAD.replace("OFFSET 0 -15 0", "OFFSET 0 -15")))
    add("End Site OFFSET with 4 numbers", bvh(HEAD.replace("OFFSET 0 -15 0", "OFFSET 0 -15 0 0")))
    add("unbalanced: two extra {", bvh(HEAD.replace("JOINT Leg\n\t{", "JOINT Leg\n\t{\n{\n{")))
    add("unbalanced: one missing } in the middle", bvh(HEAD.replace("\t\t}\n\t}\n\tJOINT Leg", "\t\t}\n\tJOINT Leg")))
    add("unbalanced: extra } in the middle", bvh(HEAD.replace("\t}\n\tJOINT Leg", "\t}\n}\n\tJOINT Leg")))
    add("unbalanced: no braces at all", bvh(HEAD.replace("{", "").replace("}", "")))
    add("braces only", "HIERARCHY\nROOT a\n" + "{" * 200_000 + "}" * 200_000
        + "\nMOTION\nFrames: 1\nFrame Time: 0.1\n0\n")
    add("100,000 nested '{'", "HIERARCHY\nROOT a\n" + "{\n" * 100_000 + "MOTION\nFrames: 1\nFrame Time: 0.1\n0\n")
    add("100,000 '}'", bvh(HEAD + "}\n" * 100_000))
    deep = ("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 0\n" + "JOINT j\n{\nOFFSET 0 1 0\nCHANNELS 0\n" * 100_000
            + "}\n" * 100_001 + "MOTION\nFrames: 1\nFrame Time: 0.1\n\n")
    add("100,000-deep chain of identical names", deep)
    deep2 = ("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 0\n" + "".join(
        f"JOINT j{k}\n{{\nOFFSET 0 1 0\nCHANNELS 0\n" for k in range(100_000)) + "}\n" * 100_001
        + "MOTION\nFrames: 1\nFrame Time: 0.1\n\n")
    add("100,000-deep chain, 0 channels", deep2)
    wide = ("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 0\n" + "".join(
        f"JOINT j{k}\n{{\nOFFSET 1 0 0\nCHANNELS 0\n}}\n" for k in range(100_000)) + "}\n"
        + "MOTION\nFrames: 1\nFrame Time: 0.1\n\n")
    add("100,000 siblings, 0 channels", wide)
    wide_es = ("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 0\n" + "End Site\n{\nOFFSET 0 1 0\n}\n" * 100_000
               + "}\nMOTION\nFrames: 1\nFrame Time: 0.1\n\n")
    add("100,000 End Sites under the root", wide_es)
    add("1,000,000 blank header lines", bvh(HEAD.replace("\tJOINT Chest", "\n" * 1_000_000 + "\tJOINT Chest")),
        "either")
    add("Frames: 50,000,000 x 15 channels and 4 lines", bvh(frames="50000000"))
    add("Frames: 1 with 10 MB single line", bvh(frames="1", rows=["1 " * 5_000_000]))
    add("1,000,000 frames of one channel (2 MB)", "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 1 "
        "Zrotation\n}\nMOTION\nFrames: 1000000\nFrame Time: 0.01\n" + "1\n" * 1_000_000, "either")
    # line ends, encodings
    base = bvh()
    add("mixed CRLF/LF/CR", "".join(ln + ("\r\n", "\n", "\r")[k % 3] for k, ln in enumerate(base.split("\n"))),
        "either")
    add("LF CR (reversed CRLF)", base.replace("\n", "\n\r"), "either")
    add("CR CR LF", base.replace("\n", "\r\r\n"), "either")
    add("U+2028 line separators", base.replace("\n", "\u2028"), "either")
    add("NEL line ends", base.replace("\n", "\u0085"), "either")
    add("form feed line ends", base.replace("\n", "\x0c"), "either")
    add("vertical tab line ends", base.replace("\n", "\x0b"), "either")
    add("NBSP separators in motion", bvh(rows=[r.replace(" ", "\u00a0") for r in ROWS]), "either")
    add("thin space separators in motion", bvh(rows=[r.replace(" ", "\u2009") for r in ROWS]), "either")
    add("NBSP separators in the header", bvh(HEAD.replace(" ", "\u00a0")), "either")
    add("ideographic spaces in the header", bvh(HEAD.replace(" ", "\u3000")), "either")
    add("UTF-16-LE with BOM", base.encode("utf-16-le").join([b"\xff\xfe", b""]), "either")
    add("UTF-16-BE with BOM", b"\xfe\xff" + base.encode("utf-16-be"), "either")
    add("UTF-16-LE without BOM", base.encode("utf-16-le"), "either")
    add("UTF-8 BOM twice", b"\xef\xbb\xbf\xef\xbb\xbf" + base.encode(), "either")
    add("UTF-8 BOM before MOTION", bvh(motion="\ufeffMOTION"), "either")
    add("Latin-1 name and CRLF", bvh(HEAD.replace("Chest", "Br\xfcst")).replace("\n", "\r\n").encode("latin-1"),
        "either")
    add("cp1252 smart quotes in a name", bvh(HEAD.replace("Chest", "\u201cChest\u201d")).encode("cp1252"), "either")
    add("invalid UTF-8 in a name", bvh(HEAD).encode().replace(b"Chest", b"Ch\xc3\x28st"), "either")
    add("overlong UTF-8 NUL in a name", bvh(HEAD).encode().replace(b"Chest", b"Ch\xc0\x80st"), "either")
    add("NUL bytes in the header", bvh(HEAD.replace("JOINT Chest", "JOINT\x00Chest")))
    add("NUL padding at the end", base.encode() + b"\x00" * 4096, "either")
    add("Ctrl-Z at the end (DOS EOF)", base + "\x1a", "either")
    add("trailing junk after the motion", base + "this is junk\n")
    add("trailing numbers after the motion", base + " ".join(["0"] * NCH) + "\n")
    add("trailing HIERARCHY after the motion", base + HEAD)
    add("trailing 1 MB of spaces", base + " " * (1 << 20), "either")
    add("motion line too long by 1", bvh(rows=ROWS[:3] + [ROWS[3] + " 1"]))
    add("motion line too short by 1", bvh(rows=ROWS[:3] + [ROWS[3].rsplit(" ", 1)[0]]))
    add("first motion line too short", bvh(rows=[ROWS[0].rsplit(" ", 1)[0]] + ROWS[1:]))
    add("two frames on one line", bvh(rows=[ROWS[0] + " " + ROWS[1]] + ROWS[2:], frames="4"))
    add("Frames: 0 with rows", bvh(frames="0"))
    add("Frames: 0 without rows", bvh(frames="0", rows=[]), "either")
    add("Frames: 1 with 0 rows", bvh(frames="1", rows=[]))
    add("MOTION only, empty hierarchy", "HIERARCHY\nMOTION\nFrames: 1\nFrame Time: 0.1\n\n")
    add("tabs everywhere incl. keyword separators", bvh(HEAD.replace(" ", "\t"), fr="Frames:\t", ftk="Frame\tTime:"),
        "either")
    return c


def bvh_odd_valid():
    """(name, bytes, edit joint) of odd but valid rigs: read, edit, export, re-read within 1e-5 of height."""
    c = []

    def rig(channels_of, offsets=None, names=("Hips", "A", "B"), frames=5, rng_seed=0):
        """A chain Hips -> A -> B (+ End Site) with the given channel names per joint."""
        offsets = offsets or [(0, 0, 0), (0, 10, 0), (0, 8, 2)]
        rng = np.random.default_rng(rng_seed)
        lines = ["HIERARCHY"]
        depth = 0
        for j, (name, chans) in enumerate(zip(names, channels_of)):
            lines.append("\t" * depth + ("ROOT " if j == 0 else "JOINT ") + name)
            lines.append("\t" * depth + "{")
            lines.append("\t" * (depth + 1) + "OFFSET " + " ".join(repr(float(v)) for v in offsets[j]))
            lines.append("\t" * (depth + 1) + f"CHANNELS {len(chans)} " + " ".join(chans))
            depth += 1
        lines += ["\t" * depth + "End Site", "\t" * depth + "{", "\t" * (depth + 1) + "OFFSET 0 5 0",
                  "\t" * depth + "}"]
        for d in range(depth - 1, -1, -1):
            lines.append("\t" * d + "}")
        n = sum(len(ch) for ch in channels_of)
        vals = rng.uniform(-60, 60, (frames, n))
        text = "\n".join(lines) + f"\nMOTION\nFrames: {frames}\nFrame Time: 0.0333333\n"
        text += "\n".join(" ".join(f"{v:.6f}" for v in row) for row in vals) + "\n"
        return text.encode()
    P = ["Xposition", "Yposition", "Zposition"]
    R = {o: [f"{a}rotation" for a in o] for o in ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")}
    for o in R:
        c.append((f"{o} order everywhere", rig([P + R[o], R[o], R[o]]), "A"))
    c.append(("mixed orders per joint", rig([P + R["ZYX"], R["YXZ"], R["XZY"]]), "B"))
    c.append(("rotation first, positions last on root", rig([R["YZX"] + P, R["XYZ"], R["ZXY"]]), "A"))
    c.append(("positions interleaved with rotations", rig([["Zrotation", "Xposition", "Yrotation", "Yposition",
                                                           "Xrotation", "Zposition"], R["XYZ"], R["XYZ"]]), "A"))
    c.append(("1-channel Xrotation joint edited about y and z", rig([P + R["ZXY"], ["Xrotation"], R["ZXY"]]), "A"))
    c.append(("1-channel Yrotation joint edited", rig([P + R["ZXY"], ["Yrotation"], ["Zrotation"]]), "A"))
    c.append(("2-channel ZX joint edited", rig([P + R["ZXY"], ["Zrotation", "Xrotation"], R["ZXY"]]), "A"))
    c.append(("2-channel XY leaf edited", rig([P + R["ZXY"], R["ZXY"], ["Xrotation", "Yrotation"]]), "B"))
    c.append(("root with rotations only (no position)", rig([R["ZXY"], R["ZXY"], R["ZXY"]]), "A"))
    c.append(("root with one rotation channel", rig([P + ["Yrotation"], R["ZXY"], R["ZXY"]]), "Hips"))
    c.append(("root with positions only, edited root", rig([P, R["ZXY"], R["ZXY"]]), "Hips"))
    c.append(("root with 2 position channels", rig([["Xposition", "Zposition"] + R["ZXY"], R["ZXY"], R["ZXY"]]),
              "A"))
    c.append(("position channels on children", rig([P + R["ZXY"], P + R["XYZ"], ["Yposition"] + R["YXZ"]]), "B"))
    c.append(("child with positions only", rig([P + R["ZXY"], P, R["ZXY"]]), "B"))
    c.append(("child with zero channels edited", rig([P + R["ZXY"], [], R["ZXY"]]), "A"))
    c.append(("zero-length bones", rig([P + R["ZXY"], R["ZXY"], R["ZXY"]], offsets=[(0, 0, 0)] * 3), "A"))
    c.append(("all offsets zero, end site zero", rig([P + R["ZXY"], R["ZXY"], R["ZXY"]],
                                                     offsets=[(0, 0, 0)] * 3).replace(b"OFFSET 0 5 0",
                                                                                       b"OFFSET 0 0 0"), "A"))
    c.append(("tiny units (1e-6)", rig([P + R["ZXY"], R["ZXY"], R["ZXY"]],
                                       offsets=[(0, 0, 0), (0, 1e-6, 0), (0, 1e-6, 1e-7)]), "A"))
    c.append(("huge units (1e6)", rig([P + R["ZXY"], R["ZXY"], R["ZXY"]],
                                      offsets=[(0, 0, 0), (0, 1e6, 0), (0, 1e6, 3e5)]), "A"))
    c.append(("one frame", rig([P + R["ZXY"], R["ZXY"], R["ZXY"]], frames=1), "A"))
    c.append(("two frames", rig([P + R["ZXY"], R["ZXY"], R["ZXY"]], frames=2), "A"))
    one = b"HIERARCHY\nROOT only\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation " \
          b"Yrotation\nEnd Site\n{\nOFFSET 0 10 0\n}\n}\nMOTION\nFrames: 3\nFrame Time: 0.05\n1 2 3 10 20 30\n" \
          b"2 3 4 11 21 31\n3 4 5 12 22 32\n"
    c.append(("single-joint rig with End Site", one, "only"))
    c.append(("single-joint rig without End Site", one.replace(b"End Site\n{\nOFFSET 0 10 0\n}\n", b""), "only"))
    c.append(("single-joint rig, 1 frame", one.replace(b"Frames: 3", b"Frames: 1").rsplit(b"\n", 3)[0] + b"\n",
              "only"))
    c.append(("single joint, one rotation channel", b"HIERARCHY\nROOT only\n{\nOFFSET 0 0 0\nCHANNELS 1 Zrotation\n"
              b"End Site\n{\nOFFSET 0 10 0\n}\n}\nMOTION\nFrames: 2\nFrame Time: 0.05\n10\n20\n", "only"))
    c.append(("angles near gimbal lock (Y = 90)", rig([P + R["XYZ"], R["XYZ"], R["XYZ"]]).replace(
        b"\nFrame Time: 0.0333333\n", b"\nFrame Time: 0.0333333\n") if False else _gimbal(), "A"))
    return c


def _ops_for_rig(joint: str) -> list[dict]:
    """Every op with valid parameters, aimed at ``joint`` of an odd rig."""
    return [{"op": "extract"}, {"op": "cull", "percent": 50}, {"op": "cull", "count": 2},
            {"op": "succession", "root": joint, "s": 0.02, "l": 2.0},
            {"op": "random_timing", "tau": 0.02, "seed": 3}, {"op": "exaggerate", "w_r": 1.5},
            {"op": "edit_pose", "pose": 0, "deltas": {joint: [10, 20, 30]}},
            {"op": "retime", "pose": 1, "time": 0.05}, {"op": "insert_pose", "time": 0.05},
            {"op": "delete_pose", "pose": 1}, {"op": "keep_contacts"},
            {"op": "ik_pose", "pose": 0, "joint": joint, "target": [1, 5, 1]},
            {"op": "edit_frame", "frame": 0, "deltas": {joint: [10, 20, 30]}},
            {"op": "propagate", "frame": 0, "deltas": {joint: [10, 20, 30]}},
            {"op": "guided_warp", "duration": 0.1}, {"op": "linear_warp", "duration": 0.1},
            {"op": "resample", "frame_time": 0.01}]


def _gimbal():
    return (b"HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation "
            b"Zrotation\nJOINT A\n{\nOFFSET 0 10 0\nCHANNELS 3 Xrotation Yrotation Zrotation\nEnd Site\n{\nOFFSET 0 5 "
            b"0\n}\n}\n}\nMOTION\nFrames: 3\nFrame Time: 0.04\n0 0 0 30 90 40 10 90 -20\n0 0 0 31 -90 40 10 89.9999 0\n"
            b"0 0 0 -179.99 90 179.99 0 90 0\n")


# --------------------------------------------------------------------------------------------------
# ASF / AMC material
# --------------------------------------------------------------------------------------------------
ASF = ("# a comment\n:version 1.10\n:name heldout\n:units\n  mass 1.0\n  length 0.45\n  angle deg\n:documentation\n"
       "  held-out corpus\n" + ASF_ROOT + ":bonedata\n"
       + asf_bone(1, "lhipjoint", "0.6 -0.7 0.3", 2.4, "0 0 -20 XYZ")
       + asf_bone(2, "lfemur", "0.34 -0.93 0", 7.1, "0 0 20 XYZ", "rx ry rz", FEMUR_LIMITS)
       + asf_bone(3, "lowerback", "0 1 0", 2, "0 0 0 XYZ", "rx ry rz", ("(-20 20)",) * 3)
       + ":hierarchy\n  begin\n    root lhipjoint lowerback\n    lhipjoint lfemur\n  end\n")
AMC = ":FULLY-SPECIFIED\n:DEGREES\n" + "".join(
    f"{f}\nroot {f} 16 {f} 1 2 3\nlfemur 10 20 {f}\nlowerback 1 2 {f}\n" for f in range(1, 5))


def amc_cases():
    c = []

    def a(name, asf=ASF, amc=AMC, mode="hostile"):
        c.append((name, asf, amc, mode))
    for name, v in [("hex float", "0x1p3"), ("1..2", "1..2"), ("U+2212", "\u22121"), ("NBSP inside", "1\u00a02"),
                    ("1e400", "1e400"), ("-nan", "-nan"), ("Devanagari", "\u0969"), ("superscript", "\u00b2"),
                    ("1e", "1e"), (".", "."), ("-", "-"), ("1.#INF", "1.#INF"), ("full-width 1", "\uff11"),
                    ("400 digits", "1" * 400), ("surrogate", "\udc80")]:
        a(f"AMC value {name}", amc=AMC.replace("lfemur 10 20 2", f"lfemur 10 {v} 2", 1))
        a(f"AMC root value {name}", amc=AMC.replace("root 3 16 3", f"root 3 {v} 3", 1))
        a(f"ASF length {name}", ASF.replace("length 7.1", f"length {v}"))
        a(f"ASF direction {name}", ASF.replace("direction 0 1 0", f"direction 0 {v} 0"))
        a(f"ASF axis {name}", ASF.replace("axis 0 0 20 XYZ", f"axis 0 {v} 20 XYZ"))
        a(f"ASF root position {name}", ASF.replace("position 0 0 0", f"position 0 {v} 0"))
        a(f"ASF units length {name}", ASF.replace("length 0.45", f"length {v}"))
        a(f"AMC frame number {name}", amc=AMC.replace("\n3\n", f"\n{v}\n"))
    a("ASF units length 0", ASF.replace("length 0.45", "length 0"))
    a("ASF units length -1", ASF.replace("length 0.45", "length -1"))
    a("ASF units mass nan", ASF.replace("mass 1.0", "mass nan"), mode="either")
    a("ASF angle rad", ASF.replace("angle deg", "angle rad"), mode="either")
    a("ASF angle DEG", ASF.replace("angle deg", "angle DEG"), mode="either")
    a("ASF :units missing", ASF.replace(":units\n  mass 1.0\n  length 0.45\n  angle deg\n", ""), mode="either")
    a("ASF :hierarchy missing", ASF.split(":hierarchy")[0])
    a("ASF :hierarchy without begin", ASF.replace(":hierarchy\n  begin\n", ":hierarchy\n"))
    a("ASF :hierarchy without end", ASF.rsplit("  end", 1)[0])
    a("ASF glued comment 7.1#cm", ASF.replace("length 7.1", "length 7.1#cm"))
    a("ASF two :root sections", ASF.replace(":bonedata", ":root\n  order TX TY TZ RX RY RZ\n:bonedata"))
    a("ASF :bonedata twice", ASF.replace(":hierarchy", ":bonedata\n  begin\n    id 9\n    name x\n    direction 0 1 0"
                                              "\n    length 1\n    axis 0 0 0 XYZ\n  end\n:hierarchy"))
    a("ASF bone without name", ASF.replace("    name lowerback\n", ""))
    a("ASF bone without direction", ASF.replace("    direction 0 1 0\n", ""))
    a("ASF bone without length", ASF.replace("    length 2\n", ""))
    a("ASF bone name with space", ASF.replace("name lowerback", "name lower back"))
    a("ASF bone named root", ASF.replace("name lowerback", "name root").replace("lhipjoint lowerback",
                                                                                "lhipjoint root"))
    a("ASF dof listed twice", ASF.replace("    dof rx ry rz\n    limits (-20 20)", "    dof rx ry rz\n    dof rx\n"
                                          "    limits (-20 20)"))
    a("ASF dof 'l' only", ASF.replace("dof rx ry rz\n    limits (-20 20)\n           (-20 20)\n           (-20 20)",
                                      "dof l\n    limits (-1 1)"), mode="either")
    a("ASF dof tx on a bone", ASF.replace("dof rx ry rz\n    limits (-20 20)\n           (-20 20)\n"
                                          "           (-20 20)", "dof tx ty tz\n    limits (-1 1)\n (-1 1)\n (-1 1)"),
      mode="either")
    a("ASF limits fewer than dofs", ASF.replace("           (-70.0 70.0)\n           (-60.0 70.0)\n", ""),
      mode="either")
    a("ASF limits malformed", ASF.replace("(-160.0 20.0)", "(-160.0, 20.0"), mode="either")
    a("ASF limits inf", ASF.replace("(-160.0 20.0)", "(-inf inf)"), mode="either")
    a("ASF root order 5 items", ASF.replace("order TX TY TZ RX RY RZ", "order TX TY TZ RX RY"))
    a("ASF root order repeated", ASF.replace("order TX TY TZ RX RY RZ", "order TX TX TZ RX RY RZ"))
    a("ASF root order 'RW'", ASF.replace("order TX TY TZ RX RY RZ", "order TX TY TZ RX RY RW"))
    a("ASF root axis 'XYX'", ASF.replace("  axis XYZ\n", "  axis XYX\n"))
    a("ASF root axis 'xyz'", ASF.replace("  axis XYZ\n", "  axis xyz\n"), mode="either")
    a("ASF axis order lower-case", ASF.replace("axis 0 0 20 XYZ", "axis 0 0 20 zyx"), mode="either")
    a("ASF axis missing order", ASF.replace("axis 0 0 20 XYZ", "axis 0 0 20"))
    a("ASF direction zero vector", ASF.replace("direction 0.34 -0.93 0", "direction 0 0 0"), mode="either")
    a("ASF direction 1e300", ASF.replace("direction 0.34 -0.93 0", "direction 1e300 1e300 0"), mode="either")
    a("ASF length 1e300", ASF.replace("length 7.1", "length 1e300"), mode="either")
    a("ASF length negative", ASF.replace("length 7.1", "length -7.1"), mode="either")
    a("ASF hierarchy line names root twice", ASF.replace("root lhipjoint lowerback", "root lhipjoint lhipjoint"))
    a("ASF bone listed in two parents", ASF.replace("    lhipjoint lfemur\n", "    lhipjoint lfemur\n"
                                                    "    lowerback lfemur\n"))
    a("ASF bone never in the hierarchy", ASF.replace("root lhipjoint lowerback", "root lhipjoint"), mode="either")
    a("ASF CRLF", ASF.replace("\n", "\r\n"), AMC.replace("\n", "\r\n"), mode="either")
    a("ASF CR only", ASF.replace("\n", "\r"), AMC.replace("\n", "\r"), mode="either")
    a("ASF tabs", ASF.replace("  ", "\t"), AMC.replace(" ", "\t"), mode="either")
    a("ASF UTF-8 BOM", "\ufeff" + ASF, "\ufeff" + AMC, mode="either")
    a("ASF keywords misspelled :bonedta", ASF.replace(":bonedata", ":bonedta"))
    a("ASF keywords misspelled :hierachy", ASF.replace(":hierarchy", ":hierachy"))
    a("ASF keyword 'begin' misspelled", ASF.replace("  begin\n    id 3", "  begn\n    id 3"))
    a("ASF keyword 'direction' misspelled", ASF.replace("direction 0 1 0", "dirction 0 1 0"))
    a("ASF unknown section", ASF.replace(":bonedata", ":weird\n  stuff\n:bonedata"), mode="either")
    a("ASF 100,000 bones siblings", ASF.replace(":hierarchy", "".join(
        f"  begin\n    id {k}\n    name b{k}\n    direction 0 1 0\n    length 1\n    axis 0 0 0 XYZ\n  end\n"
        for k in range(10, 100_010)) + ":hierarchy").replace("root lhipjoint lowerback",
                                                            "root lhipjoint lowerback " + " ".join(
                                                                f"b{k}" for k in range(10, 100_010))))
    a("AMC :RADIANS header", amc=AMC.replace(":DEGREES", ":RADIANS"), mode="either")
    a("AMC no header", amc=AMC.replace(":FULLY-SPECIFIED\n:DEGREES\n", ""), mode="either")
    a("AMC frame numbers start at 0", amc=AMC.replace("\n1\n", "\n0\n", 1).replace("\n2\n", "\n1\n", 1).replace(
        "\n3\n", "\n2\n", 1).replace("\n4\n", "\n3\n", 1), mode="either")
    a("AMC frame number repeated", amc=AMC.replace("\n3\n", "\n2\n"))
    a("AMC frame number 1.0", amc=AMC.replace("\n2\n", "\n2.0\n"))
    a("AMC frame number +2", amc=AMC.replace("\n2\n", "\n+2\n"), mode="either")
    a("AMC frame number 02", amc=AMC.replace("\n2\n", "\n02\n"), mode="either")
    a("AMC frame number then junk", amc=AMC.replace("\n2\n", "\n2 x\n"))
    a("AMC frame with no bones", amc=AMC.replace("root 2 16 2 1 2 3\nlfemur 10 20 2\nlowerback 1 2 2\n", ""))
    a("AMC frame missing one bone", amc=AMC.replace("lowerback 1 2 2\n", ""), mode="either")
    a("AMC bone with dof in ASF but 0 values", amc=AMC.replace("lfemur 10 20 2", "lfemur"))
    a("AMC value for a dof-less bone", amc=AMC.replace("lfemur 10 20 2\n", "lfemur 10 20 2\nlhipjoint 5\n"))
    a("AMC root 5 values", amc=AMC.replace("root 2 16 2 1 2 3", "root 2 16 2 1 2"))
    a("AMC root 7 values", amc=AMC.replace("root 2 16 2 1 2 3", "root 2 16 2 1 2 3 4"))
    a("AMC bone names case", amc=AMC.replace("lfemur 10 20 2", "LFEMUR 10 20 2"))
    a("AMC 1e6 frames declared by numbering", amc=AMC + "1000000\nroot 0 0 0 0 0 0\n")
    a("AMC 20 MB of one line", amc=AMC.replace("lowerback 1 2 2", "lowerback " + "1 " * 10_000_000, 1))
    a("AMC NUL bytes", amc=AMC.replace("lfemur 10 20 2", "lfemur 10\x0020 2"))
    a("AMC UTF-16", amc=None)  # written as UTF-16 by the runner
    a("AMC comment lines", amc="# comment\n" + AMC, mode="either")
    a("AMC trailing junk", amc=AMC + "junk here\n")
    a("AMC 1e9 frames sparse", amc=AMC.replace("\n4\n", "\n999999999\n"))
    return c


# --------------------------------------------------------------------------------------------------
# session material
# --------------------------------------------------------------------------------------------------
GOOD = op_examples("Chest", "Neck", 0.5)   # every op with a valid example (the corpus's builder, other joints)
EXTRA_FIELDS = {  # optional fields beyond the required examples, each given hostile values too
    "succession": {"joints": ["Chest"]}, "random_timing": {"joints": ["Chest"]},
    "exaggerate": {"poses": [0], "reference": "previous", "mode": "staggered", "joints": ["Chest"]},
    "edit_pose": {"mode": "staggered"}, "propagate": {"sigma": 1.0, "frame_range": [0, 10]},
    "guided_warp": {"skip": 4, "keytimes": [[0.2, 0.3]]}, "linear_warp": {"keytimes": [[0.2, 0.3]]},
    "cull": {"count": 3},
}
HOSTILE_VALUES = [1.5, -0.0, 2 ** 63, -(2 ** 63), 2 ** 64, 1e-320, -1e-320, 1e300, -1e300, 123456789,
                  "Chest ", "chest", "0", "1e3", "\x00", "\u202eChest", [None], [1, "a"], [[0, 0]], {"": 0},
                  {"Chest": None}, {"Chest": [0, 0]}, {"Chest": [0, 0, 0, 0]}, {"Chest": [1e300, 1e300, 1e300]},
                  {"Chest": "010"}, {"Nope": [0, 0, 1]}, [0.2, 0.3], [[0.3, 0.2, 0.1]], [[1e9, 1e9]],
                  [[-1, 0.1]], [["0.1", "0.2"]], ["previous"], "next", "nearest", "STAGGERED", [True]]


def session_cases(src: str, tmp: Path, sess_self: Path):
    """(name, text/bytes/obj, mode) for Session.load + edited + export."""
    doc = lambda ops, **kw: {"format": "stagger_nb.session", "version": 1, "source": {"path": src},  # noqa: E731
                             "extract_options": {}, "ops": ops, **kw}
    c = []

    def add(name, d, mode="hostile"):
        c.append((name, d, mode))
    for op, good in GOOD.items():
        fields = {**good, **EXTRA_FIELDS.get(op, {})}
        for f in fields:
            for v in HOSTILE_VALUES:
                if op == "cull" and f in ("percent", "count"):
                    o = {"op": "cull", f: v}
                else:
                    o = {"op": op, **good, f: v}
                add(f"{op}.{f} = {v!r}"[:90], doc([o]), "either")
    # valid-looking ops, hostile in context
    add("succession root not a joint", doc([{"op": "succession", "root": "Tail", "s": 0.03}]))
    add("succession joints not in the rig", doc([{"op": "succession", "root": "Chest", "s": 0.03,
                                                  "joints": ["Tail"]}]))
    add("succession l 1e-300", doc([{"op": "succession", "root": "Chest", "s": 0.03, "l": 1e-300}]), "either")
    add("succession s 59.9", doc([{"op": "succession", "root": "Chest", "s": 59.9}]), "either")
    add("random_timing tau 59", doc([{"op": "random_timing", "tau": 59}]), "either")
    add("random_timing joints empty list", doc([{"op": "random_timing", "tau": 0.05, "joints": []}]), "either")
    add("exaggerate w_r 99 on pose 0", doc([{"op": "exaggerate", "w_r": 99, "poses": [0]}]), "either")
    add("exaggerate poses 10**6", doc([{"op": "exaggerate", "w_r": 2, "poses": [10 ** 6]}]))
    add("exaggerate reference pose 10**6", doc([{"op": "exaggerate", "w_r": 2, "reference": 10 ** 6}]))
    add("exaggerate reference -1", doc([{"op": "exaggerate", "w_r": 2, "reference": -1}]))
    add("cull then edit_pose beyond the culled", doc([{"op": "cull", "count": 2},
                                                      {"op": "edit_pose", "pose": 5, "deltas": {"Chest": [0, 0, 1]}}]))
    add("delete_pose every pose", doc([{"op": "delete_pose", "pose": 0}] * 40))
    add("insert_pose beyond the end", doc([{"op": "insert_pose", "time": 59}]))
    add("insert_pose at an existing pose time", doc([{"op": "insert_pose", "time": 0.0}] * 3), "either")
    add("retime pose past the end", doc([{"op": "retime", "pose": 1, "time": 50}]))
    add("retime pose 0 after pose 1", doc([{"op": "retime", "pose": 0, "time": 0.5}]), "either")
    add("ik_pose joint is the root", doc([{"op": "ik_pose", "pose": 0, "joint": "Hips", "target": [0, 0, 0]}]),
        "either")
    add("ik_pose target 1e300", doc([{"op": "ik_pose", "pose": 0, "joint": "Neck", "target": [1e300, 0, 0]}]),
        "either")
    add("ik_pose target unreachable", doc([{"op": "ik_pose", "pose": 0, "joint": "Neck", "target": [1e4, 0, 0]}]),
        "either")
    add("edit_frame frame == F", doc([{"op": "edit_frame", "frame": 30, "deltas": {"Chest": [0, 0, 1]}}]))
    add("edit_frame after resample past the end", doc([{"op": "resample", "frame_time": 0.2},
                                                       {"op": "edit_frame", "frame": 20,
                                                        "deltas": {"Chest": [0, 0, 1]}}]))
    add("propagate frames list with duplicates", doc([{"op": "propagate", "frames": [1, 1],
                                                       "deltas": [{"Chest": [0, 0, 1]}, {"Chest": [0, 0, 2]}]}]),
        "either")
    add("propagate frames and deltas lengths differ", doc([{"op": "propagate", "frames": [1, 2],
                                                            "deltas": [{"Chest": [0, 0, 1]}]}]))
    add("propagate frame and frames", doc([{"op": "propagate", "frame": 1, "frames": [2],
                                            "deltas": {"Chest": [0, 0, 1]}}]))
    add("propagate frame_range outside", doc([{"op": "propagate", "frame": 1, "frame_range": [100, 200],
                                               "deltas": {"Chest": [0, 0, 1]}}]))
    add("propagate frame outside its frame_range", doc([{"op": "propagate", "frame": 1, "frame_range": [5, 20],
                                                         "deltas": {"Chest": [0, 0, 1]}}]))
    add("propagate sigma 1e300", doc([{"op": "propagate", "frame": 1, "sigma": 1e300,
                                       "deltas": {"Chest": [0, 0, 1]}}]), "either")
    add("propagate sigma 5e-324", doc([{"op": "propagate", "frame": 1, "sigma": 5e-324,
                                        "deltas": {"Chest": [0, 0, 1]}}]), "either")
    add("guided_warp duration 1e5", doc([{"op": "guided_warp", "duration": 1e5}]))
    add("guided_warp duration 59", doc([{"op": "guided_warp", "duration": 59}]), "either")
    add("guided_warp duration 1e-3 (0 frames)", doc([{"op": "guided_warp", "duration": 1e-3}]), "either")
    add("guided_warp keytimes past the end", doc([{"op": "guided_warp", "duration": 0.5,
                                                   "keytimes": [[5.0, 0.1]]}]))
    add("guided_warp keytimes equal", doc([{"op": "guided_warp", "duration": 0.5,
                                            "keytimes": [[0.2, 0.2], [0.2, 0.2]]}]))
    add("guided_warp reference is the session file itself", doc([{"op": "guided_warp", "duration": 0.5,
                                                                  "reference": {"path": str(sess_self)}}]))
    add("guided_warp reference relative ../..", doc([{"op": "guided_warp", "duration": 0.5,
                                                      "reference": {"path": "../../../../../../etc/passwd"}}]))
    add("guided_warp reference /proc/self/status", doc([{"op": "guided_warp", "duration": 0.5,
                                                         "reference": {"path": "/proc/self/status"}}]))
    add("guided_warp reference /proc/self/pagemap", doc([{"op": "guided_warp", "duration": 0.5,
                                                          "reference": {"path": "/proc/self/pagemap"}}]))
    add("guided_warp reference /dev/urandom", doc([{"op": "guided_warp", "duration": 0.5,
                                                    "reference": {"path": "/dev/urandom"}}]))
    add("guided_warp reference a socket", doc([{"op": "guided_warp", "duration": 0.5,
                                                "reference": {"path": str(tmp / "sock")}}]))
    add("guided_warp reference a FIFO", doc([{"op": "guided_warp", "duration": 0.5,
                                              "reference": {"path": str(tmp / "fifo")}}]))
    add("guided_warp reference unreadable file", doc([{"op": "guided_warp", "duration": 0.5,
                                                       "reference": {"path": str(tmp / "unreadable.bvh")}}]),
        "either" if os.getuid() == 0 else "hostile")
    add("guided_warp reference empty path", doc([{"op": "guided_warp", "duration": 0.5, "reference": {"path": ""}}]))
    add("guided_warp reference path with NUL", doc([{"op": "guided_warp", "duration": 0.5,
                                                     "reference": {"path": "a\x00b"}}]))
    add("guided_warp reference path 5000 chars", doc([{"op": "guided_warp", "duration": 0.5,
                                                       "reference": {"path": "a" * 5000}}]))
    add("guided_warp reference embedded 1-joint motion", doc([{"op": "guided_warp", "duration": 0.5, "reference": {
        "motion": {"names": ["a"], "parents": [-1], "offsets": [[0, 0, 0]], "channels": [["Zrotation"]],
                   "end_sites": {}, "frame_time": 0.1, "root_positions": [[0, 0, 0]] * 3,
                   "local_quats": [[[0, 0, 0, 1]]] * 3}}}]), "either")
    add("linear_warp duration 1e5", doc([{"op": "linear_warp", "duration": 1e5}]))
    add("linear_warp keytimes beyond", doc([{"op": "linear_warp", "duration": 0.5, "keytimes": [[3.0, 0.1]]}]))
    add("resample frame_time 59", doc([{"op": "resample", "frame_time": 59}]), "either")
    add("resample frame_time 1e-5", doc([{"op": "resample", "frame_time": 1e-5}]))
    add("resample then extract many times", doc([{"op": "resample", "frame_time": 0.01}, {"op": "extract"},
                                                 {"op": "cull", "percent": 50}] * 3), "either")
    add("4,000 edit_frame ops", doc([{"op": "edit_frame", "frame": k % 30, "deltas": {"Chest": [0, 0, 0.01]}}
                                     for k in range(4000)]), "either")
    add("20,000 keep_contacts ops", doc([{"op": "keep_contacts"}] * 20_000), "either")
    add("100,001 ops", doc([{"op": "keep_contacts"}] * 100_001))
    # extract_options
    for key, vals in {"iterations": [-1, 1e9, 1.5, "x", 10 ** 30], "filter_width": [-1, 1e9, "x"],
                      "bogus": [1], "": [1], "smoothing": [1e9, -1, None]}.items():
        for v in vals:
            add(f"extract_options.{key} = {v!r}", doc([{"op": "cull", "percent": 50}], extract_options={key: v}),
                "either" if key in ("smoothing",) else "hostile")
    for key, v in (("iterations", 0), ("filter_width", 0), ("filter_width", 1e-300)):
        add(f"extract_options.{key} = {v!r}", doc([{"op": "cull", "percent": 50}], extract_options={key: v}),
            "either")
    add("extract_options a list", doc([{"op": "cull", "percent": 50}], extract_options=[1]))
    add("extract_options null", doc([{"op": "cull", "percent": 50}], extract_options=None), "either")
    # top-level shapes
    add("source missing", {"format": "stagger_nb.session", "version": 1, "ops": []})
    add("source both path and motion", doc([], source={"path": src, "motion": {}}))
    add("source path relative ..", doc([], source={"path": "../" * 12 + "etc/hostname"}))
    add("source path the session itself", doc([], source={"path": str(sess_self)}))
    add("source path a directory", doc([], source={"path": str(tmp)}))
    add("source path /proc/self/environ", doc([], source={"path": "/proc/self/environ"}))
    add("source path /proc/self/mem", doc([], source={"path": "/proc/self/mem"}))
    add("source path /dev/stdin", doc([], source={"path": "/dev/stdin"}))
    add("source path /dev/null", doc([], source={"path": "/dev/null"}))
    add("source path a socket", doc([], source={"path": str(tmp / "sock")}))
    add("source path symlink to /proc/self/pagemap", doc([], source={"path": str(tmp / "pagemap_link")}))
    add("source path ~ (tilde)", doc([], source={"path": "~/nothing.bvh"}))
    add("source path file URL", doc([], source={"path": "file://" + src}))
    add("source path number", doc([], source={"path": 1.5}))
    add("source path list", doc([], source={"path": [src]}))
    add("source sha256 mismatch", doc([], source={"path": src, "sha256": "0" * 64}), "either")
    add("source sha256 wrong type", doc([], source={"path": src, "sha256": 5}), "either")
    add("format missing", {"version": 1, "source": {"path": src}, "ops": []})
    add("version missing", {"format": "stagger_nb.session", "source": {"path": src}, "ops": []}, "either")
    add("version 1.0", doc([], version=1.0), "either")
    add("version 0", doc([], version=0))
    add("version 2**70", doc([], version=2 ** 70))
    add("format with BOM", doc([], format="\ufeffstagger_nb.session"))
    add("duplicate keys (later a bad type)", '{"format": "stagger_nb.session", "version": 1, "source": {"path": '
        + json.dumps(src) + '}, "ops": [{"op": "cull", "percent": 50, "percent": "x"}]}')
    add("duplicate 'op' keys", '{"format": "stagger_nb.session", "version": 1, "source": {"path": '
        + json.dumps(src) + '}, "ops": [{"op": "cull", "op": "explode", "percent": 50}]}')
    add("UTF-8 BOM", "\ufeff" + json.dumps(doc([{"op": "cull", "percent": 50}])), "either")
    add("UTF-16 with BOM", json.dumps(doc([{"op": "cull", "percent": 50}])).encode("utf-16"), "either")
    add("UTF-32 with BOM", json.dumps(doc([{"op": "cull", "percent": 50}])).encode("utf-32"))
    add("-Infinity in a delta", json.dumps(doc([{"op": "edit_frame", "frame": 1, "deltas": {"Chest": [0, 0, 1]}}]))
        .replace("[0, 0, 1]", "[0, 0, -Infinity]"))
    add("NaN as a key value inside source", json.dumps(doc([])).replace('"version": 1', '"version": NaN'))
    add("1e400 frame", json.dumps(doc([{"op": "edit_frame", "frame": 1, "deltas": {"Chest": [0, 0, 1]}}]))
        .replace('"frame": 1', '"frame": 1e400'))
    add("-1e400 time", json.dumps(doc([{"op": "retime", "pose": 1, "time": 1}])).replace('"time": 1',
                                                                                        '"time": -1e400'))
    add("frame 1.0000000000000001", json.dumps(doc([{"op": "edit_frame", "frame": 1, "deltas": {"Chest": [0, 0, 1]}}]))
        .replace('"frame": 1', '"frame": 1.0000000000000001'), "either")
    add("4301-digit integer", json.dumps(doc([{"op": "delete_pose", "pose": 1}])).replace('"pose": 1',
                                                                                        '"pose": ' + "1" * 4301))
    add("huge exponent integer-like 1E+9999999999", json.dumps(doc([{"op": "delete_pose", "pose": 1}])).replace(
        '"pose": 1', '"pose": 1E+9999999999'))
    add("deep nesting in deltas", json.dumps(doc([{"op": "edit_frame", "frame": 1, "deltas": 1}])).replace(
        '"deltas": 1', '"deltas": ' + '{"a":' * 50_000 + "1" + "}" * 50_000))
    add("deep nesting of objects at top level", '{"a":' * 100_000 + "1" + "}" * 100_000)
    add("deep nesting just under the recursion limit", json.dumps(doc([{"op": "cull", "keep": 1}])).replace(
        '"keep": 1', '"keep": ' + "[" * 900 + "]" * 900))
    add("32 MB + 1 bytes", b"")  # written by the runner at MAX_SESSION_BYTES + 1
    add("32 MB exactly of whitespace then a doc", b"")  # ditto
    add("session is a directory", None)
    add("session is a FIFO", None)
    add("session is /proc/self/pagemap symlink", None)
    add("session is a socket", None)
    add("session unreadable (chmod 000)", None, "either" if os.getuid() == 0 else "hostile")
    add("session path with NUL", None)
    add("session symlink to /dev/zero", None)
    return c


# --------------------------------------------------------------------------------------------------
# public functions with hostile parameters
# --------------------------------------------------------------------------------------------------
BAD_NUMBERS = [float("nan"), float("inf"), -float("inf"), -1, 0, 1e308, -1e308, 5e-324, 2 ** 64, 1.5, "1", None,
               np.float32("nan"), np.int64(-1), True, [1], np.array([1.0, 2.0]), complex(1, 1)]


def api_cases():
    """(name, callable(ctx), param, mode)."""
    from stagger_nb import staggered, timewarp, wand
    c = []

    def add(name, fn, param, mode="either"):
        c.append((name, fn, param, mode))
    for v in BAD_NUMBERS:
        r = repr(v)[:30]
        add(f"cull percent={r}", lambda x, v=v: staggered.cull(x.sm, percent=v), "percent")
        add(f"cull count={r}", lambda x, v=v: staggered.cull(x.sm, count=v), "count")
        add(f"succession s={r}", lambda x, v=v: staggered.succession(x.sm, root="Chest", s=v, l=2.0), "s")
        add(f"succession l={r}", lambda x, v=v: staggered.succession(x.sm, root="Chest", s=0.03, l=v), "l")
        add(f"random_timing tau={r}", lambda x, v=v: staggered.random_timing(x.sm, tau=v, seed=0), "tau")
        add(f"random_timing seed={r}", lambda x, v=v: staggered.random_timing(x.sm, tau=0.05, seed=v), "seed")
        add(f"exaggerate w_r={r}", lambda x, v=v: staggered.exaggerate(x.sm, 1, w_r=v), "w_r")
        add(f"falloff frame={r}", lambda x, v=v: wand.falloff(x.m, v), "frame")
        add(f"falloff sigma={r}", lambda x, v=v: wand.falloff(x.m, 3, sigma=v), "sigma")
        add(f"falloff frame_range=(0,{r})", lambda x, v=v: wand.falloff(x.m, 3, frame_range=(0, v)), "frame_range")
        add(f"propagate frame={r}", lambda x, v=v: wand.propagate(x.m, v, x.m.local_quats[3]), "frame")
        add(f"propagate sigma={r}", lambda x, v=v: wand.propagate(x.m, 3, x.m.local_quats[3], sigma=v), "sigma")
        add(f"guided_warp num_frames={r}", lambda x, v=v: timewarp.guided_warp(x.m, x.m, v), "num_frames")
        add(f"guided_warp skip={r}", lambda x, v=v: timewarp.guided_warp(x.m, x.m, 20, skip=v), "skip")
        add(f"linear_warp num_frames={r}", lambda x, v=v: timewarp.linear_warp(x.m, v), "num_frames")
        add(f"resample frame_time={r}", lambda x, v=v: x.m.resample(v), "frame_time")
        add(f"slice start={r}", lambda x, v=v: x.m.slice(v, 5), "start")
        add(f"slice stop={r}", lambda x, v=v: x.m.slice(0, v), "stop")
        add(f"extract {r} for every option", lambda x, v=v: _extract_all_options(x, v), "extract")
        add(f"detect_contacts on frame_time={r} motion", lambda x, v=v: staggered.detect_contacts(
            _with_frame_time(x.m, v)), "frame_time")
    for name, q in [("NaN quats", np.full((5, 4), np.nan)), ("zero quats", np.zeros((5, 4))),
                    ("wrong shape (4,)", np.zeros(4)), ("wrong shape (5, 3)", np.zeros((5, 3))),
                    ("wrong shape (F, J, 4)", None), ("huge quats 1e200", np.full((5, 4), 1e200)),
                    ("string array", np.array([["a"] * 4] * 5)), ("object array", np.array([[None] * 4] * 5)),
                    ("int quats", np.tile(np.array([0, 0, 0, 1]), (5, 1))), ("empty", np.zeros((0, 4))),
                    ("complex", np.ones((5, 4), complex)), ("list of lists", [[0, 0, 0, 1]] * 5)]:
        add(f"propagate edited_local_quats {name}", lambda x, q=q: wand.propagate(
            x.m, 3, x.m.local_quats if q is None else q), "edited_local_quats")
    for kt_name, kt in [("NaN", [(float("nan"), 0.1)]), ("out of range", [(100.0, 0.1)]), ("negative", [(-1, 0.1)]),
                        ("3-tuples", [(0.1, 0.2, 0.3)]), ("string", "abc"), ("dict", {"a": 1}),
                        ("unsorted", [(0.3, 0.3), (0.1, 0.4)]), ("1e6 keytimes", [(0.1, 0.1)] * 1_000_000),
                        ("array (2,2,2)", np.zeros((2, 2, 2))), ("inf", [(float("inf"), 0.1)])]:
        add(f"guided_warp keytimes {kt_name}", lambda x, kt=kt: timewarp.guided_warp(x.m, x.m, 20, keytimes=kt),
            "keytimes")
        add(f"linear_warp keytimes {kt_name}", lambda x, kt=kt: timewarp.linear_warp(x.m, 20, keytimes=kt),
            "keytimes")
    add("guided_warp reference not a Motion", lambda x: timewarp.guided_warp(x.m, "walk", 20), "reference")
    add("guided_warp reference another rig", lambda x: timewarp.guided_warp(x.m, x.other, 20), "reference", "either")
    add("guided_warp reference 1 frame", lambda x: timewarp.guided_warp(x.m, x.m.slice(0, 1), 20), "reference")
    add("guided_warp motion 2 frames", lambda x: timewarp.guided_warp(x.m.slice(0, 2), x.m, 2), "m")
    add("guided_warp motion 3 frames", lambda x: timewarp.guided_warp(x.m.slice(0, 3), x.m, 5), "m")
    add("guided_warp num_frames 2**40", lambda x: timewarp.guided_warp(x.m, x.m, 2 ** 40), "num_frames", "hostile")
    add("linear_warp num_frames 2**40", lambda x: timewarp.linear_warp(x.m, 2 ** 40), "num_frames", "hostile")
    add("linear_warp 1-frame motion to 10", lambda x: timewarp.linear_warp(x.m.slice(0, 1), 10), "m")
    add("linear_warp 0-frame motion", lambda x: timewarp.linear_warp(x.m.slice(0, 0), 10), "m")
    add("resample 1-frame motion", lambda x: x.m.slice(0, 1).resample(0.01), "frame_time")
    add("resample 1e-7 (huge)", lambda x: x.m.resample(1e-7), "frame_time", "hostile")
    add("slice reversed", lambda x: x.m.slice(10, 5), "start")
    add("slice step 0", lambda x: x.m.slice(0, 10, 0), "step")
    add("slice step -1", lambda x: x.m.slice(10, 0, -1), "step")
    add("slice step 1e9", lambda x: x.m.slice(0, 10, 10 ** 9), "step")
    add("extract 1-frame motion", lambda x: staggered.extract(x.m.slice(0, 1)), "motion")
    add("extract 2-frame motion", lambda x: staggered.extract(x.m.slice(0, 2)), "motion")
    add("extract 0-frame motion", lambda x: staggered.extract(x.m.slice(0, 0)), "motion")
    add("extract static motion", lambda x: staggered.extract(_static(x.m)), "motion")
    add("extract root at 1e300", lambda x: staggered.extract(_shifted(x.m, 1e300)), "motion")
    add("extract root at 1e150", lambda x: staggered.extract(_shifted(x.m, 1e150)), "motion")
    add("extract offsets 1e200", lambda x: staggered.extract(_scaled(x.m, 1e200)), "motion")
    add("falloff root at 1e300", lambda x: wand.falloff(_shifted(x.m, 1e300), 3), "motion")
    add("falloff 1-frame motion", lambda x: wand.falloff(x.m.slice(0, 1), 0), "frame")
    add("falloff 2-frame motion", lambda x: wand.falloff(x.m.slice(0, 2), 0), "frame")
    add("falloff static motion", lambda x: wand.falloff(_static(x.m), 3), "sigma")
    add("propagate static motion", lambda x: wand.propagate(_static(x.m), 3, x.m.local_quats[5]), "sigma")
    add("guided_warp static motion", lambda x: timewarp.guided_warp(_static(x.m), _static(x.m), 20), "m")
    add("guided_warp root at 1e300", lambda x: timewarp.guided_warp(_shifted(x.m, 1e300), x.m, 20), "m")
    add("cull on a 1-frame extraction", lambda x: staggered.cull(staggered.extract(x.m.slice(0, 3)), percent=50),
        "percent")
    add("succession root missing", lambda x: staggered.succession(x.sm, root="Tail", s=0.03), "root", "hostile")
    add("succession root int", lambda x: staggered.succession(x.sm, root=3, s=0.03), "root")
    add("succession root None", lambda x: staggered.succession(x.sm, root=None, s=0.03), "root")
    add("random_timing joints missing", lambda x: staggered.random_timing(x.sm, joints=["Tail"], tau=0.05), "joints",
        "hostile")
    add("random_timing joints a string", lambda x: staggered.random_timing(x.sm, joints="Chest", tau=0.05), "joints")
    add("random_timing seed Generator", lambda x: staggered.random_timing(x.sm, tau=0.05,
                                                                           seed=np.random.default_rng(0)), "seed")
    add("evaluate on a non-StaggeredMotion", lambda x: staggered.evaluate(x.m), "sm")
    add("cull on a Motion", lambda x: staggered.cull(x.m, percent=50), "sm")
    add("detect_contacts 1-frame", lambda x: staggered.detect_contacts(x.m.slice(0, 1)), "motion")
    add("write_bvh to a directory", lambda x: __import__("stagger_nb").write_bvh(x.m, x.tmp), "path", "hostile")
    add("write_bvh to None", lambda x: __import__("stagger_nb").write_bvh(x.m, None), "path")
    add("write_bvh to 123", lambda x: __import__("stagger_nb").write_bvh(x.m, 123), "path")
    add("write_bvh to a path with NUL", lambda x: __import__("stagger_nb").write_bvh(x.m, "a\x00b.bvh"), "path")
    add("write_bvh not a Motion", lambda x: __import__("stagger_nb").write_bvh("m", x.tmp / "o.bvh"), "motion")
    add("write_bvh 0-frame motion", lambda x: _write_read(x, x.m.slice(0, 0)), "motion")
    add("write_gltf 0-frame motion", lambda x: __import__("stagger_nb").write_gltf(x.m.slice(0, 0),
                                                                                    x.tmp / "z.glb"), "motion")
    add("write_gltf to a .txt name", lambda x: __import__("stagger_nb").write_gltf(x.m, x.tmp / "z.txt"), "path")
    add("write_gltf units bogus", lambda x: __import__("stagger_nb").write_gltf(x.m, x.tmp / "z.glb", units="furlong"),
        "units")
    add("export_html to a directory", lambda x: _export_html(x.m, x.tmp), "path")
    add("export_html of a string", lambda x: _export_html("m", x.tmp / "h.html"), "obj")
    add("read_bvh None", lambda x: __import__("stagger_nb").read_bvh(None), "path")
    add("read_bvh bytes path", lambda x: __import__("stagger_nb").read_bvh(b"/nonexistent"), "path")
    add("read_bvh a URL", lambda x: __import__("stagger_nb").read_bvh("http://example.com/a.bvh"), "path")
    add("read_asf_amc swapped", lambda x: __import__("stagger_nb").read_asf_amc(x.amc_path, x.asf_path), "asf")
    add("Motion with NaN root positions", lambda x: _motion_with(x.m, root_positions=np.full_like(
        x.m.root_positions, np.nan)), "root_positions")
    add("Motion with zero quaternions", lambda x: _motion_with(x.m, local_quats=np.zeros_like(x.m.local_quats)),
        "local_quats")
    add("Motion with int quats", lambda x: _motion_with(x.m, local_quats=x.m.local_quats.astype(int)), "local_quats")
    add("Motion with float32 quats", lambda x: _motion_with(x.m, local_quats=x.m.local_quats.astype(np.float32)),
        "local_quats")
    add("Motion with frame_time nan", lambda x: _motion_with(x.m, frame_time=float("nan")), "frame_time")
    add("Motion with frame_time '0.1'", lambda x: _motion_with(x.m, frame_time="0.1"), "frame_time")
    add("Motion with quats shape mismatch", lambda x: _motion_with(x.m, local_quats=x.m.local_quats[:-1]),
        "shape")
    add("Session ops not a list", lambda x: _session(x.m, ops="cull"), "ops")
    add("Session ops dicts with NaN", lambda x: _session(x.m, ops=[{"op": "cull", "percent": float("nan")}]),
        "percent")
    add("Session source not a Motion", lambda x: _session("walk", ops=[]), "source")
    add("Session extract_options bogus", lambda x: _session(x.m, ops=[{"op": "cull", "percent": 50}],
                                                            extract_options={"bogus": 1}), "extract_options")
    add("Session save to a directory", lambda x: _session(x.m, save=x.tmp), "path", "hostile")
    add("Session.load a directory", lambda x: __import__("stagger_nb.session", fromlist=["Session"]).Session.load(
        x.tmp), "session", "hostile")
    add("Session export_bvh odd rig 1-channel edit", lambda x: _odd_export(x), "path")
    return c


def _extract_all_options(x, v):
    import inspect

    from stagger_nb import staggered
    params = [p for p in inspect.signature(staggered.extract).parameters.values()
              if (p.kind == p.KEYWORD_ONLY or (p.default is not inspect.Parameter.empty))
              and p.name not in ("progress",) and p.kind != p.VAR_KEYWORD]
    for p in params:
        try:
            staggered.extract(x.m, **{p.name: v})
        except ValueError as e:
            if p.name not in str(e):
                raise ValueError(f"[unnamed: expected {p.name!r}] {e}") from None


def _with_frame_time(m, v):
    return _motion_with(m, frame_time=v)


def _motion_with(m, **kw):
    import dataclasses
    return dataclasses.replace(m, **kw)


def _static(m):
    q = np.broadcast_to(m.local_quats[:1], m.local_quats.shape).copy()
    r = np.broadcast_to(m.root_positions[:1], m.root_positions.shape).copy()
    return _motion_with(m, local_quats=q, root_positions=r)


def _shifted(m, d):
    return _motion_with(m, root_positions=m.root_positions + d)


def _scaled(m, s):
    import dataclasses
    sk = dataclasses.replace(m.skeleton, offsets=m.skeleton.offsets * s)
    return _motion_with(m, skeleton=sk, root_positions=m.root_positions * s)


def _write_read(x, m):
    import stagger_nb as sn
    p = x.tmp / "w.bvh"
    sn.write_bvh(m, p)
    return sn.read_bvh(p)


def _export_html(obj, path):
    from stagger_nb.widgets import export_html
    return export_html(obj, path)


def _session(m, ops=None, extract_options=None, save=None):
    from stagger_nb.session import Session
    s = Session(m, ops=ops or [], extract_options=extract_options)
    if save is not None:
        s.save(save)
        return s
    return s.edited()


def _odd_export(x):
    import stagger_nb as sn
    from stagger_nb.session import Session
    m = sn.read_bvh(x.one_channel)
    s = Session(m, source_path=str(x.one_channel))
    s.add({"op": "edit_frame", "frame": 0, "deltas": {"A": [0, 30, 40]}})
    out = x.tmp / "one_channel_out.bvh"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s.export_bvh(out)
    _same_motion(s.edited(), sn.read_bvh(out), "export")


# --------------------------------------------------------------------------------------------------
# checks
# --------------------------------------------------------------------------------------------------
def _same_motion(a, b, what):
    from stagger_nb.core.kinematics import forward_kinematics, skeleton_height
    if list(a.skeleton.names) != list(b.skeleton.names):
        raise AssertionError(f"{what}: joint names differ: {a.skeleton.names[:5]} vs {b.skeleton.names[:5]}")
    if a.num_frames != b.num_frames:
        raise AssertionError(f"{what}: {a.num_frames} frames became {b.num_frames}")
    if a.num_frames == 0:
        return
    p1, _ = forward_kinematics(a)
    p2, _ = forward_kinematics(b)
    h = max(skeleton_height(a), 1e-9)
    with np.errstate(all="ignore"):
        err = float(np.max(np.abs(p1 - p2))) / h
    if not err <= 1e-5:
        raise AssertionError(f"{what}: re-read {err:.3g} x height away")
    if abs(a.frame_time - b.frame_time) > 1e-6 * a.frame_time:
        raise AssertionError(f"{what}: frame time {a.frame_time} became {b.frame_time}")


def _replay_and_export(session, out):
    """Replay ``session``, check its edited motion, export it to ``out`` and re-read it to the same motion."""
    import stagger_nb as sn
    e = session.edited()
    _check_motion(e)
    session.export_bvh(out)
    _same_motion(e, sn.read_bvh(out), "export")


def _check_motion(m, what="result"):
    """A clean result must be a finite, well-formed Motion."""
    import stagger_nb as sn
    if isinstance(m, tuple):
        for x in m:
            _check_motion(x, what)
        return
    if isinstance(m, sn.Motion):
        for name in ("root_positions", "local_quats"):
            a = getattr(m, name)
            if not np.all(np.isfinite(a)):
                raise AssertionError(f"{what}: {name} not finite")
        n = np.linalg.norm(m.local_quats, axis=-1)
        if n.size and not np.allclose(n, 1, atol=1e-6):
            raise AssertionError(f"{what}: quaternions not unit ({n.min():.3g}..{n.max():.3g})")
        if not (np.isfinite(m.frame_time) and m.frame_time > 0):
            raise AssertionError(f"{what}: frame_time {m.frame_time}")
    elif isinstance(m, np.ndarray) and m.dtype.kind == "f":
        if not np.all(np.isfinite(m)):
            raise AssertionError(f"{what}: array not finite")


# --------------------------------------------------------------------------------------------------
# the forked runner
# --------------------------------------------------------------------------------------------------
def _rss_kib():
    with open("/proc/self/status") as f:
        return int(next(line for line in f if line.startswith("VmRSS")).split()[1])


def run_forked(fn, seconds):
    """Run ``fn()`` in a forked child; returns dict(result, type, message, seconds, peak)."""
    r, w = os.pipe()
    base = _rss_kib()
    t0 = time.perf_counter()
    pid = os.fork()
    if pid == 0:  # child
        os.close(r)
        try:
            resource.setrlimit(resource.RLIMIT_AS, (AS_LIMIT, AS_LIMIT))
        except (ValueError, OSError):
            pass
        out = {}
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fn()
            out["result"] = "no error"
        except ValueError as e:
            out.update(result="ValueError", type=type(e).__name__, message=str(e)[:600])
        except BaseException as e:
            out.update(result=type(e).__name__, message=(str(e)[:300] + " | "
                                                         + traceback.format_exc()[-900:]))
        try:
            os.write(w, json.dumps(out).encode()[:60000])
        finally:
            os._exit(0)
    os.close(w)
    chunks = []
    deadline = time.monotonic() + seconds
    import select
    status = None
    rusage = None
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            os.kill(pid, signal.SIGKILL)
            _, status, rusage = os.wait4(pid, 0)
            os.close(r)
            return {"result": "timeout", "message": f"> {seconds:.0f} s", "seconds": time.perf_counter() - t0,
                    "cpu": rusage.ru_utime + rusage.ru_stime, "peak": max(0, rusage.ru_maxrss - base) * 1024}
        ready, _, _ = select.select([r], [], [], min(left, 0.5))
        if ready:
            data = os.read(r, 65536)
            if not data:
                break
            chunks.append(data)
    os.close(r)
    _, status, rusage = os.wait4(pid, 0)
    secs = time.perf_counter() - t0
    peak = max(0, rusage.ru_maxrss - base) * 1024
    try:
        out = json.loads(b"".join(chunks).decode())
    except ValueError:
        sig = os.WTERMSIG(status) if os.WIFSIGNALED(status) else None
        out = {"result": "crash", "message": f"status {status} signal {sig}"}
    out["seconds"], out["peak"], out["cpu"] = secs, peak, rusage.ru_utime + rusage.ru_stime
    return out


class Ctx:
    pass


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", choices=["bvh", "odd", "oddops", "amc", "session", "api"])
    ap.add_argument("--match", default=None)
    ap.add_argument("--seconds", type=float, default=MAX_SECONDS)
    ap.add_argument("--verbose", action="store_true")
    args = ap.parse_args(argv)
    import stagger_nb as sn
    from stagger_nb import staggered
    from stagger_nb.session import Session
    from stagger_nb.session.files import MAX_SESSION_BYTES

    tmp = Path(tempfile.mkdtemp(prefix="heldout_"))
    results = []
    t_start = time.perf_counter()

    def record(kind, name, mode, res, ok, why=""):
        res.update(kind=kind, name=name, mode=mode, ok=ok, why=why)
        results.append(res)
        if not ok or args.verbose:
            print(f"{'FAIL' if not ok else 'ok  '} [{kind}] {name!r}: {res['result']} {why} "
                  f"{res.get('message', '')[:300]!r} ({res['seconds']:.2f} s wall, {res['cpu']:.2f} s CPU, "
                  f"{res['peak'] / 2 ** 20:.0f} MB)",
                  flush=True)

    def bounded(res):
        """Within the time bound (wall; on a machine loaded beyond its CPUs, the child's CPU time, and a
        timeout is a failure unless its CPU time stayed under half the bound) and the memory bound."""
        busy = os.getloadavg()[0] > (os.cpu_count() or 1)
        if res["result"] == "timeout":
            fast = busy and res["cpu"] <= args.seconds / 2
        else:
            fast = res["seconds"] <= args.seconds or (busy and res["cpu"] <= args.seconds)
        return fast and res["peak"] <= MAX_BYTES

    def wanted(kind, name):
        return (args.only in (None, kind)) and (args.match is None or args.match.lower() in name.lower())

    # ---------------- BVH files
    for k, (name, raw, mode) in enumerate(bvh_cases()):
        if not wanted("bvh", name):
            continue
        p = tmp / f"h{k}.bvh"
        p.write_bytes(raw)
        before = raw

        def case(p=p):
            m = sn.read_bvh(p)
            q = tmp / f"h{k}_out.bvh"
            sn.write_bvh(m, q)
            _same_motion(m, sn.read_bvh(q), "write/re-read")
        res = run_forked(case, args.seconds)
        untouched = p.read_bytes() == before
        msg = res.get("message", "")
        named = res["result"] == "ValueError" and p.name in msg and bool(re.search(r"line \d+", msg))
        ok = bounded(res) and untouched and (named or (mode == "either" and res["result"] == "no error"))
        record("bvh", name, mode, res, ok, "" if named or res["result"] != "ValueError" else "(not naming file+line)")
        p.unlink()
    # ---------------- odd rigs
    for k, (name, raw, joint) in enumerate(bvh_odd_valid()):
        if not wanted("odd", name):
            continue
        p = tmp / f"odd{k}.bvh"
        p.write_bytes(raw)

        def case(p=p, joint=joint, k=k):
            m = sn.read_bvh(p)
            s = Session(m, source_path=str(p))
            s.add({"op": "edit_frame", "frame": 0, "deltas": {joint: [15.0, -27.0, 41.0]}})
            if m.num_frames >= 3:
                s.add({"op": "propagate", "frame": m.num_frames // 2, "deltas": {joint: [0.0, 20.0, 10.0]}})
            edited = s.edited()
            out = tmp / f"odd{k}_out.bvh"
            s.export_bvh(out)
            _same_motion(edited, sn.read_bvh(out), "BVH export")
            glb = tmp / f"odd{k}.glb"
            s.export_gltf(glb)
            sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
            from hostile_corpus import gltf_positions

            from stagger_nb.core.kinematics import forward_kinematics, skeleton_height
            names, scale, pos = gltf_positions(glb)
            p1, _ = forward_kinematics(edited)
            # glTF holds float32: a rig of zero-length bones (height 0) moving 60 units is exact to ~4e-6
            # units, so the tolerance is 1e-5 of the height or, for such a rig, float32's share of its reach
            reach = float(np.max(np.abs(p1), initial=0.0))
            h = max(skeleton_height(edited), 1e-9, 8 * reach * 2.0 ** -24 / 1e-5)  # 8 float32 ulps
            err = float(np.max(np.abs(pos - p1 * scale))) / (h * scale)
            if not err <= 1e-5:
                raise AssertionError(f"glTF re-reads {err:.3g} x height away")
            # the staggered path on rigs with enough frames
            if m.num_frames >= 5:
                s2 = Session(m, source_path=str(p), ops=[{"op": "succession", "root": m.skeleton.names[0],
                                                          "s": 0.02, "l": 1.5}])
                out2 = tmp / f"odd{k}_out2.bvh"
                s2.export_bvh(out2)
                _same_motion(s2.edited(), sn.read_bvh(out2), "BVH export after succession")
        res = run_forked(case, args.seconds)
        ok = bounded(res) and res["result"] == "no error" and p.read_bytes() == raw
        record("odd", name, "odd", res, ok)
    # ---------------- every op on every odd rig: a clean, exportable result or a ValueError naming the field
    for k, (name, raw, joint) in enumerate(bvh_odd_valid()):
        if args.only not in (None, "oddops"):
            break
        p = tmp / f"oddops{k}.bvh"
        p.write_bytes(raw)
        for op in _ops_for_rig(joint):
            label = f"{name} + {op['op']}"
            if args.match is not None and args.match.lower() not in label.lower():
                continue

            def case(p=p, op=op, k=k):
                s = Session(sn.read_bvh(p), ops=[op], source_path=str(p))
                _replay_and_export(s, tmp / f"oddops{k}_out.bvh")
            res = run_forked(case, args.seconds)
            msg = res.get("message", "")
            named = res["result"] == "ValueError" and bool(re.match(r"^ops\[0\] \(\w+\): [\w.\[\]]+", msg))
            ok = bounded(res) and p.read_bytes() == raw and (named or res["result"] == "no error")
            record("oddops", label, "either", res, ok, "" if named or res["result"] != "ValueError"
                   else "(not naming field)")
    # ---------------- ASF / AMC
    for k, (name, asf, amc, mode) in enumerate(amc_cases()):
        if not wanted("amc", name):
            continue
        pa, pm = tmp / f"a{k}.asf", tmp / f"a{k}.amc"
        pa.write_text(asf, encoding="utf-8", errors="surrogateescape")
        if amc is None:
            pm.write_bytes(AMC.encode("utf-16"))
        else:
            pm.write_text(amc, encoding="utf-8", errors="surrogateescape")
        ba, bm = pa.read_bytes(), pm.read_bytes()

        def case(pa=pa, pm=pm, k=k):
            m = sn.read_asf_amc(pa, pm)
            _check_motion(m)
            q = tmp / f"a{k}_out.bvh"
            sn.write_bvh(m, q)
            _same_motion(m, sn.read_bvh(q), "write/re-read")
        res = run_forked(case, args.seconds)
        msg = res.get("message", "")
        named = res["result"] == "ValueError" and (pa.name in msg or pm.name in msg) and bool(
            re.search(r"line \d+", msg))
        ok = (bounded(res) and pa.read_bytes() == ba and pm.read_bytes() == bm
              and (named or (mode == "either" and res["result"] == "no error")))
        record("amc", name, mode, res, ok, "" if named or res["result"] != "ValueError" else "(not naming file+line)")
    # ---------------- sessions
    src = tmp / "source.bvh"
    src.write_text(bvh(frames="30", rows=[" ".join(f"{(f * 0.7 + j * 3) % 50 - 25:.3f}" if j != 1 else "90"
                                                   for j in range(NCH)) for f in range(30)]))
    src_bytes = src.read_bytes()
    (tmp / "unreadable.bvh").write_bytes(src_bytes)
    os.chmod(tmp / "unreadable.bvh", 0)
    os.mkfifo(tmp / "fifo")
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(tmp / "sock"))
    os.symlink("/proc/self/pagemap", tmp / "pagemap_link")
    sess_dir = tmp / "sessions"
    sess_dir.mkdir()
    for k, (name, d, mode) in enumerate(session_cases(str(src), tmp, sess_dir / "s_self.json")):
        if not wanted("session", name):
            continue
        p = sess_dir / (f"s{k}.json" if "session file itself" not in name and "session itself" not in name
                        else "s_self.json")
        for q in (p,):
            if os.path.lexists(q):
                if q.is_dir() and not q.is_symlink():
                    os.rmdir(q)
                else:
                    os.unlink(q)
        if name == "32 MB + 1 bytes":
            body = json.dumps({"format": "stagger_nb.session", "version": 1, "source": {"path": str(src)}, "ops": []})
            p.write_bytes(body.encode() + b" " * (MAX_SESSION_BYTES + 1 - len(body)))
        elif name == "32 MB exactly of whitespace then a doc":
            body = json.dumps({"format": "stagger_nb.session", "version": 1, "source": {"path": str(src)}, "ops": []})
            p.write_bytes(b" " * (MAX_SESSION_BYTES - len(body)) + body.encode())
            mode = "either"
        elif name == "session is a directory":
            p.mkdir()
        elif name == "session is a FIFO":
            os.mkfifo(p)
        elif name == "session is /proc/self/pagemap symlink":
            os.symlink("/proc/self/pagemap", p)
        elif name == "session symlink to /dev/zero":
            os.symlink("/dev/zero", p)
        elif name == "session is a socket":
            p = tmp / "sock"
        elif name == "session unreadable (chmod 000)":
            p.write_text(json.dumps({"format": "stagger_nb.session", "version": 1, "source": {"path": str(src)},
                                     "ops": []}))
            os.chmod(p, 0)
        elif name == "session path with NUL":
            p = Path(str(p) + "\x00x")
        else:
            p.write_bytes(d if isinstance(d, bytes) else (d if isinstance(d, str) else json.dumps(d)).encode(
                "utf-8", "surrogatepass"))
        try:
            before = p.read_bytes() if p.is_file() and os.access(p, os.R_OK) and os.getuid() != 0 or (
                p.is_file() and "unreadable" not in name) else None
        except (OSError, ValueError):
            before = None

        def case(p=p, k=k):
            _replay_and_export(Session.load(p), tmp / f"s{k}_export.bvh")
        res = run_forked(case, args.seconds)
        msg = res.get("message", "")
        named = res["result"] == "ValueError" and bool(re.match(r"^[A-Za-z_][\w.\[\]]*( \(\w+\))?( key)?: ", msg))
        try:
            untouched = src.read_bytes() == src_bytes and (before is None or p.read_bytes() == before)
        except (OSError, ValueError):
            untouched = src.read_bytes() == src_bytes
        ok = bounded(res) and untouched and (named or (mode == "either" and res["result"] == "no error"))
        record("session", name, mode, res, ok, "" if named or res["result"] != "ValueError" else "(not naming field)")
    # ---------------- public functions
    if args.only in (None, "api"):
        x = Ctx()
        x.tmp = tmp
        x.m = sn.read_bvh(src)
        x.sm = staggered.extract(x.m)
        x.other = sn.data.load("walk").slice(0, 40)
        x.asf_path, x.amc_path = tmp / "ok.asf", tmp / "ok.amc"
        x.asf_path.write_text(ASF)
        x.amc_path.write_text(AMC)
        x.one_channel = tmp / "one_channel.bvh"
        x.one_channel.write_bytes(b"HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition "
                                  b"Zposition Zrotation Xrotation Yrotation\nJOINT A\n{\nOFFSET 0 10 0\nCHANNELS 1 "
                                  b"Xrotation\nEnd Site\n{\nOFFSET 0 5 0\n}\n}\n}\nMOTION\nFrames: 2\nFrame Time: 0.1"
                                  b"\n0 0 0 0 0 0 10\n0 0 0 0 0 0 20\n")
        for name, fn, param, mode in api_cases():
            if not wanted("api", name):
                continue

            def case(fn=fn):
                out = fn(x)
                _check_motion(out)
            res = run_forked(case, args.seconds)
            msg = res.get("message", "")
            named = res["result"] == "ValueError" and (param.lower() in msg.lower() or bool(
                param in ("path", "asf") and re.search(r"(/|\.bvh|\.amc|\.asf)", msg)))
            ok = bounded(res) and (named or (mode == "either" and res["result"] == "no error"))
            record("api", name, mode, res, ok, "" if named or res["result"] != "ValueError"
                   else f"(not naming {param!r})")
    # ---------------- summary
    total = time.perf_counter() - t_start
    by = {}
    for r in results:
        n, f = by.get(r["kind"], (0, 0))
        by[r["kind"]] = (n + 1, f + (not r["ok"]))
    print(f"\n{len(results)} cases, {sum(not r['ok'] for r in results)} failing, {total:.0f} s wall "
          f"(load {os.getloadavg()[0]:.1f}, {os.cpu_count()} CPUs)")
    for kind, (n, f) in by.items():
        print(f"  {kind:8s} {n:5d} cases {f:4d} failing")
    slow = sorted(results, key=lambda r: -r["seconds"])[:3]
    big = sorted(results, key=lambda r: -r["peak"])[:3]
    print("  slowest:", "; ".join(f"{r['name'][:50]} {r['seconds']:.2f} s ({r['cpu']:.2f} s CPU)" for r in slow))
    print("  largest:", "; ".join(f"{r['name'][:50]} {r['peak'] / 2 ** 20:.0f} MB" for r in big))
    sock.close()
    return 1 if any(not r["ok"] for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
