"""BVH (Biovision Hierarchy) reader: :func:`read_bvh`, :func:`parse_bvh` (the writer is :mod:`.bvh_write`;
:mod:`.bvh` is the public module holding both).

Semantics: rotation channels are intrinsic Euler angles in degrees in the order they are listed
(``Zrotation Xrotation Yrotation`` means ``R = Rz Rx Ry``), any order per joint. Position channels give
the joint's translation relative to its parent and *replace* its OFFSET (as Blender and MotionBuilder
read them), on the root or on any joint. Line breaks may be LF, CRLF, CR or mixed; tokens may be
separated by tabs; numbers may have a leading dot or an exponent; joint names may contain colons.

Reading is fast and lean. Where the optional C accelerator was built (:func:`accelerated`), the motion block
is parsed by ``_cparse.parse_rows`` (plain decimal tokens only, rounded exactly as ``float``: Clinger's fast
path, else CPython's own strtod) ~500 frames at a time into a reused scratch buffer laid out so the angles
convert to quaternions without transposes; a block it does not certify goes to the path below, which
gives the same values or the error. Otherwise the motion block is cut into ~1 MB pieces at line breaks, each parsed by
:func:`._numparse.parse_lines` (vectorised tokenising and pyarrow's float conversion, bit-identical to
``float``, any spacing) and converted straight into its frames of the output arrays, which the Motion takes
without copies; the pieces are spread over the CPUs (up to 4 threads: numpy and pyarrow release the GIL).
When a piece cannot be certified, a line-by-line parser (bounded memory) finds the first bad line and
raises :class:`BVHError` naming the file, the line and what was expected. Only regular files within
:data:`._common.MAX_INPUT_BYTES` are read; frame times outside [1e-4, 3600] s, frames x joints beyond
:data:`~stagger_nb.core.motion.MAX_FRAME_JOINTS`, duplicate joint names and a second End Site under a joint
are refused. Both paths give the same bits, the sign of zero included: no quaternion component is -0, and an
angle's quaternion does not depend on the other angles of its piece.
"""
from __future__ import annotations

import os
import re
import threading

import numpy as np

from ..core.accel import NO_ACCEL_ENV, accel_allowed
from ..core.motion import MAX_FRAME_JOINTS, MAX_FRAME_TIME, MIN_FRAME_TIME, Motion, _continuous_inplace
from ..core.rotations import quat_continuous
from ..core.skeleton import Skeleton
from ._common import (
    _EULER_BLOCK,
    MAX_TOKEN,
    UTF8_BOM,
    FormatError,
    decode,
    euler_components,
    euler_deg_to_quat,
    file_path,
    finite_number,
    quarter_tan,
    read_bytes,
    split_values,
)
from ._numparse import NUMBER_RE, content_end, parse_lines

try:
    from . import _cparse  # the optional C accelerator (setup.py builds it where a compiler is found)
except ImportError:  # pragma: no cover - installed without a compiler: numpy + pyarrow parse the block
    _cparse = None

__all__ = ["BVHError", "read_bvh", "parse_bvh", "accelerated", "name_fits_bvh", "NO_ACCEL_ENV"]

def accelerated() -> bool:
    """Whether :func:`read_bvh` parses motion blocks with the C accelerator (``stagger_nb/io/_cparse.c``).
    True when it was built at install time (``pip install`` compiles it where a C compiler is found) and
    the environment variable ``STAGGER_NB_NO_ACCEL`` is unset, empty or ``0``; any other value forces the
    numpy + pyarrow path (read at every call), which gives bit-identical motions, only slower."""
    return _cparse is not None and accel_allowed()

_VALID_CHANNELS = {"xposition", "yposition", "zposition", "xrotation", "yrotation", "zrotation"}
_MAX_FRAMES = 10_000_000  # refuse absurd headers before allocating anything
_MAX_JOINTS = 10_000


class BVHError(FormatError):
    """A malformed BVH file; the message names the file, the line and what was expected."""


_TOKEN = re.compile(r"\S+")
_LINE = re.compile(r"\S[^\n]*")  # from a line's first token to its end (blank lines skipped in C)
_LONG_LINE = 4096  # characters: longer header lines are tokenised lazily, one token at a time
_SMALL_HEAD = 1 << 16  # characters: a header this short is split into its lines at once


_C_CONTINUITY: list[bool] = []  # the answer of _c_continuity, once known


