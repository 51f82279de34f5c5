"""Where the StaggerEditor's per-move replay spends its time (issue 11 "bare replay"), part by part.

Run: ``OPENBLAS_NUM_THREADS=1 nice .venv/bin/python benchmarks/bench_replay_parts.py``. Clip: CMU 01_01's
first 900 frames (``data/cmu_01_01.bvh``, or ``$STAGGER_NB_DATA``; skipped with a message if absent). The edit
is the editor's chain cull(60 %) -> exaggerate(0.3) -> succession(Hips, 0.03, 1.5) -> random_timing(0.06, 4).

Prints CPU ms per call of ``keep_contacts`` and of each function it calls (wrapped in this process: inclusive
times, nested ones counted in their callers too), then ``evaluate``'s own parts on the same edit: segment
coordinates, the per-sample Bezier (six slerps and three arcs), the gathers of per-pair controls, with the
sample and (segment, joint) pair counts. Baseline: ``evaluate`` alone in this process (the ratio column).
Read it as a profile for the next optimisation, not as a pass/fail figure; the load average is printed.
"""
from __future__ import annotations

import functools
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from stagger_nb import read_bvh, staggered
from stagger_nb.staggered import _kernels as K
from stagger_nb.staggered import evaluation as R
from stagger_nb.staggered import plants as C


def cpu(f, n=30):
    """Mean CPU ms of ``f()`` over ``n`` runs after one warm-up."""
    f()
    c = time.process_time()
    for _ in range(n):
        f()
    return 1000 * (time.process_time() - c) / n


def main():
    path = next((p for p in (REPO / "data" / "cmu_01_01.bvh",
                             Path(os.environ.get("STAGGER_NB_DATA", "")) / "cmu_01_01.bvh") if p.is_file()), None)
    if path is None:
        print("cmu_01_01.bvh not found (data/ or $STAGGER_NB_DATA): nothing measured")
        return
    m = read_bvh(path).slice(0, 900)
    sm = staggered.extract(m)
    culled = staggered.cull(sm, 60.0)
    held = staggered.exaggerate(culled, list(range(culled.num_poses)), 0.3)
    ed = staggered.random_timing(staggered.succession(held, root="Hips", s=0.03, l=1.5), tau=0.06, seed=4)
    print(f"# cmu_01_01 frames 0-900, K = {ed.num_poses} after cull(60 %); load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores")
    t_ev = cpu(lambda: staggered.evaluate(ed))
    acc: dict[str, float] = {}
    originals = []

    def wrap(mod, name):
        f = getattr(mod, name)
        originals.append((mod, name, f))

        @functools.wraps(f)
        def g(*a, **k):
            c = time.process_time()
            try:
                return f(*a, **k)
            finally:
                acc[name] = acc.get(name, 0.0) + time.process_time() - c
        setattr(mod, name, g)

    for name in ("_hold", "_fk_joints", "_fk_rows", "_source_tables", "_carried", "_plants", "_choose_shifts",
                 "_envelope", "_solve_rows", "_leg_ik", "_no_hyperextension", "_pivot", "_sample", "_sample_quats",
                 "_source_frames", "quat_mul", "slerp"):
        wrap(C, name)
    wrap(R, "evaluate")
    try:
        n = 30
        staggered.keep_contacts(ed, m)
        acc.clear()
        c = time.process_time()
        for _ in range(n):
            staggered.keep_contacts(ed, m)
        total = 1000 * (time.process_time() - c) / n
    finally:
        for mod, name, f in originals:
            setattr(mod, name, f)
    print(f"keep_contacts (incl. its evaluate)  {total:6.2f} ms cpu   ratio {total / t_ev:.2f} x "
          f"evaluate alone ({t_ev:.2f} ms)")
    for k, v in sorted(acc.items(), key=lambda x: -x[1]):
        print(f"  {k:<32} {1000 * v / n:6.2f} ms")
    # evaluate's parts, on the same samples evaluate computes (moving joints only)
    times = R.default_times(ed)
    static, _ = R.static_rotations(ed)
    mov = np.flatnonzero(~static)
    J, N = ed.num_joints, times.size
    seg, tn = R.segment_coordinates(R.knot_times(ed)[:, mov], times)
    idx = seg.reshape(-1) * J + np.tile(mov, N)
    t = tn.reshape(-1)
    R._rotations_at(ed.rotations, idx, t)              # fills the per-pair workspace rows read below
    W, n_s = K.WORK, t.size
    P = ed.tangents.shape[0] * J
    ctrl, arcp = W.get("ev_ctrl", (16, P)), W.get("ev_arcp", (9, P))
    c_ = K.take_cols_into(ctrl, idx, np.empty((16, n_s)))
    a_ = K.take_cols_into(arcp, idx, np.empty((9, n_s)))
    arc, tmp, z = np.empty((3, n_s)), np.empty(n_s), np.empty(n_s)
    s, w0, z4, o = np.empty(n_s), np.empty(n_s), np.empty((4, n_s)), np.empty((4, n_s))
    print(f"evaluate: {n_s} (frame, moving joint) samples of {mov.size}/{J} joints, {P} (segment, joint) pairs")
    for name, f in (("evaluate", lambda: staggered.evaluate(ed)),
                    ("  segment_coordinates", lambda: R.segment_coordinates(R.knot_times(ed)[:, mov], times)),
                    ("  _rotations_at (spline + displacement)", lambda: R._rotations_at(ed.rotations, idx, t)),
                    ("    gathers of pair controls (25 rows)", lambda: (K.take_cols_into(ctrl, idx, c_),
                                                                         K.take_cols_into(arcp, idx, a_))),
                    ("    bezier_into (6 slerps + 3 arcs)", lambda: K.bezier_into(
                        c_[0:4], c_[4:8], c_[8:12], c_[12:16], t, (a_[0:3], a_[3:6], a_[6:9]), tag="bp_",
                        normalize=False)),
                    ("      one slerp_into", lambda: K.slerp_into(c_[0:4], c_[4:8], t, a_[0:3], o, s, w0, z, z4)),
                    ("      one arc_into", lambda: K.arc_into(c_[0:4], c_[4:8], arc, tmp, z)),
                    ("  root_positions_at", lambda: R.root_positions_at(ed, times))):
        ms = cpu(f)
        print(f"{name:<44} {ms:6.2f} ms cpu   ratio {ms / t_ev:.2f} x evaluate alone")
    print(f"# load average at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
