"""Shared test fixtures: the real clips in ../shared/mocap (when present) and small hand-built motions."""
from __future__ import annotations

import os
import select
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


@pytest.fixture(scope="module")
def _server(tmp_path_factory):
    """One JupyterLab for a browser test module (tests/browser_harness.py: free port, state in its own folder, the
    preferred kernel started without a "Select Kernel" dialog); started only by a module whose tests use ``lab``."""
    import browser_harness as bh
    with bh.shared_lab(tmp_path_factory) as server:
        yield server


@pytest.fixture
def lab(_server):
    """(url, folder, runtime_dir) of the module's JupyterLab; each test's kernels are shut down after it."""
    import browser_harness as bh
    with bh.lab_for_test(_server) as lab:
        yield lab


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


def run_forked(body, timeout: float = 60) -> tuple[str, int]:
    """Run ``body(send)`` in a forked child, ``send(text)`` passing text to the parent at once: ``(all text,
    waitpid status)``. A child silent for ``timeout`` s (a blocking read of a FIFO) is killed and fails the
    test with what it sent last; a crash (SIGSEGV) shows in the status."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        try:
            body(lambda text: os.write(w, text.encode("utf-8", "backslashreplace")))
        finally:
            os._exit(0)
    os.close(w)
    chunks = []
    try:
        while True:
            ready, _, _ = select.select([r], [], [], timeout)
            if not ready:
                os.kill(pid, 9)
                os.waitpid(pid, 0)
                pytest.fail(f"the child sent nothing for {timeout} s after {b''.join(chunks)[-300:]!r}")
            chunk = os.read(r, 1 << 16)
            if not chunk:
                break
            chunks.append(chunk)
    finally:
        os.close(r)
    return b"".join(chunks).decode("utf-8"), os.waitpid(pid, 0)[1]