def _c_continuity() -> bool:
    """Whether the C accelerator's hemisphere continuity decides exactly as numpy's ``einsum`` does here
    (:func:`~stagger_nb.core.rotations.quat_continuous`): its dot products are summed in the order
    ``(x x' + z z') + (y y' + w w')``, numpy's here (an AVX-512 build); another order (other builds or
    CPUs) is detected on pairs of quaternions whose sign of dot product depends on it, and the reader
    then keeps numpy's pass. Checked once per process (0.6 ms), on the first accelerated read."""
    if not accelerated():
        return False
    if not _C_CONTINUITY:
        # 512 pseudo-random pairs (a hash, not numpy.random: it is not imported yet), made orthogonal:
        # ~40 of them get the sign of their dot product wrong in any other summation order
        a, b = ((np.sin(np.arange(1.0, 4097.0) * 12.9898) * 43758.5453) % 1.0 - 0.5).reshape(2, 512, 1, 4)
        b = b - (np.einsum("fji,fji->fj", a, b) / np.einsum("fji,fji->fj", a, a))[..., None] * a  # dots ~ 0
        q = np.empty((2 * len(a), 1, 4))
        q[0::2], q[1::2] = b, a  # frame pairs (b, a): the odd frames' flips depend on dot(a, b) < 0
        mine = q.copy()
        _cparse.make_continuous(mine, 1)
        _C_CONTINUITY.append(np.array_equal(quat_continuous(q).view(np.int64), mine.view(np.int64)))
    return _C_CONTINUITY[0]


def _header_tokens(head: str):
    """``(token, line)`` pairs of ``head``, produced lazily: each non-blank line is split at once (the
    usual ~5 tokens), a line longer than ``_LONG_LINE`` one token at a time (a header of millions of
    junk tokens on one line is never held as a list)."""
    if len(head) <= _SMALL_HEAD:  # the usual header: split into lines at once (~2.5x faster)
        for ln, line in enumerate(head.split("\n"), 1):
            if len(line) <= _LONG_LINE:
                for t in line.split():
                    yield t, ln
            else:
                for t in _TOKEN.finditer(line):
                    yield t.group(), ln
        return
    ln, at = 1, 0
    for m in _LINE.finditer(head):
        start = m.start()
        ln += head.count("\n", at, start)
        at = start
        if m.end() - start <= _LONG_LINE:
            for t in m.group().split():
                yield t, ln
        else:
            for t in _TOKEN.finditer(head, start, m.end()):
                yield t.group(), ln


class _Tokens:
    """Whitespace tokens of the header, produced one at a time with their 1-based line numbers (see
    :func:`_header_tokens`); ``end_line`` is the line of the ``MOTION`` keyword that ends the header."""

    def __init__(self, head: str, source: str, end_line: int):
        self._it = _header_tokens(head)
        self.source = source
        self.end_line = end_line
        self._next = next(self._it, None)

    def next(self, expected: str) -> tuple[str, int]:
        if self._next is None:
            raise BVHError(self.source, self.end_line, f"hierarchy ends early: expected {expected} before 'MOTION'")
        tok = self._next
        self._next = next(self._it, None)
        return tok

    def peek(self) -> tuple[str, int] | None:
        """The next token and its line, or ``None`` at the end of the header."""
        return self._next

    def number(self, expected: str) -> float:
        tok, ln = self.next(expected)
        return finite_number(tok, expected, self.source, ln, BVHError)

    def keyword(self, word: str) -> int:
        tok, ln = self.next(repr(word))
        if tok.upper() != word.upper():
            raise BVHError(self.source, ln, f"expected {word!r}, found {tok!r}")
        return ln


def name_fits_bvh(name: str) -> bool:
    """Can a BVH file hold joint name ``name``? Names are the tokens between ``JOINT`` and ``{`` on one
    line, joined by single spaces on reading: printable characters, no lone braces, no runs of blanks.
    The reader refuses what the writer could not write back (a name read from a file always re-writes)."""
    toks = name.split()
    return bool(toks) and " ".join(toks) == name and "{" not in toks and "}" not in toks and name.isprintable()


