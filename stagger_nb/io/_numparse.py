"""Vectorised parsing of a whitespace-separated table of decimal numbers (the BVH motion block).

``parse_table(block, rows, cols)`` returns the ``(rows, cols)`` float64 table, bit-identical to
``float(token)`` for every token, or ``None`` when it cannot certify the block (a token outside the
grammar ``[+-]?(\\d+\\.?\\d*|\\.\\d+)([eE][+-]?\\d+)?``, a line with the wrong number of tokens, a blank
line before the last data line, a stray control byte): the caller then runs its line-by-line parser,
which finds and reports the first problem with its line number.

How (numpy only, no Python loop over tokens): token boundaries come from the whitespace mask. For plain
``[-]digits[.digits]`` tokens, each token's bytes are loaded as two little-endian 8-byte words, the dot
is found and turned into '0' with SWAR byte tests, and the digits are packed into an integer with three
multiply-shift steps per word (exact below 2**53). Blocks with exponents map every '.', sign and 'e' to
its token through a running token index and pack the mantissa and exponent digits the same way. The
value is then ``M * 10**k`` or ``M / 10**-k`` with ``|k| <= 22``: both factors are exact doubles, so the
single IEEE operation rounds correctly and equals ``float(token)`` (Clinger's fast path). Tokens outside
that range (more than 15 significant digits, huge exponents) are converted with ``float`` one by one.
When pyarrow is installed its CSV reader (correctly rounded as well) is tried first.
"""
from __future__ import annotations

import re

import numpy as np

__all__ = ["parse_table", "NUMBER_RE"]

NUMBER_RE = re.compile(rb"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?\Z")
_POW10 = 10.0 ** np.arange(23)  # exact doubles 1 .. 1e22
_MAX_DIGITS = 15  # 10**15 < 2**53: integers of up to 15 digits (plus the dot read as a 0) are exact

_ALLOWED = b"0123456789.-+eE \t\r\n"


_POW10_U64 = 10 ** np.arange(9, dtype=np.uint64)
_M8 = np.uint64(0x00FF00FF00FF00FF)
_M16 = np.uint64(0x0000FFFF0000FFFF)
_M32 = np.uint64(0x00000000FFFFFFFF)


def _swar8(x: np.ndarray) -> np.ndarray:
    """Eight decimal digits held one per byte of a little-endian ``uint64`` (first digit in the lowest
    byte) -> their integer value: pairs, then quads, then octets combined in place (SIMD within a word)."""
    x = (x * np.uint64(10) + (x >> np.uint64(8))) & _M8
    x = (x * np.uint64(100) + (x >> np.uint64(16))) & _M16
    return (x * np.uint64(10000) + (x >> np.uint64(32))) & _M32


