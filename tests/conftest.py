"""Shared test fixtures: the real clips in ../shared/mocap (when present) and small hand-built motions."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
# ../shared/mocap beside the repository; STAGGER_NB_SHARED_MOCAP (or STAGGER_NB_MOCAP) points elsewhere
# (e.g. from a git worktree)
SHARED_MOCAP = Path(os.environ.get("STAGGER_NB_SHARED_MOCAP") or os.environ.get("STAGGER_NB_MOCAP")
                    or REPO.parent / "shared" / "mocap")
SHARED_CLIPS = sorted(p.name for p in SHARED_MOCAP.glob("*.bvh")) if SHARED_MOCAP.is_dir() else []


def shared_clip_path(name: str) -> Path:
    """Path of a real clip in ../shared/mocap; skips the test (with the reason) where it is absent."""
    p = SHARED_MOCAP / name
    if not p.is_file():
        pytest.skip(f"../shared/mocap/{name} not present on this machine (real clips are not copied into the repo)")
    return p


@pytest.fixture(scope="session", autouse=True)
def _close_widgets_at_the_end():
    """Close every ipywidgets widget still open when the run ends. Open widgets stay registered with
    ipywidgets (so they are never collected) until the interpreter exits, where their ``__del__`` runs after
    ipywidgets' module state is gone and prints "Exception ignored in: Widget.__del__"."""
    yield
    import sys
    if "ipywidgets" in sys.modules:
        sys.modules["ipywidgets"].Widget.close_all()


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def shared_motion():
    """Loader with a cache: ``shared_motion("xia_angry_run.bvh") -> Motion`` (skips if absent)."""
    from stagger_nb import read_bvh

    cache = {}

    def load(name: str):
        if name not in cache:
            cache[name] = read_bvh(shared_clip_path(name))
        return cache[name]

    return load