def _parse_hierarchy(tok: _Tokens) -> Skeleton:
    """The ``HIERARCHY`` section (iterative: deep chains cannot exhaust Python's recursion limit)."""
    names, parents, offsets, channels, end_sites = [], [], [], [], {}
    name_line: dict[str, int] = {}
    src = tok.source
    tok.keyword("HIERARCHY")
    t, ln = tok.next("'ROOT'")
    if t.upper() != "ROOT":
        raise BVHError(src, ln, f"expected 'ROOT', found {t!r}")
    stack = []  # open joints
    parent = -1
    while True:
        # a joint: name, '{', OFFSET x y z, CHANNELS n names...
        name_tok, ln = tok.next("a joint name")
        if name_tok == "{":
            raise BVHError(src, ln, "expected a joint name before '{'")
        parts = [name_tok]  # some exporters put spaces in names: join tokens up to '{' on the line
        while tok.peek() is not None and tok.peek()[0] != "{" and tok.peek()[1] == ln:
            parts.append(tok.next("'{'")[0])
        if len(names) >= _MAX_JOINTS:
            raise BVHError(src, ln, f"more than {_MAX_JOINTS} joints")
        j = len(names)
        name = " ".join(parts)
        if not name_fits_bvh(name):
            raise BVHError(src, ln, f"joint name {name!r} has characters BVH names cannot hold (control "
                                    "characters, lone braces)")
        if name in name_line:
            raise BVHError(src, ln, f"joint name {name!r} is used twice (first on line {name_line[name]})")
        name_line[name] = ln
        names.append(name)
        parents.append(parent)
        tok.keyword("{")
        tok.keyword("OFFSET")
        offsets.append([tok.number("an OFFSET value") for _ in range(3)])
        t, ln = tok.next("'CHANNELS'")
        if t.upper() != "CHANNELS":
            raise BVHError(src, ln, f"expected 'CHANNELS', found {t!r}")
        n = tok.number("a channel count")
        if n != int(n) or not 0 <= n <= 6:
            raise BVHError(src, ln, f"expected a channel count from 0 to 6, found {n:g}")
        chans = []
        for _ in range(int(n)):
            c, cl = tok.next("a channel name")
            if c.lower() not in _VALID_CHANNELS:
                raise BVHError(src, cl, f"unknown channel {c!r} (expected X/Y/Z position or rotation)")
            chans.append(c[0].upper() + c[1:].lower())
        if len({c.lower() for c in chans}) != len(chans):
            raise BVHError(src, ln, f"repeated channel in {' '.join(chans)}")
        channels.append(tuple(chans))
        stack.append(j)
        # the joint's body: children, end sites, then '}' (which may close several joints)
        while True:
            t, ln = tok.next("'JOINT', 'End Site' or '}'")
            u = t.upper()
            if u == "JOINT":
                parent = stack[-1]
                break
            if u == "END":
                if stack[-1] in end_sites:
                    raise BVHError(src, ln, f"a second 'End Site' under joint {names[stack[-1]]!r} "
                                            "(a joint has at most one)")
                tok.keyword("Site")
                tok.keyword("{")
                tok.keyword("OFFSET")
                end_sites[stack[-1]] = [tok.number("an End Site OFFSET value") for _ in range(3)]
                tok.keyword("}")
            elif u == "}":
                stack.pop()
                if not stack:
                    if tok.peek() is not None:
                        t, ln = tok.peek()
                        raise BVHError(src, ln, f"expected 'MOTION' after the hierarchy, found {t!r}")
                    return Skeleton(names, parents, np.array(offsets).reshape(-1, 3), tuple(channels), end_sites)
            else:
                raise BVHError(src, ln, f"expected 'JOINT', 'End Site' or '}}', found {t!r}")


_FIRST_TOKEN = re.compile(rb"\s*(\S{0,16})")
#: Words of the format: the only first tokens an error quotes (a file that does not start with HIERARCHY is
#: not a BVH file, and its content -- a text file's first words, /etc/shadow through a link -- is not repeated)
_KEYWORDS = {b"ROOT", b"JOINT", b"END", b"SITE", b"OFFSET", b"CHANNELS", b"MOTION", b"FRAMES:", b"FRAME",
             b"TIME:", b"{", b"}"}


def _not_hierarchy(tok: bytes) -> str:
    """The error for a file whose first token ``tok`` is not ``HIERARCHY``, quoting it only if it is a word
    of the format."""
    if not tok:
        return "expected 'HIERARCHY', found nothing (an empty or blank file)"
    if tok.upper() in _KEYWORDS:
        return f"expected 'HIERARCHY', found {decode(tok)!r}"
    what = "binary data" if any(b < 32 or b == 127 for b in tok) else "other text"
    return f"expected 'HIERARCHY': not a BVH file (it starts with {what}, not quoted here)"
_MOTION_LINE = re.compile(rb"^[ \t]*MOTION[ \t\r]*$", re.MULTILINE | re.IGNORECASE)


