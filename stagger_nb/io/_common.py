"""Helpers shared by the file readers: the error base class, file reading, checked numbers."""
from __future__ import annotations

import math
import os
import re
import stat

# the Euler conversion lives in core (one definition); re-exported for the readers
from ..core.rotations import _EULER_BLOCK, euler_components, quarter_tan  # noqa: F401
from ..core.rotations import euler_to_quat as euler_deg_to_quat

__all__ = ["atomic_write_bytes", "WriteError", "FormatError", "read_text", "read_bytes", "decode", "finite_number", "euler_deg_to_quat",
           "MAX_INPUT_BYTES", "read_regular_file"]

#: The one size limit for every file the package reads (BVH, ASF/AMC, session JSON, referenced clips):
#: 256 MiB. The joint-sample limit (core.motion.MAX_FRAME_JOINTS, 4x10^6) caps a valid BVH near 4x10^6 x 6
#: channels x 11 characters; a 100,000-frame, 31-joint take is ~100 MB. (It was 1 GiB: a sparse 900 MB
#: file was read whole, 928 MB RSS, 33 s, to report its line 1.) Override per call with ``max_bytes``.
MAX_INPUT_BYTES = 256 << 20


def file_path(path, what: str = "path") -> str | bytes:
    """``os.fspath(path)``, or ``ValueError`` naming ``what`` when ``path`` is not a path (None, a number) or
    holds a NUL character (which no file name can)."""
    try:
        name = os.fspath(path)
    except TypeError:
        raise ValueError(f"{what}: expected a file path (str or os.PathLike), got {path!r}") from None
    if ("\0" if isinstance(name, str) else b"\0") in name:
        raise ValueError(f"{what}: a file path cannot hold a NUL character, got {path!r}")
    return name


