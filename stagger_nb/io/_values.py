"""Values the readers check: decimal tokens (:func:`finite_number`, :func:`split_values`). Re-exported by
:mod:`._common` (beside the euler -> quaternion conversion, which lives in :mod:`stagger_nb.core.rotations`)."""
from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ._text import FormatError

__all__ = ["finite_number", "split_values", "MAX_TOKEN"]


#: A decimal number as files write it: ASCII digits only. ``float`` also takes ``1_000``, Arabic-Indic or
#: full-width digits, which no exporter writes and which would read differently elsewhere.
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:nan|inf|infinity)", re.ASCII | re.I)


def finite_number(tok: str, what: str, source: str, line: int, error: type[FormatError]) -> float:
    """``float(tok)`` of an ASCII decimal token, raising ``error`` naming ``what`` was expected if it is not
    a finite number."""
    if not _NUMBER.fullmatch(tok):
        raise error(source, line, f"expected a number for {what}, found {tok!r}")
    v = float(tok)
    if not math.isfinite(v):
        raise error(source, line, f"expected a finite number for {what}, found {tok!r}")
    return v


MAX_TOKEN = 1024  # characters of one value in a motion line (real files: <= 25)


def split_values(text, n: int, truncated: bool, what: str, source: str, line: int, error: type[FormatError]):
    """The ``n`` whitespace-separated values of ``text`` (``str`` or ``bytes``: a line, or its first
    characters when ``truncated``), split into at most ``n + 1`` pieces whatever the line holds; ``error``
    naming ``what`` (e.g. ``"on frame 3"``) when there are not exactly ``n``."""
    vals = text.split(None, n)
    if len(vals) <= n and truncated:
        raise error(source, line, f"expected {n} values {what}, found a value of more than {MAX_TOKEN} characters")
    if len(vals) != n:
        found = f"more than {n}" if len(vals) > n else str(len(vals))
        raise error(source, line, f"expected {n} values {what}, found {found}")
    return vals