_SCAN = 1 << 20  # bytes lower-cased at once while looking for the MOTION line (2 MB of copies)


def _find_motion_line(raw: bytes) -> int | None:
    """Offset of the start of the first ``MOTION`` line (any case, blanks around), or None. The word is
    found with ``bytes.find`` in 1 MB lower-cased pieces and each hit's line checked: 200 MB of blank lines
    or NULs take ~0.3 s (``_MOTION_LINE.search`` tries its MULTILINE ``^`` at every byte: 4-19 s)."""
    for c0 in range(0, len(raw), _SCAN):
        low = raw[c0:c0 + _SCAN + 8].lower()  # 8 bytes of overlap: a word across the cut
        i = low.find(b"motion")
        while 0 <= i < _SCAN:
            at = raw.rfind(b"\n", 0, c0 + i) + 1
            if _MOTION_LINE.match(raw, at):  # the whole line, on the file's bytes
                return at
            i = low.find(b"motion", i + 1)
    return None


def _normalise_breaks(raw: bytes) -> bytes:
    """Bytes whose line breaks are all ``\n`` (optionally after ``\r``): a lone ``\r`` (classic Mac)
    becomes ``\n``. Unchanged (no copy) for LF / CRLF / mixed LF-CRLF files. Line numbers in errors
    count ``\n``, ``\r\n`` and lone ``\r`` as one break each."""
    if b"\r" not in raw or raw.count(b"\r") == raw.count(b"\r\n"):
        return raw
    return raw.replace(b"\r\n", b"\n").replace(b"\r", b"\n")


def _header_value(line: bytes, key: str, source: str, ln: int) -> float:
    text = decode(line).strip()
    pattern = key.replace(" ", r"\s+")  # 'Frame Time' may be split by a tab
    m = re.fullmatch(rf"{pattern}\s*:\s*(\S+)", text, flags=re.IGNORECASE)
    if not m:
        raise BVHError(source, ln, f"expected '{key}: <number>', found {text!r}")
    return finite_number(m.group(1), f"'{key}:'", source, ln, BVHError)


def _parse_motion_lines(block: bytes, first_ln: int, num_frames: int, num_channels: int, source: str,
                        start: int = 0, first_frame: int = 0):
    """Line-by-line parse of the frame lines ``block[start:]`` (frames ``first_frame`` on, the first on
    line ``first_ln``) into ``(num_frames - first_frame, C)`` floats; raises :class:`BVHError` at the first
    bad line (the reference for :func:`parse_table`, and the fallback where a piece cannot be certified).
    Lines are taken one at a time and split into at most ``C + 1`` pieces, so a hostile block (millions
    of blank lines, a line of millions of values) costs no more memory than its output."""
    stop = _data_end(block, start)
    out = np.empty((max(0, min(num_frames - first_frame, block.count(b"\n", start, stop) + 1)), num_channels))
    first_ln -= first_frame  # so that frame k is on line first_ln + k
    k, pos = first_frame, start
    longest = (num_channels + 1) * (MAX_TOKEN + 1)
    while pos < stop:
        nl = block.find(b"\n", pos, stop)
        end = stop if nl < 0 else nl
        line = block[pos:min(end, pos + longest)]  # a prefix: enough to find C + 1 tokens of sane length
        pos = end + 1
        ln = first_ln + k
        if k >= num_frames:
            raise BVHError(source, ln, f"more frame lines than 'Frames: {num_frames}' declares")
        toks = split_values(line, num_channels, len(line) == longest, f"on frame {k}", source, ln, BVHError)
        for c, t in enumerate(toks):
            if not NUMBER_RE.match(t):
                raise BVHError(source, ln, f"expected a number on frame {k}, found {decode(t[:40])!r}")
            v = float(t)
            if not np.isfinite(v):
                raise BVHError(source, ln, f"expected a finite number on frame {k}, found {decode(t[:40])!r}")
            out[k - first_frame, c] = v
        k += 1
    if k < num_frames:
        raise BVHError(source, first_ln + max(k - 1, 0),
                       f"file ends early: 'Frames: {num_frames}' declared, {k} frame lines found")
    return out


def _next_line(raw: bytes, pos: int) -> tuple[bytes, int]:
    """The line starting at ``pos`` and the position after its ``\n``."""
    nl = raw.find(b"\n", pos)
    if nl < 0:
        return raw[pos:], len(raw)
    return raw[pos:nl], nl + 1


