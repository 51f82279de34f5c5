"""The text of a BVH file before its motion block: :class:`BVHError`, the HIERARCHY's tokens and its
:class:`~stagger_nb.core.skeleton.Skeleton` (:func:`_parse_hierarchy`), joint names (:func:`name_fits_bvh`),
line breaks, the MOTION line and the ``Frames:`` / ``Frame Time:`` values. Every error names the file and line."""
from __future__ import annotations

import re

import numpy as np

from ..core.skeleton import Skeleton
from ._common import (
    FormatError,
    decode,
    finite_number,
)

_VALID_CHANNELS = {"xposition", "yposition", "zposition", "xrotation", "yrotation", "zrotation"}


_MAX_JOINTS = 10_000


class BVHError(FormatError):
    """A malformed BVH file; the message names the file, the line and what was expected."""


_TOKEN = re.compile(r"\S+")


_LINE = re.compile(r"\S[^\n]*")  # from a line's first token to its end (blank lines skipped in C)


_LONG_LINE = 4096  # characters: longer header lines are tokenised lazily, one token at a time


_SMALL_HEAD = 1 << 16  # characters: a header this short is split into its lines at once


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


def _next_line(raw: bytes, pos: int) -> tuple[bytes, int]:
    """The line starting at ``pos`` and the position after its ``\n``."""
    nl = raw.find(b"\n", pos)
    if nl < 0:
        return raw[pos:], len(raw)
    return raw[pos:nl], nl + 1
