"""Long takes as exact as short ones, and how their cost grows (issue 25): a real clip tiled to 100,000 frames.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_long_exact.py [--sizes 10000,25000,50000,100000]

A take made of copies of one real clip (``../shared/mocap/xia_neutral_walk.bvh``, 327 frames, 120 Hz, tiled and
F rounded to whole copies; ``--cut`` cuts at F) holds the clip's poses only, so with the default
``distinct=True`` its graph is the graph of the clip's distinct poses (:func:`stagger_nb.wand.greens.pose_graph`).
Nearly the same
graph comes from the short take of three copies (981 frames; the seams join the clip's last pose to its first
as in the long one): its falloff of the frame at the same place in the clip is the reference for every F.  Per size: CPU
seconds of the graph (``pose_graph``), of the basis (default sigma) and of one falloff, the growth exponent
d log(cpu) / d log(F) against the previous size, and |w_long - w_short| over the long take's frames (each long
frame compared with the short frame at the same place in the clip) for 5 edited frames: max and mean.
Goal: the long take as exact as a short one — max |dw| at every size within 0.005 of the smallest size's (the
error does not grow with the length), growth <= 1.2 (about linear).  The short take is not the same graph to
round-off: its 2 seams carry 2/3 of a within-copy chain edge's weight, k copies' (k - 1) / k, so even whole
copies differ from it by a max 0.024-0.027 (mean 0.002), measured the same at 10,137 and 100,062 frames.  With ``--cut``
the last copy is partial, so the first poses of the clip occur once more than the others: a different graph
(node weights not all equal), measured 0.023-0.027 max |dw| at every size from 10,000 to 100,000 frames.
Baseline in the same process: the same three steps on the short take.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
SHARED = Path(os.environ.get("STAGGER_NB_SHARED_MOCAP") or REPO.parent / "shared" / "mocap")

import stagger_nb as sn
from stagger_nb import wand


def tiled(m, F):
    return sn.concatenate([m] * int(np.ceil(F / m.num_frames))).slice(0, F)


def run(m, frames):
    c0 = time.process_time()
    g = wand.pose_graph(m)
    c1 = time.process_time()
    b = g.basis()
    c2 = time.process_time()
    ws = [wand.greens_falloff(b, int(f)) for f in frames]
    c3 = time.process_time()
    return g, b, ws, (c1 - c0, c2 - c1, (c3 - c2) / len(frames))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="10000,25000,50000,100000")
    ap.add_argument("--cut", action="store_true", help="cut the take at F frames (a partial last copy)")
    args = ap.parse_args(argv)
    whole = not args.cut
    clip = sn.read_bvh(SHARED / "xia_neutral_walk.bvh")
    n = clip.num_frames
    short = sn.concatenate([clip] * 3)
    edited = [n + k * n // 5 for k in range(5)]                      # frames of the short take's middle copy
    _, _, w_short, cost0 = run(short, edited)
    print(f"clip xia_neutral_walk {n} frames; short take 3 copies = {short.num_frames} frames: graph {cost0[0]:.2f} s, "
          f"basis {cost0[1]:.2f} s, falloff {1e3 * cost0[2]:.1f} ms CPU; load {os.getloadavg()[0]:.1f}")
    print(f"{'F':>7s} {'method':>9s} {'graph s':>8s} {'basis s':>8s} {'falloff ms':>10s} {'growth':>6s} "
          f"{'max |dw|':>9s} {'mean |dw|':>9s}  goal")
    prev = None
    first_err = None
    for F in (int(s) for s in args.sizes.split(",")):
        F = max(3, int(round(F / n))) * n if whole else F
        m = tiled(clip, F)
        place = np.arange(F) % n                                       # the frame's place in the clip
        g, b, w_long, cost = run(m, edited)
        # the short take's frame at the same place (its middle copy; the first and last frames of the long take
        # sit at a take end like the short take's first / last copy)
        ref = place + n
        ref[:n] = np.arange(min(n, F))
        tail = F - (F // n) * n
        err = np.concatenate([np.abs(wl - ws[ref]) for wl, ws in zip(w_long, w_short)])
        tot = sum(cost)
        growth = np.log(tot / prev[1]) / np.log(F / prev[0]) if prev else float("nan")
        prev = (F, tot)
        first_err = err.max() if first_err is None else first_err
        good = err.max() <= first_err + 0.005 and (np.isnan(growth) or growth <= 1.2)
        print(f"{F:7d} {g.method:>9s} {cost[0]:8.2f} {cost[1]:8.2f} {1e3 * cost[2]:10.1f} {growth:6.2f} "
              f"{err.max():9.2e} {err.mean():9.2e}  {'ok' if good else 'MISSED'}  (last copy {tail} frames)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
