"""StaggerEditor slider moves with the contact layer on vs off (issue 20: "slider moves <= 50 ms CPU warm on
900 frames with the layer on"), in one process.

Clip: the first 900 frames of CMU 01_01 (data/cmu_01_01.bvh, 31 joints, 120 Hz). Two editors, built the same
way (``precompute=False``), one with ``model.keep_contacts = True``; each is warmed (extraction, the first
replay, the layer's cached source tables), then its ``l`` slider is moved through the same 12 values
(``s = 0.03``, ``tau = 0.06``: a succession + random-timing edit) and each move's CPU time is taken
(``time.process_time``: the model's replay, the layer and the editor's redraw, no browser). Prints min / median
per move for both editors, the ratio on / off, and the layer alone (``staggered.keep_contacts`` on the same
edit) against ``staggered.evaluate``.

Run: ``OPENBLAS_NUM_THREADS=1 PYTHONPATH=$PWD nice .venv/bin/python benchmarks/bench_plants_slider.py``.
"""
from __future__ import annotations

import os
import statistics
import sys
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import stagger_nb as sn
from stagger_nb import staggered
from stagger_nb.core.body import pelvis_joint

GOAL_MS = 50.0
VALUES = [1.0 + 0.1 * i for i in range(12)]


def cpu(fn) -> float:
    c = time.process_time()
    fn()
    return 1000 * (time.process_time() - c)


def editor(m, on: bool):
    from stagger_nb.widgets import StaggerEditor
    ed = StaggerEditor(m, precompute=False)
    ed.model.keep_contacts = on
    ed.model.s = 0.03
    ed.model.tau = 0.06
    for v in (0.9, 0.95):       # warm: the extraction, first replays, the layer's source tables
        ed.model.l = v
    return ed


def moves(ed) -> list[float]:
    out = []
    for v in VALUES:
        out.append(cpu(lambda v=v: setattr(ed.model, "l", v)))
    return out


def main() -> None:
    warnings.simplefilter("ignore", DeprecationWarning)
    m = sn.data.load("cmu_01_01").slice(0, 900)
    print(f"clip: cmu_01_01 frames 0-900 ({m.num_joints} joints); load average {os.getloadavg()[0]:.1f}")
    off, on = editor(m, False), editor(m, True)
    t_off, t_on = moves(off), moves(on)
    assert on.model.keep_contacts and not off.model.keep_contacts
    mo, mn = statistics.median(t_off), statistics.median(t_on)
    print(f"slider move, layer off  cpu min {min(t_off):6.1f} median {mo:6.1f} ms")
    print(f"slider move, layer on   cpu min {min(t_on):6.1f} median {mn:6.1f} ms   on/off x {mn / mo:.2f}   "
          f"[goal {GOAL_MS:.0f} ms] {'ok' if mn <= GOAL_MS else 'OVER'}")
    sm = staggered.extract(m)
    root = m.skeleton.names[pelvis_joint(m.skeleton)]
    e = staggered.random_timing(staggered.succession(sm, root=root, s=0.03, l=1.5), tau=0.06, seed=0)
    staggered.keep_contacts(e, m)
    ev = [cpu(lambda: staggered.evaluate(e)) for _ in range(8)]
    kc = [cpu(lambda: staggered.keep_contacts(e, m)) for _ in range(8)]
    print(f"evaluate alone          cpu median {statistics.median(ev):6.1f} ms")
    k, v = statistics.median(kc), statistics.median(ev)
    print(f"keep_contacts (incl. evaluate) median {k:6.1f} ms   x {k / v:.2f}")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
