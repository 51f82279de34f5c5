"""The one output policy: atomic, durable writes (:func:`atomic_write_bytes`) and the error that names what
could not be written (:class:`WriteError`). Writes inside a folder the package owns are in :mod:`._confined`."""
from __future__ import annotations

import os
import stat

from ._input import _kind, file_path


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view[:1 << 24]):]


_UNNAMED_OK = True  # becomes False once naming an unnamed file failed here (then named temporaries are used)
_DIR_FLAGS = os.O_RDONLY | getattr(os, "O_DIRECTORY", 0) | getattr(os, "O_CLOEXEC", 0)


def _unnamed_file(dfd: int, mode: int) -> int | None:
    """A file descriptor of a new, unnamed file in the folder ``dfd`` (Linux ``O_TMPFILE``): a process killed
    while writing it leaves nothing behind. ``None`` where the platform or file system has none."""
    flag = getattr(os, "O_TMPFILE", 0)
    if not flag or not _UNNAMED_OK:
        return None
    try:
        return os.open(".", flag | os.O_WRONLY | getattr(os, "O_CLOEXEC", 0), mode, dir_fd=dfd)
    except OSError:  # EOPNOTSUPP / EISDIR / EINVAL: a file system without unnamed files
        return None


def _link_unnamed(fd: int, dfd: int, name: str) -> bool:
    """Give the unnamed file ``fd`` the name ``name`` in the folder ``dfd`` (``linkat``, which never replaces);
    ``False`` if this system cannot. ``FileExistsError`` when ``name`` exists."""
    try:
        os.link(f"/proc/self/fd/{fd}", name, dst_dir_fd=dfd)  # the documented way (open(2)); needs /proc
        return True
    except FileExistsError:
        raise
    except OSError:
        pass
    try:  # linkat(fd, "", dfd, name, AT_EMPTY_PATH): where /proc links are refused (sandboxes)
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.linkat(fd, b"", dfd, os.fsencode(name), 0x1000) == 0:
            return True
        if ctypes.get_errno() == 17:  # EEXIST
            raise FileExistsError(name)
    except (OSError, AttributeError):
        pass
    return False


class WriteError(OSError, ValueError):
    """A file that cannot be written, or must not be replaced; the message names the path. Both an
    ``OSError`` (what writing raises) and a ``ValueError`` (a bad path argument), like
    ``io.UnsupportedOperation``."""


def _check_target(st: os.stat_result | None, shown: str, replace: bool) -> None:
    """Refuse a destination that exists and is not a regular file (a folder, a device such as ``/dev/null``,
    a FIFO, a socket): renaming over it would replace it; and any existing file when ``replace`` is false."""
    if st is None:
        return
    if stat.S_ISDIR(st.st_mode):
        raise WriteError(f"{shown}: is a folder; write to a file path in it")
    if stat.S_ISLNK(st.st_mode):
        raise WriteError(f"{shown}: is a symbolic link; nothing is written through it")
    if not stat.S_ISREG(st.st_mode):
        raise WriteError(f"{shown}: exists and is not a regular file ({_kind(st.st_mode)}); it is not replaced")
    if not replace:
        raise WriteError(f"{shown}: exists and was not written here; it is not replaced")


def _stat_or_none(name, dir_fd=None, follow=True):
    try:
        return os.stat(name, dir_fd=dir_fd, follow_symlinks=follow)
    except FileNotFoundError:
        return None


