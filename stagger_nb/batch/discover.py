"""Finding the clips of a batch and reading them: ``*.bvh`` files and CMU ``*.amc`` motions (with the ``*.asf``
of the same folder: ``NN.asf`` for ``NN_MM.amc``, else the folder's only ``.asf``), found recursively, in
sorted order; the SHA-256 of a clip's bytes keys the manifest. Clips are read and hashed under the package's
one input policy (:func:`stagger_nb.io._common.read_regular_file`): a FIFO, a device, a folder or a /proc file
named ``x.bvh`` (or a link to one) is a failed clip, never opened for a blocking read."""
from __future__ import annotations

import os

__all__ = ["find_clips", "read_clip"]


def _asf_for(amc: str) -> str | None:
    folder, name = os.path.split(amc)
    asfs = sorted(f for f in os.listdir(folder) if f.lower().endswith(".asf"))
    subject = name.split("_")[0].lower()
    for f in asfs:
        if os.path.splitext(f)[0].lower() == subject:
            return os.path.join(folder, f)
    return os.path.join(folder, asfs[0]) if len(asfs) == 1 else None


def find_clips(input_dir, exclude=None, *, unlisted: list | None = None) -> list[str]:
    """Relative paths (``/``-separated, sorted) of the ``.bvh`` and ``.amc`` files under ``input_dir``;
    ``exclude`` (a folder) is skipped, e.g. an output folder inside the input folder.

    A sub-folder that cannot be listed (permission denied) is never left out silently: with ``unlisted`` (a
    list) each is appended as ``(rel + "/", message)``; without it, ``ValueError`` naming it. ``input_dir``
    itself unlisted is a ``ValueError``."""
    root = os.path.abspath(os.fspath(input_dir))
    if not os.path.isdir(root):
        raise ValueError(f"input_dir: {input_dir} is not a folder")
    skip = os.path.realpath(exclude) if exclude is not None else None
    found, errors = [], []

    def listing_failed(e: OSError) -> None:
        path = e.filename if isinstance(e.filename, str) else root
        errors.append((path, f"folder {path}: cannot list: {e.strerror or e}"))

    for folder, dirs, files in os.walk(root, onerror=listing_failed):
        dirs[:] = sorted(d for d in dirs if not d.startswith(".")
                         and os.path.realpath(os.path.join(folder, d)) != skip)
        for f in files:
            if f.lower().endswith((".bvh", ".amc")) and not f.startswith("."):
                found.append(os.path.relpath(os.path.join(folder, f), root).replace(os.sep, "/"))
    for path, message in errors:
        if os.path.abspath(path) == root:
            raise ValueError(f"input_dir: {message}")
        if unlisted is None:
            raise ValueError(message)
        unlisted.append((os.path.relpath(path, root).replace(os.sep, "/") + "/", message))
    return sorted(found)


def read_clip(path: str):
    """The Motion of a ``.bvh`` file, or of a ``.amc`` file with its folder's ``.asf``."""
    from ..io import read_asf_amc, read_bvh
    if path.lower().endswith(".amc"):
        asf = _asf_for(path)
        if asf is None:
            raise ValueError(f"{path}: no .asf skeleton beside it (NN.asf for NN_MM.amc, or one .asf)")
        return read_asf_amc(asf, path)
    return read_bvh(path)


def clip_sha256(path: str) -> str:
    """SHA-256 of the clip's bytes (a regular file within the input size limit; ``ValueError`` naming it)."""
    from ..io._common import sha256_regular_file
    return sha256_regular_file(path, what="clip")
