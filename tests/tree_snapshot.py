"""A folder tree's snapshot, to show that a run wrote nothing where it must not (tests/test_hostile_batch.py,
benchmarks/hostile_issue21.py)."""
from __future__ import annotations

import hashlib
import os
import stat
from pathlib import Path


def snapshot(root: Path, skip: Path | None = None, *, mtimes: bool = False) -> dict:
    """Every entry under ``root`` (not following links, not opening FIFOs): path -> (kind, content hash or link
    target[, a file's mtime in ns with ``mtimes``]); ``skip`` (a folder) left out."""
    out = {}
    for folder, dirs, files in os.walk(root):
        if skip is not None and Path(folder).resolve() == Path(skip).resolve():
            dirs[:] = []
            continue
        for name in dirs + files:
            p = os.path.join(folder, name)
            st = os.lstat(p)
            if stat.S_ISLNK(st.st_mode):
                out[p] = ("link", os.readlink(p))
            elif stat.S_ISREG(st.st_mode):
                with open(p, "rb") as f:
                    digest = hashlib.sha256(f.read()).hexdigest()
                out[p] = ("file", digest, st.st_mtime_ns) if mtimes else ("file", digest)
            else:
                out[p] = ("dir" if stat.S_ISDIR(st.st_mode) else "other", None)
    return out
