"""BVH (Biovision Hierarchy) reader and writer.

Semantics: rotation channels are intrinsic Euler angles in degrees in the order they are listed
(``Zrotation Xrotation Yrotation`` means ``R = Rz Rx Ry``). Position channels give the joint's
translation relative to its parent and *replace* its OFFSET (as Blender and MotionBuilder read them).
"""
from __future__ import annotations

import os
import re
import tempfile

import numpy as np

from ..core.motion import Motion
from ..core.rotations import euler_to_quat, quat_to_euler
from ..core.skeleton import Skeleton
from ._common import FormatError

__all__ = ["BVHError", "read_bvh", "write_bvh", "parse_bvh"]

_VALID_CHANNELS = {"xposition", "yposition", "zposition", "xrotation", "yrotation", "zrotation"}
_MAX_FRAMES = 10_000_000  # refuse absurd headers before allocating anything
_MAX_JOINTS = 10_000


class BVHError(FormatError):
    """A malformed BVH file; the message names the file, the line and what was expected."""


class _Tokens:
    """Whitespace tokens of the header with their 1-based line numbers."""

    def __init__(self, lines: list[str], source: str):
        self.items = []
        self.source = source
        for ln, line in enumerate(lines, 1):
            for tok in line.split():
                self.items.append((tok, ln))
        self.pos = 0

    def next(self, expected: str) -> tuple[str, int]:
        if self.pos >= len(self.items):
            last = self.items[-1][1] if self.items else 1
            raise BVHError(self.source, last, f"file ends early: expected {expected}")
        tok = self.items[self.pos]
        self.pos += 1
        return tok

    def peek(self) -> str | None:
        return self.items[self.pos][0] if self.pos < len(self.items) else None

    def number(self, expected: str) -> float:
        tok, ln = self.next(expected)
        try:
            v = float(tok)
        except ValueError:
            raise BVHError(self.source, ln, f"expected {expected}, found {tok!r}") from None
        if not np.isfinite(v):
            raise BVHError(self.source, ln, f"expected a finite number for {expected}, found {tok!r}")
        return v

    def keyword(self, word: str) -> int:
        tok, ln = self.next(repr(word))
        if tok.upper() != word.upper():
            raise BVHError(self.source, ln, f"expected {word!r}, found {tok!r}")
        return ln


def _parse_hierarchy(tok: _Tokens):
    names, parents, offsets, channels, end_sites = [], [], [], [], {}
    tok.keyword("HIERARCHY")
    t, ln = tok.next("'ROOT'")
    if t.upper() != "ROOT":
        raise BVHError(tok.source, ln, f"expected 'ROOT', found {t!r}")

    def joint(parent: int):
        name_tok, ln = tok.next("a joint name")
        if name_tok == "{":
            raise BVHError(tok.source, ln, "expected a joint name before '{'")
        # names may contain spaces in some exporters: join tokens up to '{' on the same line
        parts = [name_tok]
        while tok.peek() is not None and tok.peek() != "{" and tok.items[tok.pos][1] == ln:
            parts.append(tok.next("'{'")[0])
        if len(names) >= _MAX_JOINTS:
            raise BVHError(tok.source, ln, f"more than {_MAX_JOINTS} joints")
        j = len(names)
        names.append(" ".join(parts))
        parents.append(parent)
        tok.keyword("{")
        tok.keyword("OFFSET")
        offsets.append([tok.number("an OFFSET value") for _ in range(3)])
        t, ln = tok.next("'CHANNELS'")
        if t.upper() != "CHANNELS":
            raise BVHError(tok.source, ln, f"expected 'CHANNELS', found {t!r}")
        n = tok.number("a channel count")
        if n != int(n) or not 0 <= n <= 6:
            raise BVHError(tok.source, ln, f"expected a channel count from 0 to 6, found {n:g}")
        chans = []
        for _ in range(int(n)):
            c, cl = tok.next("a channel name")
            if c.lower() not in _VALID_CHANNELS:
                raise BVHError(tok.source, cl, f"unknown channel {c!r} (expected X/Y/Z position or rotation)")
            chans.append(c[0].upper() + c[1:].lower())
        if len({c.lower() for c in chans}) != len(chans):
            raise BVHError(tok.source, ln, f"repeated channel in {' '.join(chans)}")
        channels.append(tuple(chans))
        while True:
            t, ln = tok.next("'JOINT', 'End Site' or '}'")
            u = t.upper()
            if u == "}":
                return
            if u == "JOINT":
                joint(j)
            elif u == "END":
                tok.keyword("Site")
                tok.keyword("{")
                tok.keyword("OFFSET")
                end_sites[j] = [tok.number("an End Site OFFSET value") for _ in range(3)]
                tok.keyword("}")
            else:
                raise BVHError(tok.source, ln, f"expected 'JOINT', 'End Site' or '}}', found {t!r}")

    joint(-1)
    if tok.peek() is not None:
        t, ln = tok.items[tok.pos]
        raise BVHError(tok.source, ln, f"expected 'MOTION' after the hierarchy, found {t!r}")
    return Skeleton(names, parents, np.array(offsets).reshape(-1, 3), tuple(channels), end_sites)