def _span_integers(digits: np.ndarray, starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Integer value (float64) of the bytes ``digits[s:s+l]`` of each span (bytes are digit values
    0..9; non-digits must already be 0 so they read as a 0 digit), for ``1 <= l <= 16``; exact while the
    value is below 2**53. ``digits`` must have 16 spare zero bytes after the last span."""
    if starts.size == 0:
        return np.zeros(0)
    words = np.ndarray((digits.size - 7,), dtype="<u8", buffer=digits, strides=(1,))  # unaligned loads
    L = np.asarray(lengths, dtype=np.int64)
    short = L <= 8
    # bytes past the span sit in the high end of the word: shifting left drops them and feeds zeros in
    # at the low (most significant decimal) end, i.e. harmless leading zeros
    a = _swar8(words[starts] << (8 * np.clip(8 - L, 0, 7)).astype(np.uint64))
    if np.all(short):
        return a.astype(np.float64)
    b = _swar8(words[starts + 8] << (8 * np.clip(16 - L, 0, 7)).astype(np.uint64))
    scale = _POW10_U64[np.clip(L - 8, 0, 8)]
    return np.where(short, a, a * scale + b).astype(np.float64)  # b unused (and wrong) where short


def _with_exponents(b, block, starts, ends, edge, nonws):
    """Tokens of a block with 'e'/'E'/'+': per token (negative, mantissa body length, fraction digits, has
    a dot, decimal exponent ``k``, mantissa read with the dot as a 0 digit); ``None`` if a token breaks
    the grammar."""
    n = starts.size
    digits = np.zeros(b.size + 16, dtype=np.uint8)  # digit values, 0 elsewhere, 16 spare bytes
    np.subtract(b, np.uint8(48), out=digits[:b.size])
    digits[:b.size] *= digits[:b.size] < 10
    tok_id = np.cumsum(edge[:-1] & nonws, dtype=np.int32) - 1  # token of every byte (of tokens)
    dots = np.flatnonzero(b == 46)
    dot_tok = tok_id[dots]
    if dot_tok.size > 1 and np.any(dot_tok[1:] == dot_tok[:-1]):
        return None  # two dots in a token
    signs = np.flatnonzero((b == 45) | (b == 43))
    exps = np.flatnonzero((b | 32) == 101)
    sign_tok, exp_tok = tok_id[signs], tok_id[exps]
    if exp_tok.size > 1 and np.any(exp_tok[1:] == exp_tok[:-1]):
        return None  # two exponents in a token
    mant_end = ends.copy()  # mantissa [starts, mant_end), exponent (mant_end, ends)
    mant_end[exp_tok] = exps
    if np.any(dots > mant_end[dot_tok]):
        return None  # a '.' in the exponent
    lead = signs == starts[sign_tok]  # a sign leads its token or follows its 'e'
    after_e = ~lead
    if np.any(signs[after_e] - 1 != mant_end[sign_tok[after_e]]):
        return None
    neg = np.zeros(n, dtype=bool)
    neg[sign_tok[lead]] = b[signs[lead]] == 45
    has_sign = np.zeros(n, dtype=np.int64)
    has_sign[sign_tok[lead]] = 1
    has_dot = np.zeros(n, dtype=bool)
    has_dot[dot_tok] = True
    nfrac = np.zeros(n, dtype=np.int64)
    nfrac[dot_tok] = mant_end[dot_tok] - dots - 1
    exponent = np.zeros(n, dtype=np.int64)
    exp_sign = np.zeros(n, dtype=np.int64)
    exp_neg = np.zeros(n, dtype=bool)
    exp_sign[sign_tok[after_e]] = 1
    exp_neg[sign_tok[after_e]] = b[signs[after_e]] == 45
    e_len = ends[exp_tok] - exps - 1
    e_digits = e_len - exp_sign[exp_tok]
    if np.any(e_digits < 1):
        return None  # 'e' without exponent digits
    ok_e = e_digits <= 4  # longer exponents go through float()
    ev = _span_integers(digits, exps[ok_e] + 1, e_len[ok_e]).astype(np.int64)
    exponent[exp_tok[ok_e]] = np.where(exp_neg[exp_tok[ok_e]], -ev, ev)
    exponent[exp_tok[~ok_e]] = 10_000  # outside the fast range
    body = mant_end - starts - has_sign  # digits and the dot
    v = _span_integers(digits, starts + has_sign, np.clip(body, 1, 16))
    return neg, body, nfrac, has_dot, exponent - nfrac, v


_FILL = np.uint64(0x3030303030303030)  # eight ASCII '0'
_DOTS = np.uint64(0x2E2E2E2E2E2E2E2E)
_MINUS = np.uint64(0x2D2D2D2D2D2D2D2D)
_LOW7 = np.uint64(0x7F7F7F7F7F7F7F7F)
_U7 = np.uint64(7)


def _zero_bytes(x: np.ndarray) -> np.ndarray:
    """0x80 in each byte of ``x`` that is zero, 0 elsewhere (exact SWAR test, no false positives)."""
    return ~(((x & _LOW7) + _LOW7) | x | _LOW7)


def _plain(b, block, starts, ends):
    """Tokens of a block of ``[-]digits[.digits]`` numbers, all per token on two little-endian 8-byte
    words (SIMD within a register): find the dot, turn it and the padding into '0', then pack the
    digits. Same results as :func:`_with_exponents` (``k = None``: no exponents)."""
    neg = b[starts] == 45
    s0 = starts + neg
    body = ends - s0  # digits and the dot
    L = np.clip(body, 1, 16)
    raw = np.empty(b.size + 16, dtype=np.uint8)
    raw[:b.size] = b
    raw[b.size:] = 32
    words = np.ndarray((raw.size - 7,), dtype="<u8", buffer=raw, strides=(1,))  # unaligned loads
    long = L > 8
    # first word: the token's first min(L, 8) bytes, right-aligned, '0'-filled on the left (low bytes)
    sh_a = (8 * np.where(long, 0, 8 - L)).astype(np.uint64)
    a = (words[s0] << sh_a) | (_FILL >> (np.uint64(64) - sh_a))
    # second word: bytes 8..L-1 right-aligned (all '0' for short tokens)
    sh_b = (8 * np.where(long, 16 - L, 8)).astype(np.uint64)
    wb = np.where(long, words[s0 + 8], _FILL)
    bb = (wb << sh_b) | (_FILL >> (np.uint64(64) - sh_b))
    bb = np.where(long, bb, _FILL)
    if np.any(_zero_bytes(a ^ _MINUS) | _zero_bytes(bb ^ _MINUS)):
        return None  # a '-' after the first byte
    da, db = _zero_bytes(a ^ _DOTS), _zero_bytes(bb ^ _DOTS)
    nd = np.bitwise_count(da) + np.bitwise_count(db)
    if np.any(nd > 1):
        return None  # two dots in a token
    has_dot = nd == 1
    # byte index j of a dot = (popcount(t - 1) - 7) / 8 for t = 0x80 << 8j; bytes after it = 7 - j
    after_a = _U7 - ((np.bitwise_count(da - np.uint64(1)).astype(np.uint64) - _U7) >> np.uint64(3))
    after_b = _U7 - ((np.bitwise_count(db - np.uint64(1)).astype(np.uint64) - _U7) >> np.uint64(3))
    nfrac = np.where(da != 0, after_a.astype(np.int64) + np.where(long, L - 8, 0),
                     np.where(db != 0, after_b.astype(np.int64), 0))
    # the dot reads as '0'; then every byte is an ASCII digit and subtracting '0' borrows nowhere
    a ^= (da >> _U7) * np.uint64(0x1E)  # '.' ^ 0x1E = '0'
    bb ^= (db >> _U7) * np.uint64(0x1E)
    v = _swar8(a - _FILL).astype(np.float64)
    if long.any():
        v = np.where(long, v * _POW10[np.maximum(L - 8, 0)] + _swar8(bb - _FILL), v)
    return neg, body, nfrac, has_dot, None, v


# optional accelerator: pyarrow's C++ CSV reader (the 'bench' extra installs it), imported on first use
# (it takes ~0.1 s to import); `_ARROW` is the module, or None when absent or switched off
_ARROW = _ARROW_CSV = None
_ARROW_TRIED = False


def _load_arrow():
    """pyarrow, imported once on first use, or ``None`` when it is not installed."""
    global _ARROW, _ARROW_CSV, _ARROW_TRIED
    if not _ARROW_TRIED:
        _ARROW_TRIED = True
        try:
            import pyarrow
            import pyarrow.csv
            _ARROW, _ARROW_CSV = pyarrow, pyarrow.csv
        except ImportError:  # pragma: no cover - depends on the environment
            pass
    return _ARROW


def _parse_with_arrow(block: bytes, rows: int, cols: int) -> np.ndarray | None:
    """The table through pyarrow's CSV reader (single spaces between values; a trailing space per line is
    tolerated); ``None`` (use the numpy route) for anything else. Its float parsing rounds correctly
    (fast_float), so the values equal ``float``'s (checked in tests/test_io_bvh.py)."""
    try:
        t = _ARROW_CSV.read_csv(
            _ARROW.py_buffer(block),
            read_options=_ARROW_CSV.ReadOptions(autogenerate_column_names=True),
            parse_options=_ARROW_CSV.ParseOptions(delimiter=" ", quote_char=False, ignore_empty_lines=False),
            convert_options=_ARROW_CSV.ConvertOptions(
                column_types={f"f{k}": _ARROW.float64() for k in range(cols)}, strings_can_be_null=True,
                null_values=[""]))
    except Exception:  # noqa: BLE001 - any refusal means "not certified": the numpy route decides
        return None
    if t.num_rows != rows or t.num_columns not in (cols, cols + 1):
        return None
    if t.num_columns == cols + 1 and t.column(cols).null_count != rows:  # only a trailing space allowed
        return None
    out = np.empty((rows, cols))
    for k in range(cols):
        c = t.column(k)
        if c.null_count or c.type != _ARROW.float64():
            return None
        out[:, k] = c.to_numpy()
    if not np.all(np.isfinite(out)):
        return None
    return out


