"""Vectorised fixed-point formatting of a float table (the BVH motion block), numpy only.

``format_table(table, decimals)`` writes ``table (F, C)`` as ``F`` lines of ``C`` space-separated numbers,
column ``c`` rounded to ``decimals[c]`` places with trailing zeros (and a bare dot) dropped: ``-12.5``,
``0``, ``3.000125``. Each value is scaled to an integer ``round(v * 10**d)`` and its digits are scattered
into one byte buffer, one decimal place per numpy pass (about 20 passes instead of a Python ``%`` per
value). Returns ``None`` if a scaled value reaches 2**53 (then the caller formats with ``%g``).
"""
from __future__ import annotations

import numpy as np

__all__ = ["format_table"]

_POW10_I = 10 ** np.arange(19, dtype=np.int64)
_LIMIT = 2 ** 53


def format_table(table: np.ndarray, decimals: np.ndarray) -> bytes | None:
    """Text of ``table (F, C)``, column ``c`` with at most ``decimals[c]`` (0..15) decimal places, each
    line ending in ``\\n``; ``None`` when a value is too large for exact integer scaling."""
    t = np.asarray(table, dtype=float)
    F, C = t.shape
    if F == 0 or C == 0:
        return b"\n" * F
    d = np.broadcast_to(np.asarray(decimals, dtype=np.int64), (C,))
    x = np.rint(t * (10.0 ** d))
    if not np.all(np.abs(x) < _LIMIT):
        return None
    a = np.abs(x).astype(np.int64).ravel()
    neg = (x < 0).ravel()  # -0.0 rounds to 0: no sign
    dd = np.broadcast_to(d, (F, C)).ravel()
    # digits of a (at least one), fraction digits kept after dropping trailing zeros
    nd = np.maximum(np.searchsorted(_POW10_I, a, side="right"), 1)
    tz = np.zeros(a.size, dtype=np.int64)
    alive = a != 0
    for k in range(1, int(d.max()) + 1):  # trailing zeros among the decimals
        alive &= (a % _POW10_I[k] == 0) & (k <= dd)
        tz += alive
    tz = np.where(a == 0, dd, tz)
    frac = dd - tz
    int_digits = np.maximum(nd - dd, 1)
    length = neg + int_digits + np.where(frac > 0, frac + 1, 0)
    ends = np.cumsum(length + 1)  # each token is followed by a space or a line break
    starts = ends - length - 1
    buf = np.full(int(ends[-1]), ord(" "), dtype=np.uint8)
    buf[ends.reshape(F, C)[:, -1] - 1] = ord("\n")
    buf[starts[neg]] = ord("-")
    dot = starts + neg + int_digits
    has_frac = frac > 0
    buf[dot[has_frac]] = ord(".")
    rest = a.copy()
    for k in range(int(max(nd.max(), (dd + 1).max()))):  # k-th digit from the right of a
        digit = (rest % 10).astype(np.uint8) + np.uint8(48)
        rest //= 10
        is_frac = k < dd
        pos_frac = dot + (dd - k)  # fraction digit k sits (dd - k) places right of the dot
        pos_int = dot - 1 - (k - dd)
        keep_frac = is_frac & (k >= tz)
        keep_int = ~is_frac & (k - dd < int_digits)
        buf[pos_frac[keep_frac]] = digit[keep_frac]
        buf[pos_int[keep_int]] = digit[keep_int]
    return buf.tobytes()