def parse_bvh(text: str | bytes, source: str = "<string>", *, max_samples: int | None = None) -> Motion:
    """Parse BVH text (``str`` or the file's ``bytes``) into a :class:`Motion`; ``source`` names the file
    in error messages. ``max_samples``: most frames x joints allocated (default
    :data:`~stagger_nb.core.motion.MAX_FRAME_JOINTS`, 32 bytes of rotation each)."""
    limit = MAX_FRAME_JOINTS if max_samples is None else _positive_int(max_samples, "max_samples")
    raw = text.encode("utf-8") if isinstance(text, str) else bytes(text)
    if raw[:3] == UTF8_BOM:  # a byte-order mark some Windows tools write
        raw = raw[3:]
    first = _FIRST_TOKEN.match(raw)  # a file that does not start with HIERARCHY is refused before any scan
    if first.group(1).upper() != b"HIERARCHY":  # (a 255 MB file of NULs: 9 s of searching for 'MOTION')
        ln = _normalise_breaks(raw[:first.start(1)]).count(b"\n") + 1
        raise BVHError(source, ln, _not_hierarchy(first.group(1)))
    raw = _normalise_breaks(raw)
    motion_at = _find_motion_line(raw)
    if motion_at is None:
        last = raw.count(b"\n") + (0 if raw.endswith(b"\n") else 1)
        raise BVHError(source, max(last, 1), "no 'MOTION' section found")
    head = decode(memoryview(raw)[:motion_at])
    ln = head.count("\n") + 1  # the MOTION line
    skel = _parse_hierarchy(_Tokens(head, source, ln))
    del head
    line, pos = _next_line(raw, motion_at)
    while True:  # blank lines may precede 'Frames:'
        if pos >= len(raw):
            raise BVHError(source, ln, "file ends early: expected 'Frames: <count>'")
        line, pos = _next_line(raw, pos)
        ln += 1
        if line.strip():
            break
    nf = _header_value(line, "Frames", source, ln)
    if nf != int(nf) or nf < 1:
        raise BVHError(source, ln, f"expected a positive whole number of frames, found {nf:g}")
    if nf > _MAX_FRAMES:
        raise BVHError(source, ln, f"declared {nf:g} frames, more than the {_MAX_FRAMES} supported")
    nf = int(nf)
    if nf * skel.num_joints > limit:  # joints without channels cost memory but no text
        raise BVHError(source, ln, f"declared {nf} frames x {skel.num_joints} joints, more than the "
                                   f"{limit:,} joint samples allowed"
                                   + (" by default: pass max_samples= to read_bvh to read it anyway (32 bytes "
                                      "of rotations per joint sample), or split the take" if max_samples is None
                                      else ""))
    if pos >= len(raw):
        raise BVHError(source, ln, "file ends early: expected 'Frame Time: <seconds>'")
    line, pos = _next_line(raw, pos)
    ln += 1
    ft = _header_value(line, "Frame Time", source, ln)
    if ft <= 0:
        raise BVHError(source, ln, f"frame time must be positive, found {ft:g}")
    if not MIN_FRAME_TIME <= ft <= MAX_FRAME_TIME:  # see core.motion: a corrupt value, not a capture rate
        raise BVHError(source, ln, f"frame time {ft:g} s is outside the {MIN_FRAME_TIME:g}-{MAX_FRAME_TIME:g} s "
                                   f"supported (at most {1 / MIN_FRAME_TIME:g} frames per second)")
    num_channels = sum(len(c) for c in skel.channels)
    layout = _Layout(skel)
    stop = _data_end(raw, pos)
    out, done, continuous = None, 0, False
    if num_channels == 0:
        if stop == pos:
            out, done = layout.empty(nf), nf
    elif stop - pos >= 2 * nf * num_channels - 1:  # a value and its separator take >= 2 bytes: a block that
        # cannot hold the declared values allocates nothing (the line parser reports where it ends)
        out = layout.empty(nf)
        if accelerated() and layout.read_accelerated(raw, pos, stop, nf, out):
            pos, done = stop, nf
            if _c_continuity():  # one C pass instead of numpy's einsum + mask (~0.85 -> ~0.2 ms on CMU 01_01)
                _cparse.make_continuous(out[1], skel.num_joints)
                continuous = True
        else:  # no accelerator, or a block it does not certify: today's parser (same values, or the error)
            pos, done = _read_chunks(raw, pos, stop, nf, num_channels, layout, out)
    if done < nf or pos < stop:  # the line-by-line parser reads the rest, or reports its first bad line
        data = _parse_motion_lines(raw, ln + 1 + done, nf, num_channels, source, start=pos, first_frame=done)
        if out is None:
            out = layout.empty(nf)
        layout.fill(data.T, done, out)
    root_pos, quats, trans = out
    if not continuous:
        _continuous_inplace(quats)
    # no negative zeros: every -0 component becomes +0 (nothing else changes), after the sign flips of
    # continuity, so the two paths (and any cut of the block) agree on the sign of zero by construction
    quats += 0.0
    return Motion._from_owned(skel, float(ft), root_pos, quats, trans, continuous=True)


