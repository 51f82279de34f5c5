"""AMC (Acclaim motion) text -> per-frame channel values, read against a parsed ASF (:func:`parse_amc`): the
root's channels and each bone's dof, in degrees. Every error is an :class:`~.asf_read.AMCError` naming the file
and line."""
from __future__ import annotations

import numpy as np

from ..core.motion import MAX_FRAME_JOINTS
from ._common import MAX_TOKEN, finite_number, split_values
from .asf_read import AMCError, AsfSkeleton, _iter_lines

__all__ = ["parse_amc"]

_MAX_FRAMES = 10_000_000


def parse_amc(text: str, asf: AsfSkeleton, source: str = "<amc>"):
    """Parse AMC text against a parsed ASF.

    Returns
    -------
    root : ndarray, shape (F, len(asf.root_order))
        Root channel values in ``asf.root_order`` (angles in degrees).
    dofs : list of ndarray, one per bone in ``asf.bones``, shape (F, len(bone.dof)), degrees.
    """
    to_deg = asf.angle_unit == "rad"
    names = {"root": len(asf.root_order)}
    col = {"root": 0}
    width = len(asf.root_order)
    bone_cols = []
    for b in asf.bones:
        if b.dof:
            names[b.name] = len(b.dof)
            col[b.name] = width
            bone_cols.append(width)
            width += len(b.dof)
        else:
            bone_cols.append(None)
    need = len(names)
    rows: list[list[str]] = []  # per frame: the value tokens laid out by `col`
    frame_lines: list[int] = []
    current = None
    seen: set = set()
    expect_no = None
    header_seen = False
    ln = 0
    longest = (width + 2) * (MAX_TOKEN + 1)  # characters of a line that can matter: the rest is an error
    for ln, raw in _iter_lines(text, longest):
        s = raw.strip()
        if not s or s[0] == "#":
            continue
        if s[0] == ":":
            header_seen = True
            if current is not None:
                raise AMCError(source, ln, f"unexpected header {s!r} inside frame data")
            kw = s.upper()
            if kw == ":DEGREES":
                to_deg = False
            elif kw == ":RADIANS":
                to_deg = True
            continue
        toks = s.split(None, 1)  # the head, then the values split below with a bound
        head = toks[0]
        if len(toks) == 1 and head.isascii() and head.isdigit():  # '¹', '١' are digits to isdigit()
            if current is not None and len(seen) != need:
                missing = next(n for n in names if n not in seen)
                raise AMCError(source, ln, f"frame {expect_no - 1} has no line for {missing!r}")
            if len(head) > 18:  # also keeps int() from its 4,300-digit ValueError
                raise AMCError(source, ln, f"frame number {head[:20]}... has {len(head)} digits")
            no = int(head)
            if expect_no is not None and no != expect_no:
                raise AMCError(source, ln, f"expected frame number {expect_no}, found {no}")
            if len(rows) >= _MAX_FRAMES or (len(rows) + 1) * (len(asf.bones) + 1) > MAX_FRAME_JOINTS:
                raise AMCError(source, ln, f"more than {min(_MAX_FRAMES, MAX_FRAME_JOINTS // (len(asf.bones) + 1))}"
                                           f" frames of {len(asf.bones) + 1} joints")
            expect_no = no + 1
            current = [None] * width
            rows.append(current)
            frame_lines.append(ln)
            seen = set()
            continue
        if current is None:
            if not (rows or header_seen):  # nothing yet says this is an AMC file: its words are not quoted
                raise AMCError(source, ln, "not an AMC file: expected ':FULLY-SPECIFIED', ':DEGREES' or a frame "
                                           "number first (the line is not quoted here)")
            raise AMCError(source, ln, f"expected a frame number, found {head!r}")
        n = names.get(head)
        if n is None:
            raise AMCError(source, ln, f"unknown bone {head!r} (expected root or a bone with dof)")
        if head in seen:
            raise AMCError(source, ln, f"second line for {head!r} in frame {expect_no - 1}")
        vals = split_values(toks[1] if len(toks) > 1 else "", n, len(raw) == longest, f"for {head!r}", source, ln,
                            AMCError)
        seen.add(head)
        c = col[head]
        current[c:c + n] = vals
    if current is None:
        raise AMCError(source, ln or 1, "no frames found (expected a frame number line)")
    if len(seen) != need:
        missing = next(n for n in names if n not in seen)
        raise AMCError(source, ln, f"file ends early: frame {expect_no - 1} has no line for {missing!r}")
    flat = [t for r in rows for t in r]
    joined = "".join(flat)
    # numpy, like float, reads '1_000' and non-ASCII digits: such tokens go to the checked path
    ok = joined.isascii() and "_" not in joined
    if ok:
        try:
            data = np.array(flat, dtype=float).reshape(len(rows), width)
            ok = bool(np.all(np.isfinite(data)))
        except ValueError:
            ok = False
    if not ok:
        _locate_bad_number(text, frame_lines, source)
    if to_deg:
        rot = np.array([t.startswith("r") for t in asf.root_order] + [True] * (width - len(asf.root_order)))
        data = np.where(rot, np.degrees(data), data)
    root = data[:, :len(asf.root_order)]
    dofs = [data[:, c:c + len(b.dof)] if c is not None else np.zeros((len(rows), 0))
            for b, c in zip(asf.bones, bone_cols)]
    return root, dofs


def _locate_bad_number(text, frame_lines, source):
    for ln, line in _iter_lines(text):
        if ln < frame_lines[0]:
            continue
        toks = line.split()
        if len(toks) < 2 or toks[0].startswith("#"):
            continue
        for t in toks[1:]:
            finite_number(t, repr(toks[0]), source, ln, AMCError)
    raise AMCError(source, None, "a value could not be read")  # unreachable: the fast path failed somewhere
