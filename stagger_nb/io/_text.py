"""Text files of a format: the per-format error base (:class:`FormatError`: file, line, what was expected), the
file read under the input policy (:func:`read_bytes`, :func:`read_text`) and the one text decoding
(:func:`decode`)."""
from __future__ import annotations

import os

from ._input import read_regular_file


class FormatError(ValueError):
    """Base of the per-format errors; the message names the file, the line and what was expected.

    Attributes ``source`` (file name) and ``line`` (1-based, or ``None`` when no line applies).
    """

    def __init__(self, source: str, line: int | None, message: str):
        self.source, self.line = source, line
        where = f"{source}, line {line}" if line is not None else source
        super().__init__(f"{where}: {message}")


def read_text(path: str, error: type[FormatError]) -> str:
    """The file's text (UTF-8, falling back to Latin-1); ``error(path, None, ...)`` if unreadable."""
    return decode(read_bytes(path, error))


def read_bytes(path: str, error: type[FormatError], max_bytes: int | None = None) -> bytes:
    """The file's bytes (a regular file within ``max_bytes``, default :data:`MAX_INPUT_BYTES`);
    ``error(path, None, ...)`` otherwise."""
    try:
        return read_regular_file(path, max_bytes=max_bytes)
    except ValueError as e:
        msg = str(e)
        prefix = f"file {os.fsdecode(os.fspath(path))}: "
        raise error(path, None, msg[len(prefix):] if msg.startswith(prefix) else msg) from None


UTF8_BOM = b"\xef\xbb\xbf"


def decode(raw: bytes | memoryview) -> str:
    """UTF-8 text without a leading byte-order mark, or else Windows-1252 (old Windows exporters: ``“ü”``),
    or else Latin-1 (cp1252 leaves five bytes undefined). cp1252 comes before Latin-1 because Latin-1 reads
    bytes 0x80-0x9f as invisible control characters, which no name or number holds. A ``memoryview`` is
    decoded in place (no copy of a large slice)."""
    if raw[:3] == UTF8_BOM:
        raw = raw[3:]
    try:
        return str(raw, "utf-8")
    except UnicodeDecodeError:
        pass
    try:
        return str(raw, "cp1252")
    except UnicodeDecodeError:
        return str(raw, "latin-1")
