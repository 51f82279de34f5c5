"""The contact layer at other slider positions than the timing presets (issue "Edits an animator would keep"):
pose culling x exaggeration x a moderate timing edit, layer on, on every clip of bench_edit_quality.py.

Cells: keep {100, 50, 90} % of the poses (``staggered.cull``) x ``w_r`` {0, 0.5} (``staggered.exaggerate`` of
every pose against the previous one) x succession from the pelvis (s = 0.03, l = 2) + random timing (tau = 0.1,
seed 0); judged by ``sn.quality.compare(..., baseline=<the same edit without the layer>, bounds="moderate")``.
Prints one row per cell (travel, height, floor, pelvis vs no layer, added pop, the failures) and the counts:
cells meeting every goal, cells whose feet are held (travel <= 2 cm). Session 11's figures (a lead's script,
re-written here): 79 / 102 and 101 / 102.

Run: STAGGER_NB_SHARED_MOCAP=../shared/mocap OPENBLAS_NUM_THREADS=1 PYTHONPATH=$PWD \
     python benchmarks/bench_plants_cull_sweep.py [--clip SUBSTRING]
"""
from __future__ import annotations

import argparse

import bench_edit_quality as bench

import stagger_nb as sn
from stagger_nb import staggered
from stagger_nb.core.body import pelvis_joint

KEEP = (100, 50, 90)
W_R = (0.0, 0.5)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--clip", help="only clips whose name contains this")
    a = ap.parse_args()
    ok = held = n = 0
    for name, load in bench.clips(a.clip):
        m = load()
        sm0 = staggered.extract(m)
        root = m.skeleton.names[pelvis_joint(m.skeleton)]
        for percent in KEEP:
            smc = sm0 if percent == 100 else staggered.cull(sm0, percent=percent)
            for w_r in W_R:
                sm = staggered.exaggerate(smc, list(range(smc.num_poses)), w_r=w_r) if w_r else smc
                e = staggered.random_timing(staggered.succession(sm, root=root, s=0.03, l=2.0), tau=0.1, seed=0)
                off = staggered.evaluate(e)
                r = sn.quality.compare(m, staggered.keep_contacts(e, m), staggered=e, baseline=off,
                                       bounds="moderate")
                n += 1
                ok += r.ok
                held += r.foot_travel <= 2.0
                print(f"{name[:26]:26s} keep {percent:3d} w_r {w_r:.1f}  travel {r.foot_travel:5.2f} height "
                      f"{r.foot_height:5.2f} floor {r.floor:5.2f} p-off {r.pelvis_vs_baseline:5.2f} pop "
                      f"{r.added_pop:5.1f} {'ok' if r.ok else '; '.join(r.failures)}", flush=True)
    print(f"cells {n}: meet every goal {ok}, feet held (travel <= 2 cm) {held}")


if __name__ == "__main__":
    main()
