"""Fast parsing of a whitespace-separated table of decimal numbers (the BVH motion block).

``parse_table(block, rows, cols)`` returns the ``(rows, cols)`` float64 table, bit-identical to
``float(token)`` for every token, or ``None`` when it cannot certify the block (a byte outside
``[0-9.+-eE]`` and whitespace, a token pyarrow does not read as a number, a line with the wrong number of
tokens, a blank line before the last data line, a non-finite value): the caller then runs its line-by-line
parser, which finds and reports the first problem with its line number.

How: pyarrow's C++ CSV reader (a runtime dependency) reads the block with a single space as delimiter; its
float conversion (fast_float) rounds correctly, like ``float``. A block with tabs, runs of spaces or
leading spaces is first rewritten with single spaces (tabs alone: one ``translate``; runs of blanks: one
``split``/``join`` per line, ~20 ms for the 2.5 MB CMU 01_01 block) and read again. ``benchmarks/bench_io.py`` prints both figures.
"""
from __future__ import annotations

import re

import numpy as np

__all__ = ["parse_table", "parse_columns", "NUMBER_RE"]

NUMBER_RE = re.compile(rb"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\Z")

_ALLOWED = b"0123456789.-+eE \t\r\n"  # the bytes of NUMBER_RE tokens and of whitespace

# pyarrow, imported on first use (it takes ~0.1 s to import); None when it cannot be imported
_ARROW = _ARROW_CSV = None
_ARROW_TRIED = False


def _load_arrow():
    """pyarrow, imported once on first use, or ``None`` when it is not importable."""
    global _ARROW, _ARROW_CSV, _ARROW_TRIED
    if not _ARROW_TRIED:
        _ARROW_TRIED = True
        try:
            import pyarrow
            import pyarrow.csv
            _ARROW, _ARROW_CSV = pyarrow, pyarrow.csv
        except ImportError:  # pragma: no cover - a broken install: the line parser still reads the file
            pass
    return _ARROW


def _parse_with_arrow(block: bytes, rows: int, cols: int) -> np.ndarray | None:
    """The table through pyarrow's CSV reader (single spaces between values; a trailing space per line is
    tolerated); ``None`` for anything else."""
    try:
        t = _ARROW_CSV.read_csv(
            _ARROW.py_buffer(block),
            read_options=_ARROW_CSV.ReadOptions(autogenerate_column_names=True),
            parse_options=_ARROW_CSV.ParseOptions(delimiter=" ", quote_char=False, ignore_empty_lines=False),
            convert_options=_ARROW_CSV.ConvertOptions(
                column_types={f"f{k}": _ARROW.float64() for k in range(cols)}, strings_can_be_null=True,
                null_values=[""]))
    except Exception:  # noqa: BLE001 - any refusal means "not certified": the line parser decides
        return None
    if t.num_rows != rows or t.num_columns not in (cols, cols + 1):
        return None
    if t.num_columns == cols + 1 and t.column(cols).null_count != rows:  # only a trailing space allowed
        return None
    out = np.empty((cols, rows))  # column-major: each column is one contiguous copy
    for k in range(cols):
        c = t.column(k)
        if c.null_count or c.type != _ARROW.float64():
            return None
        out[k] = c.to_numpy()
    if not np.all(np.isfinite(out)):
        return None
    return out


_TAB_TO_SPACE = bytes.maketrans(b"\t", b" ")


def _single_spaced(block: bytes) -> bytes:
    """``block`` with every line's tokens joined by one space, trailing blank lines dropped (tabs alone
    are swapped for spaces in one pass; runs of blanks need a ``split``/``join`` per line)."""
    spaced = block.translate(_TAB_TO_SPACE).rstrip()
    if b"  " not in spaced and spaced[:1] != b" " and b"\n " not in spaced:
        return spaced + b"\n"
    return b"\n".join(b" ".join(line.split()) for line in spaced.split(b"\n")) + b"\n"


def parse_table(block: bytes, rows: int, cols: int) -> np.ndarray | None:
    """``(rows, cols)`` float64 table of the numbers in ``block`` (``cols`` per ``\\n``-separated line,
    trailing blank lines allowed), bit-identical to ``float``; ``None`` when it cannot certify it.
    (A transposed view of :func:`parse_columns`.)"""
    table = parse_columns(block, rows, cols)
    return None if table is None else table.T


def parse_columns(block: bytes, rows: int, cols: int) -> np.ndarray | None:
    """Like :func:`parse_table`, laid out column by column: a C-contiguous ``(cols, rows)`` array."""
    if rows < 1 or cols < 1 or not block or block.translate(None, _ALLOWED) or _load_arrow() is None:
        return None
    table = _parse_with_arrow(block, rows, cols)
    if table is None:
        spaced = _single_spaced(block)
        if spaced != block:
            table = _parse_with_arrow(spaced, rows, cols)
    return table