_CHUNK_BYTES = 1 << 16  # ~64 KB of text at a time: temporaries stay in cache and below glibc's mmap threshold


def parse_table(block: bytes, rows: int, cols: int) -> np.ndarray | None:
    """``(rows, cols)`` float64 table of the numbers in ``block`` (``cols`` per ``\\n``-separated line,
    trailing blank lines allowed), bit-identical to ``float``; ``None`` when it cannot certify it.

    With pyarrow installed its CSV reader is tried first (single-space separated blocks). Otherwise, or
    if it declines, the block is cut at line breaks into pieces of about ``_CHUNK_BYTES`` holding whole
    rows, parsed one after the other (the many array passes are memory-bound; in cache they are faster)."""
    if rows < 1 or cols < 1 or not block:
        return None
    if _load_arrow() is not None:
        table = _parse_with_arrow(block, rows, cols)
        if table is not None:
            return table
    per_row = max(1, len(block) // rows)
    step = max(1, _CHUNK_BYTES // per_row)  # rows per piece
    if step >= rows:
        return _parse_rows(block, rows, cols)
    b = np.frombuffer(block, dtype=np.uint8)
    nl = np.flatnonzero(b == 10)
    if nl.size < rows - 1:
        return None
    out = np.empty((rows, cols))
    begin = 0
    for r0 in range(0, rows, step):
        r1 = min(r0 + step, rows)
        end = int(nl[r1 - 1]) + 1 if r1 < rows else len(block)
        part = _parse_rows(block[begin:end], r1 - r0, cols)
        if part is None:
            return None
        out[r0:r1] = part
        begin = end
    return out


def _values(found) -> tuple[np.ndarray, np.ndarray] | None:
    """Token values from the per-token fields of :func:`_plain` / :func:`_with_exponents`, and the mask
    of tokens inside Clinger's fast path (at most 15 digits, ``|k| <= 22``; the caller converts the
    others with ``float``)."""
    if found is None:
        return None
    neg, body, nfrac, has_dot, k, v = found
    if np.any(body <= has_dot):
        return None  # a sign or a dot without digits
    fast = body <= _MAX_DIGITS
    if k is not None:
        fast &= np.abs(k) <= 22
    # v = I * 10**(nfrac+1) + R reads the dot as a 0 digit; the mantissa is I * 10**nfrac + R = v - 9 I 10**nfrac.
    # floor(v / 10**(nfrac+1)) = I exactly: the quotient is I + R / 10**(nfrac+1) with the fraction < 0.1
    p = _POW10[np.minimum(nfrac + has_dot, 22)]
    q = np.floor(v / p)
    q *= p / 10.0
    q *= 9.0
    q *= has_dot
    v -= q
    if k is None:  # no exponents: divide by 10**nfrac
        v /= _POW10[np.minimum(nfrac, 22)]
    else:
        kc = np.clip(k, -22, 22)
        v = np.where(kc >= 0, v * _POW10[np.maximum(kc, 0)], v / _POW10[np.maximum(-kc, 0)])
    np.negative(v, out=v, where=neg)
    return v, fast


def _parse_rows(block: bytes, rows: int, cols: int) -> np.ndarray | None:
    """:func:`parse_table` on one piece."""
    if not block or block.translate(None, _ALLOWED):
        return None  # a byte outside the grammar (or an empty block)
    b = np.frombuffer(block, dtype=np.uint8)
    nonws = b > 32
    # token boundaries: rising / falling edges of the non-whitespace mask
    edge = np.empty(b.size + 1, dtype=bool)
    edge[0] = nonws[0]
    edge[-1] = nonws[-1]
    np.not_equal(nonws[1:], nonws[:-1], out=edge[1:-1])
    e = np.flatnonzero(edge)
    starts, ends = e[0::2], e[1::2]
    n = starts.size
    if n != rows * cols:
        return None
    # line structure: `cols` tokens on each of the first `rows` lines, nothing after
    nl = np.flatnonzero(b == 10)
    per_line = np.diff(np.searchsorted(starts, np.concatenate(([0], nl + 1, [b.size]))))
    if per_line.size < rows or np.any(per_line[:rows] != cols) or np.any(per_line[rows:]):
        return None

    if b"e" in block or b"E" in block or b"+" in block:
        special = np.flatnonzero(((b | 32) == 101) | (b == 43))
        tok = np.unique(np.searchsorted(starts, special, side="right") - 1)
        if tok.size * 4 > n:  # many exponents: the vectorised general route
            res = _values(_with_exponents(b, block, starts, ends, edge, nonws))
            if res is None:
                return None
            out, fast = res
        else:  # a few: plain tokens vectorised, the others through float() below
            plain = np.ones(n, dtype=bool)
            plain[tok] = False
            res = _values(_plain(b, block, starts[plain], ends[plain]))
            if res is None:
                return None
            out = np.empty(n)
            out[plain] = res[0]
            fast = np.zeros(n, dtype=bool)
            fast[plain] = res[1]
    else:
        res = _values(_plain(b, block, starts, ends))
        if res is None:
            return None
        out, fast = res
        if fast.all():
            return out.reshape(rows, cols)
    slow = np.flatnonzero(~fast)
    try:  # bytes are [0-9.+-eE] here, where float's grammar is NUMBER_RE's
        vals = [float(block[i:j]) for i, j in zip(starts[slow].tolist(), ends[slow].tolist())]
    except ValueError:
        return None  # the line parser reports it
    out[slow] = vals
    if not np.all(np.isfinite(out[slow])):
        return None
    return out.reshape(rows, cols)