def atomic_write_bytes(path, data: bytes, *, replace: bool = True) -> None:
    """Write ``data`` to ``path`` atomically and durably: readers see the old file or the new one, never
    half of one, and after a crash the new file is complete or absent.

    The data goes to an unnamed file in the same folder (``O_TMPFILE``: a killed writer leaves no
    temporary file), is synced (``fsync``), then given a hidden name and renamed over ``path``, and the
    folder is synced. Where unnamed files are not available, a hidden temporary file (``.tmp-*``) is used
    instead and removed on any error. The file gets the usual permissions (umask, or the mode of the file
    it replaces). ``replace=False`` never replaces an existing file (the new one is linked to its name,
    which fails if the name exists, even when it appears meanwhile). Raises :class:`WriteError` (an
    ``OSError`` and a ``ValueError``) naming the path when it cannot be written (missing folder, full disk)
    or is not a regular file (a folder, ``/dev/null``, a FIFO: never replaced)."""
    path = os.fsdecode(file_path(path, "path"))
    if not path:
        raise WriteError(f"{path!r}: not a usable file path")
    try:
        st = os.stat(path)
    except FileNotFoundError:
        st = None if not os.path.lexists(path) else False
    except OSError as e:
        raise WriteError(f"{path}: cannot write here: {e.strerror or e}") from None
    if st is False:
        raise WriteError(f"{path}: cannot write here: a broken symbolic link")
    _check_target(st, path, replace)
    folder, name = os.path.split(os.path.abspath(path))
    try:
        dfd = os.open(folder, _DIR_FLAGS)
    except OSError as e:
        raise WriteError(f"{path}: cannot write: {e.strerror or e}") from None
    try:
        _write_at(dfd, name, data, replace, path)
    finally:
        os.close(dfd)


def _write_at(dfd: int, name: str, data: bytes, replace: bool, shown: str) -> None:
    """The atomic write of :func:`atomic_write_bytes` into the folder ``dfd``; errors named by ``shown``."""
    try:
        _atomic_write(dfd, name, data, replace)
    except WriteError:
        raise
    except FileExistsError:
        raise WriteError(f"{shown}: exists and was not written here; it is not replaced") from None
    except OSError as e:  # a missing or read-only folder, a full disk: named, and a ValueError too
        raise WriteError(f"{shown}: cannot write: {e.strerror or e}") from None


def _with_free_name(ext: str, claim):
    """``(claim(name), name)`` for the first fresh hidden name ``.tmp-<random><ext>`` that ``claim`` does not
    find taken (``FileExistsError``)."""
    for _ in range(100):
        cand = f".tmp-{os.urandom(6).hex()}{ext}"
        try:
            return claim(cand), cand
        except FileExistsError:
            continue
    raise FileExistsError("no free temporary name")


def _atomic_write(dfd: int, name: str, data: bytes, replace: bool) -> None:
    st = _stat_or_none(name, dfd)
    if st is not None:
        mode = st.st_mode & 0o7777
    else:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask
    global _UNNAMED_OK
    ext = os.path.splitext(name)[1]
    fd = _unnamed_file(dfd, mode)
    tmp, done = None, False
    try:
        if fd is not None:
            try:
                _write_all(fd, data)
                os.fchmod(fd, mode)
                os.fsync(fd)
                if not replace:  # straight to its name: linkat never replaces what is there
                    done = _link_unnamed(fd, dfd, name)
                    _UNNAMED_OK = done
                else:  # name it only now that it is complete
                    linked, cand = _with_free_name(ext, lambda c: _link_unnamed(fd, dfd, c))
                    tmp = cand if linked else None
                    _UNNAMED_OK = linked
            finally:
                os.close(fd)
        if not done and tmp is None:
            flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOFOLLOW", 0)
            fd2, tmp = _with_free_name(ext, lambda c: os.open(c, flags, 0o600, dir_fd=dfd))
            try:
                _write_all(fd2, data)
                os.fchmod(fd2, mode)
                os.fsync(fd2)
            finally:
                os.close(fd2)
        if not done:
            if replace:
                os.replace(tmp, name, src_dir_fd=dfd, dst_dir_fd=dfd)
            else:
                os.link(tmp, name, src_dir_fd=dfd, dst_dir_fd=dfd, follow_symlinks=False)
                os.unlink(tmp, dir_fd=dfd)
            tmp = None
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp, dir_fd=dfd)
            except OSError:
                pass
    try:  # make the rename durable (best effort)
        os.fsync(dfd)
    except OSError:
        pass
