"""Kernel CPU of ``SkeletonView.set_motion`` (an edit replacing the shown motion: its world points as one binary
buffer, the joint states, the rig path and the kernel's still picture of the merged mesh) on 900 frames of
CMU 01_01 (31 joints, with a ghost shown), no browser attached (serialisation not included).

Baseline, same process: building a new SkeletonView of the same motion. Prints CPU ms per call (min / median),
the ratio, bytes per edit, the widget models per view (``len(ipywidgets.Widget.widgets)`` before/after building
one, and per editor), and the load average.

Run: ``OPENBLAS_NUM_THREADS=1 PYTHONPATH=$PWD nice .venv/bin/python benchmarks/bench_set_motion.py``.
"""
from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np

import stagger_nb as sn
from stagger_nb.widgets import SkeletonView


def cpu(fn) -> float:
    c = time.process_time()
    fn()
    return 1000 * (time.process_time() - c)


def main() -> None:
    m = sn.data.load("cmu_01_01").slice(0, 900)
    print(f"clip: {m}; load average {os.getloadavg()[0]:.1f} at start")
    edits, rng = [], np.random.default_rng(0)
    for _ in range(14):   # same-shaped edits: every joint's rotation changes a little
        q = m.local_quats + 0.02 * rng.standard_normal(m.local_quats.shape)
        edits.append(m.replace(local_quats=q / np.linalg.norm(q, axis=-1, keepdims=True)))
    build = [cpu(lambda: SkeletonView(m, ghost=m)) for _ in range(4)]
    v = SkeletonView(m, ghost=m)
    for e in edits[:2]:
        v.set_motion(e)
    edit = [cpu(lambda e=e: v.set_motion(e, pose_frames=[10, 200], contacts=[("LeftFoot", 5, 40)]))
            for e in edits[2:]]
    b, s = statistics.median(build), statistics.median(edit)
    print(f"new SkeletonView   cpu min {min(build):6.1f} median {b:6.1f} ms")
    print(f"set_motion (edit)  cpu min {min(edit):6.1f} median {s:6.1f} ms   edit/new x {s / b:.2f}   "
          f"bytes {v.edit_bytes:,}")
    import warnings

    import ipywidgets

    from stagger_nb.widgets import StaggerEditor, WandEditor, WarpEditor
    warnings.simplefilter("ignore", DeprecationWarning)   # Widget.widgets: the public registry, deprecated name
    counts = {}
    for name, make in [("SkeletonView (ghost hidden)", lambda: SkeletonView(m, ghost=m, show_ghost=False)),
                       ("SkeletonView (ghost shown)", lambda: SkeletonView(m, ghost=m, show_ghost=True)),
                       ("StaggerEditor", lambda: StaggerEditor(m, precompute=False)),
                       ("WandEditor", lambda: WandEditor(m)), ("WarpEditor", lambda: WarpEditor(m))]:
        n0 = len(ipywidgets.Widget.widgets)
        make()
        counts[name] = len(ipywidgets.Widget.widgets) - n0
    print("widget models created:", ", ".join(f"{k} {v}" for k, v in counts.items()))
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