def _split_sections(text: str, source: str):
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.strip().upper() == "MOTION":
            return lines[:i], lines[i + 1:], i + 1
    raise BVHError(source, len(lines) or 1, "no 'MOTION' section found")


def _header_value(line: str, key: str, source: str, ln: int) -> float:
    m = re.match(rf"\s*{key}\s*:\s*(\S+)\s*$", line, flags=re.IGNORECASE)
    if not m:
        raise BVHError(source, ln, f"expected '{key}: <number>', found {line.strip()!r}")
    try:
        v = float(m.group(1))
    except ValueError:
        raise BVHError(source, ln, f"expected a number after '{key}:', found {m.group(1)!r}") from None
    if not np.isfinite(v):
        raise BVHError(source, ln, f"expected a finite number after '{key}:', found {m.group(1)!r}")
    return v


def _parse_motion_block(lines: list[str], first_ln: int, num_frames: int, num_channels: int, source: str):
    """Parse the frame lines into (F, C) floats; errors name the offending line."""
    data_lines = lines
    # drop trailing blank lines
    end = len(data_lines)
    while end > 0 and not data_lines[end - 1].strip():
        end -= 1
    data_lines = data_lines[:end]
    expected = num_frames * num_channels
    block = " ".join(data_lines)
    try:
        values = np.array(block.split(), dtype=float)
        ok = values.size == expected and len(data_lines) == num_frames
    except ValueError:
        ok = False
    if ok and np.all(np.isfinite(values)):
        return values.reshape(num_frames, num_channels)
    # slow path: find the first bad line and say what is wrong there
    for k, line in enumerate(data_lines):
        ln = first_ln + k
        toks = line.split()
        if k >= num_frames:
            raise BVHError(source, ln, f"more frame lines than 'Frames: {num_frames}' declares")
        if len(toks) != num_channels:
            raise BVHError(source, ln, f"expected {num_channels} values on frame {k}, found {len(toks)}")
        for t in toks:
            try:
                v = float(t)
            except ValueError:
                raise BVHError(source, ln, f"expected a number on frame {k}, found {t!r}") from None
            if not np.isfinite(v):
                raise BVHError(source, ln, f"expected a finite number on frame {k}, found {t!r}")
    raise BVHError(source, first_ln + len(data_lines),
                   f"file ends early: 'Frames: {num_frames}' declared, {len(data_lines)} frame lines found")


def parse_bvh(text: str, source: str = "<string>") -> Motion:
    """Parse BVH text into a :class:`Motion` (``source`` names the file in error messages)."""
    head, rest, motion_ln = _split_sections(text, source)
    skel = _parse_hierarchy(_Tokens(head, source))
    # skip blank lines before Frames
    k = 0
    while k < len(rest) and not rest[k].strip():
        k += 1
    if k >= len(rest):
        raise BVHError(source, motion_ln + k, "file ends early: expected 'Frames: <count>'")
    nf = _header_value(rest[k], "Frames", source, motion_ln + k + 1)
    if nf != int(nf) or nf < 1:
        raise BVHError(source, motion_ln + k + 1, f"expected a positive whole number of frames, found {nf:g}")
    if nf > _MAX_FRAMES:
        raise BVHError(source, motion_ln + k + 1, f"declared {nf:g} frames, more than the {_MAX_FRAMES} supported")
    k += 1
    if k >= len(rest):
        raise BVHError(source, motion_ln + k, "file ends early: expected 'Frame Time: <seconds>'")
    ft = _header_value(rest[k], "Frame Time", source, motion_ln + k + 1)
    if ft <= 0:
        raise BVHError(source, motion_ln + k + 1, f"frame time must be positive, found {ft:g}")
    k += 1
    num_channels = sum(len(c) for c in skel.channels)
    data = _parse_motion_block(rest[k:], motion_ln + k + 1, int(nf), num_channels, source)
    return _channels_to_motion(skel, float(ft), data)