_ACCEL_VALUES = 1 << 16  # values per piece of the C parser's read (a 512 KB scratch buffer, reused)
_PIECE_BYTES = 1 << 20  # the motion block is parsed and converted in pieces of about this size ...
_MIN_PIECE_BYTES = 1 << 18  # ... split among the CPUs, but no smaller than this (a thread hand-off costs ~0.1 ms)
_MAX_PIECE_BYTES = 4 << 20  # a piece this long (one huge line) goes to the line parser: bounded memory


def _data_end(raw: bytes, pos: int) -> int:
    """The end of the last non-blank byte of ``raw[pos:]`` (trailing blank lines are allowed)."""
    return pos + content_end(memoryview(raw)[pos:])


def _pieces(raw: bytes, pos: int, stop: int, workers: int) -> list[tuple[int, int]]:
    """``[pos, stop)`` cut after line breaks into pieces of about ``_PIECE_BYTES`` (at least ``workers``
    of them when each still gets ``_MIN_PIECE_BYTES``)."""
    size = stop - pos
    n = max(1, min(-(-size // _MIN_PIECE_BYTES), max(workers, -(-size // _PIECE_BYTES))))
    step = -(-size // n)
    out = []
    while pos < stop:
        nl = raw.find(b"\n", min(pos + step, stop), stop)
        end = stop if nl < 0 else nl + 1
        out.append((pos, end))
        pos = end
    return out


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # not on Linux
        return os.cpu_count() or 1


_MAX_THREADS = 4
_POOL = None
_POOL_PID = None


def _pool(workers: int):
    """A thread pool of ``workers - 1`` threads (the caller's thread is the other one), created once per
    process (a forked child makes its own: threads do not survive ``fork``)."""
    global _POOL, _POOL_PID
    if _POOL is None or _POOL_PID != os.getpid():
        from concurrent.futures import ThreadPoolExecutor
        _POOL = ThreadPoolExecutor(max_workers=workers - 1, thread_name_prefix="stagger_nb-read_bvh")
        _POOL_PID = os.getpid()
    return _POOL


def _read_chunks(raw: bytes, pos: int, stop: int, nf: int, C: int, layout: _Layout, out) -> tuple[int, int]:
    """Parse ``raw[pos:stop]`` (``nf`` lines of ``C`` numbers) piece by piece with
    :func:`._numparse.parse_lines`, each piece converted into its frames of ``out`` at once, the pieces
    spread over the CPUs (numpy and pyarrow release the GIL). Returns ``(position, frames)``: where the
    first piece that could not be certified starts and the frames before it (``(stop, nf)`` when all
    were), so the line-by-line parser reads or reports only the rest: a bad last line of a long take
    costs one piece of slow parsing, not the whole file.

    A piece's first frame is the sum of the line counts of the pieces before it, which each piece
    publishes as soon as it is parsed; pieces start in order, so a piece only ever waits for pieces that
    have already started."""
    workers = min(_cpus(), _MAX_THREADS)
    bounds = _pieces(raw, pos, stop, workers)
    n = len(bounds)
    rows = [-1] * n
    parsed = [threading.Event() for _ in range(n)]
    view = memoryview(raw)

    def piece(k: int) -> bool:
        a, b = bounds[k]
        try:
            data = parse_lines(view[a:b], C, max_rows=nf) if b - a <= _MAX_PIECE_BYTES else None
            if data is not None:
                rows[k] = data.shape[1]
        finally:
            parsed[k].set()
        if data is None:
            return False
        first = 0
        for j in range(k):
            parsed[j].wait()
            if rows[j] < 0:
                return False
            first += rows[j]
        if first + rows[k] > nf:
            return False
        layout.fill(data, first, out)
        return True

    if n == 1 or workers == 1:
        ok = []
        for k in range(n):
            ok.append(piece(k))
            if not ok[-1]:
                break
    else:
        futures = [_pool(workers).submit(piece, k) for k in range(1, n)]
        ok = [False]
        try:
            ok[0] = piece(0)
        finally:  # no thread may still write into ``out`` when this returns
            ok += [f.result() for f in futures]
    first_bad = next((k for k, good in enumerate(ok) if not good), None)
    if first_bad is None:
        return stop, sum(rows)
    return bounds[first_bad][0], sum(rows[:first_bad])


class _Layout:
    """Where each column of the ``(F, C)`` channel table goes: root position axes, animated joint
    translations, and rotations grouped by channel order (one vectorised conversion per order)."""

    def __init__(self, skel: Skeleton):
        self.skel = skel
        self.root_pos, self.trans = [], []  # (axis, col), (joint, axis, col)
        groups: dict[str, tuple[list, list]] = {}
        col = 0
        for j, chans in enumerate(skel.channels):
            rot_cols, order = [], ""
            for c in chans:
                axis = "XYZ".index(c[0].upper())
                if c[1:].lower() == "position":
                    (self.root_pos.append((axis, col)) if j == 0 else self.trans.append((j, axis, col)))
                else:
                    rot_cols.append(col)
                    order += c[0].upper()
                col += 1
            if order:
                joints, cols = groups.setdefault(order, ([], []))
                joints.append(j)
                cols.append(rot_cols)
        J = skel.num_joints
        self.groups = [(order, joints, np.array(cols)) for order, (joints, cols) in groups.items()]
        # every joint in one order and in file order: the conversion writes the output rows directly
        self.direct = len(self.groups) == 1 and self.groups[0][1] == list(range(J))
        self.num_channels = col
        self._plan = None

    def _accel_plan(self):
        """Where the C parser puts each column of a piece of ``R`` frames in its scratch buffer: position
        columns as an ``(R, P)`` table, then per rotation group (order, joints ``Jg``, ``L`` angles) an
        ``(L, R, Jg)`` table, frame-major within each angle: the layout the conversion writes from
        without transposes. ``(R, base (C,), stride (C,), group offsets, scratch size)``."""
        if self._plan is None:
            C = self.num_channels
            rotating = sum(len(joints) for _, joints, _ in self.groups)  # a piece's rotations: one block of
            R = max(1, min(_ACCEL_VALUES // C, _EULER_BLOCK // max(1, rotating)))  # euler_components
            base, stride = np.empty(C, np.int64), np.empty(C, np.int64)
            pos_cols = [col for _, col in self.root_pos] + [col for _, _, col in self.trans]
            base[pos_cols] = np.arange(len(pos_cols))
            stride[pos_cols] = len(pos_cols)
            off, offsets = R * len(pos_cols), []
            for _, _, cols in self.groups:
                Jg, L = cols.shape
                for k in range(L):
                    base[cols[:, k]] = off + k * R * Jg + np.arange(Jg)
                    stride[cols[:, k]] = Jg
                offsets.append(off)
                off += L * R * Jg
            self._plan = R, base, stride, offsets, off
        return self._plan

    def read_accelerated(self, raw: bytes, pos: int, stop: int, nf: int, out) -> bool:
        """Parse ``raw[pos:stop]`` (``nf`` lines of ``C`` numbers) with the C parser, ``R`` frames at a
        time into one reused scratch buffer, each piece converted into its frames of ``out`` at once
        (numpy's tan, then the rest of :func:`euler_components` in C: the same bits).
        False when the C parser does not certify the block (``out`` is then partly written: the caller
        parses the block again, which rewrites every value it sets)."""
        R, base, stride, offsets, size = self._accel_plan()
        scratch = np.empty(size)
        tmp = np.empty(3 * R * max([len(joints) for _, joints, _ in self.groups] + [0]))  # quarter_tan's scratch
        root_pos, quats, trans = out
        P = len(self.root_pos) + len(self.trans)
        row = 0
        while row < nf:
            n = min(R, nf - row)
            pos = _cparse.parse_rows(raw, pos, stop, n, scratch, base, stride)
            if pos < 0:
                return False
            sl = slice(row, row + n)
            if P:
                table = scratch[:R * P].reshape(R, P)
                for p, (axis, _) in enumerate(self.root_pos):
                    root_pos[sl, axis] = table[:n, p]
                for p, (j, axis, _) in enumerate(self.trans, len(self.root_pos)):
                    trans[sl, j, axis] = table[:n, p]
                if trans is not None:
                    trans[sl, 0] = root_pos[sl]
            for (order, joints, cols), off in zip(self.groups, offsets):
                Jg, L = cols.shape
                ang = scratch[off:off + L * R * Jg].reshape(L, R, Jg)[:, :n]  # (L, n, Jg) degrees
                if L == 3 and len(set(order)) == 3:
                    # numpy's tan (its bits), then the rest of euler_components in one C loop (same operations)
                    t = quarter_tan(ang.reshape(3, -1), tmp[:3 * n * Jg].reshape(3, -1))
                    if n < R:  # the last piece: three rows at a stride of R * Jg
                        t = np.ascontiguousarray(t)
                    if self.direct:  # rotation (frame, joint) is row frame * J + joint of the output
                        _cparse.quats_from_tangents(t, order, quats[sl].reshape(-1, 4))
                    else:
                        q = np.empty((n * Jg, 4))
                        _cparse.quats_from_tangents(t, order, q)
                        quats[sl, joints] = q.reshape(n, Jg, 4)
                else:
                    quats[sl, joints] = euler_deg_to_quat(np.moveaxis(ang, 0, -1), order)
            row += n
        return pos == stop

    def empty(self, F: int):
        """Output arrays for ``F`` frames: root positions ``(F, 3)`` (the root OFFSET where not animated),
        local quaternions ``(F, J, 4)`` (identity where a joint has no rotation channels) and joint
        translations ``(F, J, 3)`` or ``None``."""
        skel, J = self.skel, self.skel.num_joints
        root_pos = np.empty((F, 3))
        root_pos[:] = skel.offsets[0]
        if self.direct:
            quats = np.empty((F, J, 4))
        else:
            quats = np.zeros((F, J, 4))
            quats[..., 3] = 1.0
        trans = None
        if self.trans:
            trans = np.empty((F, J, 3))
            trans[:] = skel.offsets
        return root_pos, quats, trans

    def fill(self, data: np.ndarray, row: int, out) -> None:
        """Convert the table ``data (C, n)`` (column-major: one row per channel) into frames
        ``[row, row + n)`` of ``out``."""
        root_pos, quats, trans = out
        sl = slice(row, row + data.shape[1])
        for axis, col in self.root_pos:
            root_pos[sl, axis] = data[col]
        for j, axis, col in self.trans:
            trans[sl, j, axis] = data[col]
        if trans is not None:
            trans[sl, 0] = root_pos[sl]
        for order, joints, cols in self.groups:
            dst = quats[sl] if self.direct else np.empty((data.shape[1], len(joints), 4))
            if len(order) == 3 and len(set(order)) == 3:  # (3, joints, n) angles -> (4, joints, n) components
                comps = euler_components(data[cols.T], order)
                for c in range(4):  # one 2-D transpose per component: ~4x faster than numpy's 3-D one
                    dst[..., c] = comps[c].T
            else:
                dst[...] = euler_deg_to_quat(data[cols].transpose(2, 0, 1), order)
            if not self.direct:
                quats[sl, joints] = dst


def _positive_int(value, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name} must be a positive whole number, got {value!r}")
    return int(value)


def read_bvh(path, *, max_bytes: int | None = None, max_samples: int | None = None) -> Motion:
    """Read a BVH file into a :class:`Motion` (see the module docstring for the semantics).

    Returns a Motion with ``root_positions (F, 3)`` (file units), ``local_quats (F, J, 4)`` (x, y, z, w),
    ``local_translations (F, J, 3)`` when non-root joints have position channels (else ``None``),
    ``frame_time`` in seconds, and a Skeleton keeping each joint's channel layout and end sites.

    Raises :class:`BVHError` (a ``ValueError``) naming the file, the line and what was expected: bad
    numbers, NaN/inf, wrong value counts, unknown channels, unbalanced braces, ``Frames:`` disagreeing
    with the data, a frame time <= 0, absurd declared sizes (nothing is allocated from them).

    The size limits protect a notebook from a file that would exhaust memory; raise them per call for a
    take known to be larger: ``max_bytes`` (default :data:`~stagger_nb.io._common.MAX_INPUT_BYTES`, 256 MiB)
    and ``max_samples`` (frames x joints, default :data:`~stagger_nb.core.motion.MAX_FRAME_JOINTS`).
    """
    path = file_path(path, "path")
    if max_bytes is not None:
        max_bytes = _positive_int(max_bytes, "max_bytes")
    return parse_bvh(read_bytes(path, BVHError, max_bytes), path, max_samples=max_samples)