def read_regular_file(path, *, what: str = "file", max_bytes: int | None = None) -> bytes:
    """The bytes of ``path``, read only if it is a regular file no larger than ``max_bytes``.

    The one path policy shared by the readers and the session: devices (``/dev/zero``), FIFOs, sockets and
    directories are refused without blocking (opened with ``O_NONBLOCK``, checked with ``fstat``), and so is a
    file over the limit, before it is read. Raises ``ValueError`` (``OSError`` texts included) naming ``what``
    and the path; the readers wrap it in their own format error.
    """
    limit = MAX_INPUT_BYTES if max_bytes is None else int(max_bytes)
    name = file_path(path, what)
    try:
        fd = os.open(name, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as e:
        raise ValueError(f"{what} {name}: cannot read: {e.strerror or e}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise ValueError(f"{what} {name}: not a regular file (devices, pipes and folders are not read)")
        if st.st_size > limit:
            raise ValueError(f"{what} {name}: {st.st_size} bytes is over the {limit}-byte limit")
        # one read of the whole file into one buffer (no second copy from joining pieces), then to EOF in
        # pieces should it have grown, never past the limit
        first = os.read(fd, min(st.st_size + 1, limit + 1))
        chunks, total = [first], len(first)
        while first and total <= limit:
            chunk = os.read(fd, min(1 << 24, limit + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > limit:
            raise ValueError(f"{what} {name}: over the {limit}-byte limit")
        return first if len(chunks) == 1 else b"".join(chunks)
    except OSError as e:
        raise ValueError(f"{what} {name}: cannot read: {e.strerror or e}") from None
    finally:
        os.close(fd)


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
        prefix = f"file {os.fspath(path)}: "
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


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view[:1 << 24]):]


_UNNAMED_OK = True  # becomes False once naming an unnamed file failed here (then named temporaries are used)


def _unnamed_file(folder: str, mode: int) -> int | None:
    """A file descriptor of a new, unnamed file in ``folder`` (Linux ``O_TMPFILE``): a process killed
    while writing it leaves nothing behind. ``None`` where the platform or file system has none."""
    flag = getattr(os, "O_TMPFILE", 0)
    if not flag or not _UNNAMED_OK:
        return None
    try:
        return os.open(folder, flag | os.O_WRONLY | getattr(os, "O_CLOEXEC", 0), mode)
    except OSError:  # EOPNOTSUPP / EISDIR / EINVAL: a file system without unnamed files
        return None


def _link_unnamed(fd: int, name: str) -> bool:
    """Give the unnamed file ``fd`` the name ``name`` (``linkat``); ``False`` if this system cannot.
    ``FileExistsError`` when ``name`` exists."""
    try:
        os.link(f"/proc/self/fd/{fd}", name)  # the documented way (open(2)); needs /proc
        return True
    except FileExistsError:
        raise
    except OSError:
        pass
    try:  # linkat(fd, "", AT_FDCWD, name, AT_EMPTY_PATH): where /proc links are refused (sandboxes)
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.linkat(fd, b"", -100, os.fsencode(name), 0x1000) == 0:
            return True
        if ctypes.get_errno() == 17:  # EEXIST
            raise FileExistsError(name)
    except (OSError, AttributeError):
        pass
    return False


def _fsync_folder(folder: str) -> None:
    """Make a rename in ``folder`` durable (best effort: some platforms cannot open folders)."""
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


class WriteError(OSError, ValueError):
    """A file that cannot be written, or must not be replaced; the message names the path. Both an
    ``OSError`` (what writing raises) and a ``ValueError`` (a bad path argument), like
    ``io.UnsupportedOperation``."""


def _check_write_target(path: str) -> None:
    """Refuse a destination that exists and is not a regular file (a folder, a device such as
    ``/dev/null``, a FIFO, a socket, a broken symbolic link): renaming over it would replace it."""
    if not os.path.lexists(path):
        return
    try:
        st = os.stat(path)
    except OSError as e:
        raise WriteError(f"{path}: cannot write here: {e.strerror or e} (a broken symbolic link?)") from None
    if stat.S_ISDIR(st.st_mode):
        raise WriteError(f"{path}: is a folder; write to a file path in it")
    if not stat.S_ISREG(st.st_mode):
        raise WriteError(f"{path}: exists and is not a regular file (a device, pipe or socket); "
                         "it is not replaced")


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically and durably: readers see the old file or the new one, never
    half of one, and after a crash the new file is complete or absent.

    The data goes to an unnamed file in the same folder (``O_TMPFILE``: a killed writer leaves no
    temporary file), is synced (``fsync``), then given a hidden name and renamed over ``path``, and the
    folder is synced. Where unnamed files are not available, a hidden temporary file (``.tmp-*``) is used
    instead and removed on any error. The file gets the usual permissions (umask, or the mode of the file
    it replaces). Raises :class:`WriteError` (an ``OSError`` and a ``ValueError``) naming the path when it
    cannot be written (missing folder, full disk) or is not a regular file (a folder, ``/dev/null``, a FIFO:
    never replaced)."""
    path = os.fsdecode(file_path(path, "path"))
    if not path or "\0" in path:
        raise WriteError(f"{path!r}: not a usable file path")
    _check_write_target(path)
    try:
        _atomic_write(path, data)
    except WriteError:
        raise
    except OSError as e:  # a missing or read-only folder, a full disk: named, and a ValueError too
        raise WriteError(f"{path}: cannot write: {e.strerror or e}") from None


def _atomic_write(path: str, data: bytes) -> None:
    folder = os.path.dirname(os.path.abspath(path))
    try:
        mode = os.stat(path).st_mode & 0o7777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask
    global _UNNAMED_OK
    fd = _unnamed_file(folder, mode)
    tmp = None
    try:
        if fd is not None:
            try:
                _write_all(fd, data)
                os.fchmod(fd, mode)
                os.fsync(fd)
                for _ in range(100):  # name it only now that it is complete: linkat(2) does not overwrite
                    cand = os.path.join(folder, f".tmp-{os.urandom(6).hex()}{os.path.splitext(path)[1]}")
                    try:
                        if not _link_unnamed(fd, cand):
                            _UNNAMED_OK = False
                            break
                    except FileExistsError:
                        continue
                    tmp = cand
                    break
                else:
                    raise FileExistsError(f"no free temporary name in {folder}")
            finally:
                os.close(fd)
        if tmp is None:
            import tempfile  # only here: it pulls in random and shutil (~10 ms of import time)
            fd2, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=os.path.splitext(path)[1], dir=folder)
            try:
                _write_all(fd2, data)
                os.fchmod(fd2, mode) if hasattr(os, "fchmod") else os.chmod(tmp, mode)
                os.fsync(fd2)
            finally:
                os.close(fd2)
        os.replace(tmp, path)
        tmp = None
    finally:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
    _fsync_folder(folder)