def _channels_to_motion(skel: Skeleton, frame_time: float, data: np.ndarray) -> Motion:
    F = data.shape[0]
    J = skel.num_joints
    quats = np.zeros((F, J, 4))
    quats[..., 3] = 1.0
    trans = np.broadcast_to(skel.offsets, (F, J, 3)).copy()
    animated_translation = False
    col = 0
    for j, chans in enumerate(skel.channels):
        rot_cols, rot_order = [], ""
        for c in chans:
            kind = c[1:].lower()
            axis = "XYZ".index(c[0].upper())
            if kind == "position":
                trans[:, j, axis] = data[:, col]
                if j > 0:
                    animated_translation = True
            else:
                rot_cols.append(col)
                rot_order += c[0].upper()
            col += 1
        if rot_order:
            if len(rot_order) == 3:
                quats[:, j] = euler_to_quat(data[:, rot_cols], rot_order)
            else:  # fewer than three rotation channels: compose the ones present
                from scipy.spatial.transform import Rotation
                quats[:, j] = Rotation.from_euler(rot_order, data[:, rot_cols], degrees=True).as_quat()
    return Motion(skel, frame_time, trans[:, 0], quats, trans if animated_translation else None)


def read_bvh(path) -> Motion:
    """Read a BVH file; raises :class:`BVHError` (a ``ValueError``) naming file and line on bad input."""
    path = os.fspath(path)
    try:
        with open(path, "rb") as f:
            raw = f.read()
    except OSError as e:
        raise BVHError(path, None, f"cannot read: {e.strerror or e}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    return parse_bvh(text, path)


def _fmt(a: np.ndarray) -> np.ndarray:
    return np.char.mod("%.9g", a)


def format_bvh(motion: Motion) -> str:
    """BVH text of ``motion``, keeping each joint's channel order and the end-site offsets."""
    skel = motion.skeleton
    out = ["HIERARCHY"]

    def write_joint(j: int, depth: int):
        ind = "\t" * depth
        kw = "ROOT" if j == 0 else "JOINT"
        out.append(f"{ind}{kw} {skel.names[j]}")
        out.append(f"{ind}{{")
        o = skel.offsets[j]
        out.append(f"{ind}\tOFFSET {o[0]:.9g} {o[1]:.9g} {o[2]:.9g}")
        out.append(f"{ind}\tCHANNELS {len(skel.channels[j])}" + "".join(" " + c for c in skel.channels[j]))
        for c in skel.children(j):
            write_joint(c, depth + 1)
        if j in skel.end_sites:
            e = skel.end_sites[j]
            out.extend([f"{ind}\tEnd Site", f"{ind}\t{{", f"{ind}\t\tOFFSET {e[0]:.9g} {e[1]:.9g} {e[2]:.9g}",
                        f"{ind}\t}}"])
        out.append(f"{ind}}}")

    write_joint(0, 0)
    F = motion.num_frames
    trans = motion.translations()
    cols = []
    for j, chans in enumerate(skel.channels):
        order = "".join(c[0].upper() for c in chans if c.lower().endswith("rotation"))
        eul = quat_to_euler(motion.local_quats[:, j], order) if len(order) == 3 else None
        if order and len(order) != 3:
            from scipy.spatial.transform import Rotation
            eul = Rotation.from_quat(motion.local_quats[:, j]).as_euler(order.upper() + "".join(
                a for a in "XYZ" if a not in order.upper())[: 3 - len(order)], degrees=True)
        r = 0
        for c in chans:
            axis = "XYZ".index(c[0].upper())
            if c.lower().endswith("position"):
                cols.append(trans[:, j, axis])
            else:
                cols.append(eul[:, r])
                r += 1
    out += ["MOTION", f"Frames: {F}", f"Frame Time: {motion.frame_time:.9g}"]
    if cols:
        table = _fmt(np.stack(cols, axis=1))
        out += [" ".join(row) for row in table]
    else:
        out += [""] * F
    return "\n".join(out) + "\n"


def write_bvh(motion: Motion, path) -> None:
    """Write ``motion`` as BVH atomically (a temporary file in the same folder, then rename)."""
    path = os.fspath(path)
    text = format_bvh(motion)
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".bvh", dir=folder)
    try:
        with os.fdopen(fd, "w", newline="\n") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
