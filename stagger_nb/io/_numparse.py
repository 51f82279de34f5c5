"""Fast parsing of a whitespace-separated table of decimal numbers (the BVH motion block).

``parse_columns(block, rows, cols)`` returns the ``(cols, rows)`` float64 table (column-major), bit-identical
to ``float(token)`` for every token, or ``None`` when it cannot certify the block (a token that is not a
finite decimal number, a line with the wrong number of tokens, a blank line before the last data line, a
control byte other than ASCII whitespace between tokens): the caller then runs its line-by-line parser, which
finds and reports the first problem with its line number. ``parse_table`` is its ``(rows, cols)`` view.

How, in four vectorised passes and no Python loop over lines or tokens:

1. ``np.flatnonzero(bytes <= 32)``: the position of every whitespace byte (the token separators);
2. an Arrow string array is laid over the block without copying it: entry ``2i`` is the text between
   separators ``i - 1`` and ``i`` (a token, or empty where separators are adjacent: runs of blanks, tabs,
   CRLF), entry ``2i + 1`` the separator itself; separators and empty entries are marked null;
3. ``pyarrow.compute.cast(..., float64)`` converts the tokens with fast_float, which rounds correctly like
   ``float`` and refuses anything that is not a number (``1_0``, ``4-``, full-width digits, quotes);
4. the line structure is checked on the separators: the ``r``-th line break comes after exactly
   ``(r + 1) * cols`` tokens.

pyarrow is a runtime dependency; without it (a broken install) everything goes through the line parser.
``benchmarks/bench_io.py`` times this against ``np.loadtxt`` (what pybvh uses) and the line parser.
"""
from __future__ import annotations

import re
import threading

import numpy as np

__all__ = ["parse_table", "parse_columns", "parse_lines", "content_end", "NUMBER_RE"]

NUMBER_RE = re.compile(rb"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\Z")

# pyarrow, imported on first use (it takes ~0.1 s to import); None when it cannot be imported
_ARROW = _ARROW_CAST = None
_ARROW_TRIED = False


_ARROW_LOCK = threading.Lock()


def _load_arrow():
    """pyarrow, imported once on first use, or ``None`` when it is not importable. Thread-safe: the
    pieces of the first file read are parsed on several threads at once, and a thread must not see
    "tried" before the import has finished."""
    global _ARROW, _ARROW_CAST, _ARROW_TRIED
    if not _ARROW_TRIED:
        with _ARROW_LOCK:
            if not _ARROW_TRIED:
                try:
                    import pyarrow
                    import pyarrow.compute
                    _ARROW, _ARROW_CAST = pyarrow, pyarrow.compute.cast
                except ImportError:  # pragma: no cover - a broken install: the line parser still reads the file
                    pass
                _ARROW_TRIED = True
    return _ARROW


def content_end(block) -> int:
    """The end of the last non-whitespace byte of ``block`` (bytes or memoryview; whitespace as
    ``bytes.split`` has it), looking only at its tail: trailing blank lines are allowed, nothing large is
    copied."""
    end = len(block)
    while end > 0:
        start = max(0, end - 4096)
        kept = len(bytes(block[start:end]).rstrip())
        if kept:
            return start + kept
        end = start
    return 0


def parse_table(block, rows: int, cols: int) -> np.ndarray | None:
    """``(rows, cols)`` float64 table of the numbers in ``block`` (``cols`` per ``\\n``-separated line,
    trailing blank lines allowed), bit-identical to ``float``; ``None`` when it cannot certify it.
    (A transposed view of :func:`parse_columns`.)"""
    table = parse_columns(block, rows, cols)
    return None if table is None else table.T


def parse_columns(block, rows: int, cols: int) -> np.ndarray | None:
    """Like :func:`parse_table`, laid out column by column: a C-contiguous ``(cols, rows)`` array.
    ``block`` is ``bytes`` or a ``memoryview`` of bytes (not copied)."""
    if rows < 1:
        return None
    table = parse_lines(block, cols)
    return table if table is not None and table.shape[1] == rows else None


def parse_lines(block, cols: int, max_rows: int | None = None) -> np.ndarray | None:
    """The ``(cols, rows)`` table of a block of lines of ``cols`` numbers each, however many lines it has
    (trailing blank lines allowed); ``None`` when it cannot certify it (see the module docstring), and
    at once, before allocating by the line count, when it has more than ``max_rows`` lines or more than
    16 whitespace bytes per value of ``max_rows`` lines (millions of blank lines, megabytes of blanks)."""
    if cols < 1 or _load_arrow() is None:
        return None
    n = content_end(block)
    if n == 0 or n >= 1 << 31:  # Arrow string offsets are 32-bit: the callers' pieces are far smaller
        return None
    buf = np.frombuffer(block, np.uint8, count=n)
    if max_rows is not None:  # line breaks counted in 64 KB steps: no temporary the size of the block
        breaks = 0
        for i in range(0, n, 1 << 16):
            breaks += np.count_nonzero(buf[i:i + (1 << 16)] == 10)
            if breaks >= max_rows:
                return None
    blank = buf <= 32
    if max_rows is not None and np.count_nonzero(blank) >= 16 * max_rows * cols:
        return None
    sep = np.flatnonzero(blank)  # (T - 1,) separators; a virtual line break ends the last line
    del blank
    T = len(sep) + 1
    what = buf[sep]
    if len(sep) and not np.all((what == 32) | ((what >= 9) & (what <= 13))):
        return None  # a control byte that is not whitespace: the line parser names it
    breaks = np.flatnonzero(what == 10)  # separators that end a line
    rows = len(breaks) + 1
    # entry 2i: bytes (sep[i-1], sep[i]) -- a token, or empty; entry 2i+1: separator i (null)
    off = np.empty(2 * T + 1, np.int32)
    off[0] = 0
    off[1:-2:2] = sep
    off[2:-1:2] = sep
    off[2:-1:2] += 1
    off[-2] = off[-1] = n
    del sep, what
    tokens = off[1::2] > off[0:-1:2]
    all_tokens = T == rows * cols  # then every entry must be a token (no empty ones): the usual file
    if all_tokens:
        if not np.all(tokens):
            return None
        valid = np.full((2 * T + 7) // 8, 0x55, np.uint8)
    else:
        bits = np.zeros(2 * T, bool)
        bits[0::2] = tokens
        valid = np.packbits(bits, bitorder="little")
        del bits
    pa = _ARROW
    arr = pa.Array.from_buffers(pa.string(), 2 * T, [pa.py_buffer(valid), pa.py_buffer(off), pa.py_buffer(block)])
    try:
        res = _ARROW_CAST(arr, pa.float64())
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        return None  # a token that is not a number
    del arr, off, valid
    vals = np.frombuffer(res.buffers()[1], np.float64, count=2 * T)[0::2]
    # line structure: the r-th line break follows token (r + 1) * cols
    if all_tokens:  # separator i follows token i
        if np.any(breaks != np.arange(cols - 1, (rows - 1) * cols, cols)):
            return None
    else:
        count = np.cumsum(tokens)  # tokens up to and including entry i
        # a blank line (also a leading one) leaves two breaks after the same token
        if count[-1] != rows * cols or np.any(count[breaks] != np.arange(cols, rows * cols, cols)):
            return None
        del count
        vals = vals[tokens]
    table = vals.reshape(rows, cols)
    if not np.all(np.isfinite(table)):
        return None
    return np.ascontiguousarray(table.T)
