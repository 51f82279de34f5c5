"""Files inside a folder the package owns (a batch's OUT), reached and written without ever leaving it: no
symbolic link inside the folder is followed (:func:`write_confined`, :func:`read_confined`,
:func:`overwrite_in_place` for a report on a full disk)."""
from __future__ import annotations

import os
import stat

from ._input import MAX_INPUT_BYTES, _kind, _open_checked, _read_fd
from ._output import _DIR_FLAGS, WriteError, _check_target, _stat_or_none, _write_at


def confined_parts(rel, what: str = "path") -> list[str]:
    """The components of ``rel``, a ``/``-separated path that stays inside the folder it is relative to:
    not absolute, no empty, ``.`` or ``..`` component, no NUL; ``ValueError`` naming ``what`` otherwise (the
    value itself is not quoted: it may come from a hand-edited file)."""
    if not isinstance(rel, str) or not rel or "\0" in rel or rel.startswith("/"):
        raise ValueError(f"{what}: not a relative path inside the output folder")
    parts = rel.split("/")
    if any(p in ("", ".", "..") for p in parts):
        raise ValueError(f"{what}: not a relative path inside the output folder (an empty, '.' or '..' part)")
    return parts


def _open_folders(root: str, parts: list[str], create: bool) -> int:
    """A descriptor of the folder ``root/parts[0]/.../parts[-1]``, each component opened relative to the one
    before without following a symbolic link (created when missing and ``create``): no path inside ``root``
    can lead outside it, whatever is swapped in meanwhile. ``WriteError`` naming the component."""
    try:
        dfd = os.open(root, _DIR_FLAGS)
    except OSError as e:
        raise WriteError(f"{root}: cannot open the folder: {e.strerror or e}") from None
    nofollow = getattr(os, "O_NOFOLLOW", 0)
    for i, comp in enumerate(parts):
        shown = os.path.join(root, *parts[:i + 1])
        for _ in range(3):
            try:
                nfd = os.open(comp, _DIR_FLAGS | nofollow, dir_fd=dfd)
                break
            except FileNotFoundError:
                if not create:
                    os.close(dfd)
                    raise WriteError(f"{shown}: no such folder") from None
                try:
                    os.mkdir(comp, 0o777, dir_fd=dfd)
                except FileExistsError:
                    pass
                except OSError as e:
                    os.close(dfd)
                    raise WriteError(f"{shown}: cannot create the folder: {e.strerror or e}") from None
            except OSError as e:
                st = _stat_or_none(comp, dfd, follow=False)
                os.close(dfd)
                if st is not None and stat.S_ISLNK(st.st_mode):
                    raise WriteError(f"{shown}: is a symbolic link; nothing is written through it") from None
                if st is not None and not stat.S_ISDIR(st.st_mode):
                    raise WriteError(f"{shown}: is not a folder ({_kind(st.st_mode)})") from None
                raise WriteError(f"{shown}: cannot open the folder: {e.strerror or e}") from None
        else:
            os.close(dfd)
            raise WriteError(f"{shown}: cannot open the folder (it keeps changing)")
        os.close(dfd)
        dfd = nfd
    return dfd


def write_confined(root: str, rel: str, data: bytes, *, replace: bool) -> None:
    """Write ``data`` atomically (as :func:`atomic_write_bytes`) to ``root/rel``, never outside ``root``: every
    folder on the way is opened (or created) without following a symbolic link, the file itself must not be
    one, and ``replace=False`` never replaces an existing file. ``WriteError`` naming the path otherwise."""
    parts = confined_parts(rel)
    shown = os.path.join(root, *parts)
    dfd = _open_folders(root, parts[:-1], create=True)
    try:
        _check_target(_stat_or_none(parts[-1], dfd, follow=False), shown, replace)
        _write_at(dfd, parts[-1], data, replace, shown)
    finally:
        os.close(dfd)


def read_confined(root: str, rel: str, *, what: str = "file", max_bytes: int | None = None) -> bytes:
    """The bytes of the regular file ``root/rel`` under the input policy, reached without following any
    symbolic link inside ``root``."""
    parts = confined_parts(rel, what)
    shown = os.path.join(root, *parts)
    limit = MAX_INPUT_BYTES if max_bytes is None else int(max_bytes)
    try:
        dfd = _open_folders(root, parts[:-1], create=False)
    except WriteError as e:
        raise ValueError(f"{what} {e}") from None
    try:
        fd, size = _open_checked(parts[-1], f"{what} {shown}", limit, dir_fd=dfd, follow=False)
    finally:
        os.close(dfd)
    try:
        return _read_fd(fd, size, limit, f"{what} {shown}")
    finally:
        os.close(fd)


def overwrite_in_place(root: str, rel: str, data: bytes, *, pad_at: int | None = None) -> None:
    """Overwrite the existing regular file ``root/rel`` in place, padded with spaces to its size when
    shorter (at index ``pad_at`` of ``data``, default its end): no new blocks are needed, so this works on a
    full disk where an atomic write cannot. ``data`` may exceed the file only up to the end of its last
    4 KiB block (``WriteError`` otherwise, nothing written). Not atomic: only for a small report that says
    the atomic write failed (its format must allow the padding)."""
    parts = confined_parts(rel)
    shown = os.path.join(root, *parts)
    dfd = _open_folders(root, parts[:-1], create=False)
    try:
        fd = os.open(parts[-1], os.O_WRONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_CLOEXEC", 0)
                     | getattr(os, "O_NONBLOCK", 0), dir_fd=dfd)
    except OSError as e:
        raise WriteError(f"{shown}: cannot write: {e.strerror or e}") from None
    finally:
        os.close(dfd)
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise WriteError(f"{shown}: not a regular file; not written")
        room = -(-st.st_size // 4096) * 4096
        if len(data) > room:
            raise WriteError(f"{shown}: {len(data)} bytes do not fit in the file's {room} bytes; not written")
        pad = b" " * max(0, st.st_size - len(data))
        at = len(data) if pad_at is None else pad_at % len(data)
        data = bytes(data[:at]) + pad + bytes(data[at:])
        view, at = memoryview(data), 0
        while at < len(view):
            at += os.pwrite(fd, view[at:at + (1 << 20)], at)
        os.fsync(fd)
    except WriteError:
        raise
    except OSError as e:
        raise WriteError(f"{shown}: cannot write: {e.strerror or e}") from None
    finally:
        os.close(fd)
